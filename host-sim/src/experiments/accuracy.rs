//! The number that matters: lumped vs. line-corrected error through the firmware's channel.

use super::*;

/// Error of one method at one frequency on the 20 mm/s trapezoid.
#[derive(Clone, Copy, Debug)]
pub struct Accuracy {
    /// Excitation frequency, Hz.
    pub freq_hz: f64,
    /// Lumped reading: RMS, max error (pF), RMS, max (%), undershoot (pF).
    pub lumped: [f64; 5],
    /// Line-corrected reading: the same.
    pub corrected: [f64; 5],
    /// Readings where the inversion gave no result.
    pub corrected_missing: usize,
    /// Number of readings.
    pub readings: usize,
}

pub(super) fn errors(rs: &[Reading], v: impl Fn(&Reading) -> f64 + Copy) -> ([f64; 5], usize) {
    let (rms, mx, bad) = rms_max(rs.iter().map(|r| pf(v(r) - r.c_true)));
    let (rrms, rmx, _) = rms_max(rs.iter().map(|r| 100.0 * (v(r) / r.c_true - 1.0)));
    let u = undershoot(first_period(rs), v);
    ([rms, mx, rrms, rmx, pf(u)], bad)
}

/// The number that matters: capacitance error against the truth on the
/// 20 mm/s trapezoid, through the firmware's code path (front end, ADC,
/// the firmware's channel), lumped vs. line-corrected, at the firmware's
/// frequencies nearest to 500 Hz, 2 kHz and 6 kHz (586, 1953, 5859 Hz).
pub fn accuracy(ctx: &Ctx) -> Result<(String, Vec<Accuracy>)> {
    let mut jobs: Vec<Job<(f64, Vec<Reading>)>> = vec![];
    for f in FREQS {
        let seed = ctx.seed ^ (f as u64 * 17 + 3);
        jobs.push(Box::new(move || (f, dynamic(ctx, 20.0, f, Meter::ADC, seed))));
    }
    let runs = parallel(jobs);
    let mut md = String::from(
        "### Capacitance error against the truth, 20 mm/s trapezoid, front end + ADC + the firmware's channel\n\n\
         | f | reading | RMS | max | RMS | max | undershoot | rejected |\n|---:|---|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut out = vec![];
    let mut panels = vec![];
    for (f, rs) in &runs {
        write_trace(&ctx.path(&format!("adc_20mmps_{f:.0}hz.csv")), rs, true)?;
        let (lumped, _) = errors(rs, |r| r.cs);
        let (corrected, missing) = errors(rs, |r| r.c_corr);
        for (name, e, bad) in [("lumped", lumped, 0), ("line-corrected", corrected, missing)] {
            writeln!(
                md,
                "| {} Hz | {name} | {:.2} pF | {:.2} pF | {:.2} % | {:.2} % | {:.2} pF | {bad} of {} |",
                rs[0].freq_hz.round(),
                e[0],
                e[1],
                e[2],
                e[3],
                e[4],
                rs.len()
            )?;
        }
        out.push(Accuracy {
            freq_hz: rs[0].freq_hz,
            lumped,
            corrected,
            corrected_missing: missing,
            readings: rs.len(),
        });
        panels.push(Panel {
            title: format!("{:.0} Hz", rs[0].freq_hz),
            x_label: "time [s]".into(),
            y_label: "C [pF]".into(),
            log_x: false,
            series: vec![
                Series::new("truth", rs.iter().map(|r| (r.t, pf(r.c_true))).collect()),
                Series::dashed("lumped Cs", rs.iter().map(|r| (r.t, pf(r.cs))).collect()),
                Series::new(
                    "line-corrected C",
                    rs.iter()
                        .filter(|r| r.c_corr.is_finite())
                        .map(|r| (r.t, pf(r.c_corr)))
                        .collect(),
                ),
            ],
        });
    }
    figure(
        &ctx.path("accuracy_20mmps.svg"),
        "Lumped vs. line-corrected capacitance, 20 mm/s (ADC + the firmware's channel)",
        &panels,
    )?;
    Ok((md, out))
}
