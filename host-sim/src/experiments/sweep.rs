//! The static frequency sweep (Fig. 7).

use super::*;

/// Log-spaced frequencies of the static sweep (500 Hz – 30 kHz, as Fig. 7).
pub fn sweep_freqs() -> Vec<f64> {
    (0..=24).map(|k| 500.0 * (60f64).powf(k as f64 / 24.0)).collect()
}

/// One stretch of the static sweep: stretch (mm), the sensor, (f Hz, Cs pF).
pub(super) type SweepAt = (f64, Sensor, Vec<(f64, f64)>);

/// Write `sweep.csv`: the LCR meter over [`sweep_freqs`] on the static
/// sensor at 0, 15 and 30 mm (with a `c_true_pf` column if `truth`).
pub(super) fn write_sweep(ctx: &Ctx, truth: bool) -> Result<Vec<SweepAt>> {
    let mut rng = Rng::new(ctx.seed ^ 7);
    let mut w = csv::Writer::from_path(ctx.path("sweep.csv"))?;
    let mut head = STATIC_HEADER.to_vec();
    if truth {
        head.push("c_true_pf");
    }
    w.write_record(&head)?;
    let mut out = vec![];
    for s_mm in [0.0, 15.0, 30.0] {
        let s = static_sensor(ctx.sensor, s_mm);
        let tr = s.truth();
        let mut pts = vec![];
        for f in sweep_freqs() {
            let (cs, rs) = lcr(&s, f, &mut rng);
            let mut row = vec![
                format!("{s_mm}"),
                format!("{f:.1}"),
                format!("{:.4}", pf(cs)),
                format!("{rs:.0}"),
                format!("{:.0}", tr.r_top_ohm),
                format!("{:.0}", tr.r_bottom_ohm),
            ];
            if truth {
                row.push(format!("{:.4}", pf(tr.c_farad)));
            }
            w.write_record(&row)?;
            pts.push((f, pf(cs)));
        }
        out.push((s_mm, s, pts));
    }
    w.flush()?;
    Ok(out)
}

/// Fig. 7: static frequency sweep at 0, 15 and 30 mm.
pub fn sweep(ctx: &Ctx) -> Result<String> {
    let mut series = vec![];
    let mut md = String::from("### Static frequency sweep (Fig. 7)\n\n| stretch | C true | Cs 500 Hz | Cs 6 kHz | 6 kHz vs 500 Hz |\n|---:|---:|---:|---:|---:|\n");
    for (s_mm, s, pts) in write_sweep(ctx, true)? {
        let at = |f: f64| pf(series_cs(s.impedance(f), f));
        let (c500, c6k) = (at(500.0), at(6000.0));
        writeln!(
            md,
            "| {s_mm} mm | {:.2} pF | {c500:.2} pF | {c6k:.2} pF | {:+.1} % |",
            pf(s.truth().c_farad),
            100.0 * (c6k / c500 - 1.0)
        )?;
        series.push(Series::new(format!("{s_mm} mm"), pts));
    }
    figure(
        &ctx.path("fig7_sweep.svg"),
        "Lumped capacitance of the static sensor vs. excitation frequency (Fig. 7)",
        &[Panel {
            title: "series Cs read through one sensor end".into(),
            x_label: "excitation frequency [Hz]".into(),
            y_label: "Cs [pF]".into(),
            log_x: true,
            series,
        }],
    )?;
    Ok(md)
}
