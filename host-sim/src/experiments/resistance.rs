//! Electrode resistance: settling and steady state (Fig. 8, 9).

use super::*;
use skin_sim::sensor::Truth;

/// Fig. 8 and 9: electrode resistance approaching a steady state, and in
/// steady state at 10 and 20 mm/s: each figure a run, its CSV, its rows
/// of the summary and its panels, in the order the paper gives them.
pub fn resistance(ctx: &Ctx) -> Result<String> {
    let (settled, mut panels) = settling(ctx)?;
    let mut md = String::from("### Electrode resistance (Fig. 8, 9)\n\n");
    writeln!(
        md,
        "A rested sensor cycled at 10 mm/s settles to within 3 % of its steady state after {settled:.0} s.\n"
    )?;
    md.push_str("| rate | R top at rest | peak | peak at stretch | R top at 30 mm (end of hold) |\n|---:|---:|---:|---:|---:|\n");
    for rate in RATES {
        let (row, panel) = steady_state(ctx, rate)?;
        md.push_str(&row);
        panels.push(panel);
    }
    figure(
        &ctx.path("fig8_9_resistance.svg"),
        "Electrode resistance under periodic stretching",
        &panels,
    )?;
    Ok(md)
}

/// Fig. 8: a rested sensor cycled at 10 mm/s for 10 minutes, to CSV;
/// when its resting R top comes within 3 % of its last (s), and its
/// panel.
fn settling(ctx: &Ctx) -> Result<(f64, Vec<Panel>)> {
    let mut s = Sensor::rested(ctx.sensor);
    let p = Profile::paper(10.0);
    let mut w = csv::Writer::from_path(ctx.path("resistance_settling.csv"))?;
    w.write_record(["time_s", "stretch_mm", "r_top_ohm", "r_bottom_ohm"])?;
    let (mut pts, mut rest_vals) = (vec![], vec![]);
    let mut t = 0.0;
    while t <= 600.0 {
        s.advance(&p, t);
        let tr = s.truth();
        write_row(&mut w, t, &tr)?;
        pts.push((t, tr.r_top_ohm / 1e3));
        // Resting value just before each stretch.
        if (t % 10.0 - 9.9).abs() < 1e-6 {
            rest_vals.push((t, tr.r_top_ohm));
        }
        ctx.progress.inc(0);
        t = ((t * 10.0).round() + 1.0) / 10.0;
    }
    w.flush()?;
    ctx.progress.inc(600);
    let last = rest_vals.last().map_or(f64::NAN, |v| v.1);
    let settled = rest_vals
        .iter()
        .find(|v| (v.1 / last - 1.0).abs() < 0.03)
        .map_or(f64::NAN, |v| v.0);
    let panel = Panel {
        title: "top electrode, rested sensor cycled at 10 mm/s (Fig. 8)".into(),
        x_label: "time [s]".into(),
        y_label: "R top [kΩ]".into(),
        log_x: false,
        series: vec![Series::new("R top", pts)],
    };
    Ok((settled, vec![panel]))
}

/// Fig. 9: one steady-state period at `rate` mm/s, to CSV; its row of
/// the summary and its panel.
fn steady_state(ctx: &Ctx, rate: f64) -> Result<(String, Panel)> {
    let mut s = Sensor::settled(ctx.sensor);
    let p = Profile::paper(rate);
    s.advance(&p, 20.0); // two periods to reach the periodic steady state
    let mut w = csv::Writer::from_path(ctx.path(&format!("resistance_{rate:.0}mmps.csv")))?;
    w.write_record(["time_s", "stretch_mm", "r_top_ohm", "r_bottom_ohm"])?;
    let (mut top, mut bot, mut st) = (vec![], vec![], vec![]);
    for k in 0..=1000 {
        let t = 20.0 + k as f64 * 0.01;
        s.advance(&p, t);
        let tr = s.truth();
        write_row(&mut w, t - 20.0, &tr)?;
        top.push((t - 20.0, tr.r_top_ohm / 1e3));
        bot.push((t - 20.0, tr.r_bottom_ohm / 1e3));
        st.push((t - 20.0, tr.stretch_mm));
    }
    w.flush()?;
    let peak = top
        .iter()
        .copied()
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    let s_at_peak = st.iter().find(|v| v.0 >= peak.0).map_or(f64::NAN, |v| v.1);
    let hold_end = top.iter().find(|v| v.0 >= 4.99).map_or(f64::NAN, |v| v.1);
    let row = format!(
        "| {rate} mm/s | {:.0} kΩ | {:.0} kΩ | {s_at_peak:.1} mm | {hold_end:.0} kΩ |\n",
        top[0].1, peak.1
    );
    let panel = Panel {
        title: format!("steady state at {rate} mm/s (Fig. 9)"),
        x_label: "time [s]".into(),
        y_label: "R [kΩ]".into(),
        log_x: false,
        series: vec![Series::new("R top", top), Series::new("R bottom", bot)],
    };
    Ok((row, panel))
}

/// One row of a resistance CSV at time `t` (s).
fn write_row<W: std::io::Write>(w: &mut csv::Writer<W>, t: f64, tr: &Truth) -> Result<()> {
    w.write_record([
        format!("{t:.2}"),
        format!("{:.3}", tr.stretch_mm),
        format!("{:.0}", tr.r_top_ohm),
        format!("{:.0}", tr.r_bottom_ohm),
    ])?;
    Ok(())
}
