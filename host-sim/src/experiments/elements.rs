//! The paper's n-element simulation against the measurement (Fig. 13, 14), and its static calibration (Fig. 11).

use super::*;

/// The paper's simulation (Fig. 6): C from the recorded stretch through a
/// static 500 Hz calibration, R = R_top + R_bottom as recorded, an n-element
/// ladder, read as a series meter would.
pub(super) fn paper_simulation(cal: &[(f64, f64)], r: &Reading, n: u8) -> f64 {
    let c = crate::numerics::lerp(cal, r.stretch_mm);
    LineModel::Ladder(n)
        .impedance((r.r_top + r.r_bottom) as f32, c as f32, r.freq_hz as f32)
        .ok()
        .and_then(|z| SeriesRc::from_impedance(z, r.freq_hz as f32).ok())
        .map_or(f64::NAN, |m| m.cs_farad as f64)
}

/// The static calibration: Cs at 500 Hz every 3 mm (Fig. 11).
pub fn calibration(ctx: &Ctx) -> Result<Vec<(f64, f64)>> {
    let mut rng = Rng::new(ctx.seed ^ 11);
    let mut w = csv::Writer::from_path(ctx.path("calibration.csv"))?;
    w.write_record(STATIC_HEADER)?;
    let mut cal = vec![];
    for k in 0..=10 {
        let s_mm = 3.0 * k as f64;
        let s = static_sensor(ctx.sensor, s_mm);
        let (cs, rs) = lcr(&s, 500.0, &mut rng);
        let tr = s.truth();
        w.write_record([
            format!("{s_mm}"),
            "500".into(),
            format!("{:.4}", pf(cs)),
            format!("{rs:.0}"),
            format!("{:.0}", tr.r_top_ohm),
            format!("{:.0}", tr.r_bottom_ohm),
        ])?;
        cal.push((s_mm, cs));
    }
    w.flush()?;
    Ok(cal)
}

/// Fig. 13 and 14: the paper's simulation with n = 1, 2, 4, 30 elements
/// against the (simulated) measurement, with the static calibration `cal`
/// ([`calibration`]).
pub fn elements(ctx: &Ctx, runs: &[Run], cal: &[(f64, f64)]) -> Result<String> {
    let meas = &runs
        .iter()
        .find(|x| x.rate == 10.0 && x.freq_hz == 6000.0)
        .context("10 mm/s 6 kHz run")?
        .readings;
    let mut md = String::from("### Number of elements (Fig. 13, 6 kHz, 10 mm/s) and simulation vs. measurement (Fig. 14)\n\n| n | RMS sim − meas | max |\n|---:|---:|---:|\n");
    let mut series = vec![Series::dashed(
        "measured",
        meas.iter().map(|r| (r.t, pf(r.cs))).collect(),
    )];
    for n in [1u8, 2, 4, 30] {
        let sim: Vec<f64> = meas.iter().map(|r| paper_simulation(cal, r, n)).collect();
        let (rms, mx, _) = rms_max(sim.iter().zip(meas).map(|(s, m)| pf(s - m.cs)));
        writeln!(md, "| {n} | {rms:.2} pF | {mx:.2} pF |")?;
        series.push(Series::new(
            format!("n = {n}"),
            meas.iter().zip(&sim).map(|(r, s)| (r.t, pf(*s))).collect(),
        ));
    }
    let mut panels = vec![Panel {
        title: "paper's simulation with n elements vs. measurement, 6 kHz, 10 mm/s (Fig. 13)".into(),
        x_label: "time [s]".into(),
        y_label: "Cs [pF]".into(),
        log_x: false,
        series,
    }];
    md.push_str("\n| rate | f | RMS n=30 sim − meas | relative |\n|---:|---:|---:|---:|\n");
    let mut series = vec![];
    for Run {
        rate,
        freq_hz: f,
        readings: rs,
    } in runs.iter().filter(|x| x.rate == 10.0)
    {
        let sim: Vec<f64> = rs.iter().map(|r| paper_simulation(cal, r, 30)).collect();
        let (rms, _, _) = rms_max(sim.iter().zip(rs).map(|(s, m)| pf(s - m.cs)));
        let (rel, _, _) = rms_max(sim.iter().zip(rs).map(|(s, m)| 100.0 * (s / m.cs - 1.0)));
        writeln!(md, "| {rate} mm/s | {f} Hz | {rms:.2} pF | {rel:.2} % |")?;
        series.push(Series::dashed(
            format!("m {f} Hz"),
            rs.iter().map(|r| (r.t, pf(r.cs))).collect(),
        ));
        series.push(Series::new(
            format!("s {f} Hz"),
            rs.iter().zip(&sim).map(|(r, s)| (r.t, pf(*s))).collect(),
        ));
    }
    panels.push(Panel {
        title: "n = 30 simulation (s) vs. measurement (m), 10 mm/s (Fig. 14)".into(),
        x_label: "time [s]".into(),
        y_label: "Cs [pF]".into(),
        log_x: false,
        series,
    });
    figure(
        &ctx.path("fig13_14_elements.svg"),
        "The paper's transmission-line simulation",
        &panels,
    )?;
    Ok(md)
}
