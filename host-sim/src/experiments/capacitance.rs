//! The LCR meter's dynamic runs (Fig. 10).

use super::*;

/// The LCR-meter runs at every rate and frequency of the paper, in parallel.
pub fn lcr_runs(ctx: &Ctx) -> Vec<Run> {
    let mut jobs: Vec<Job<Run>> = vec![];
    for rate in RATES {
        for f in FREQS {
            let seed = ctx.seed ^ (rate as u64 * 131 + f as u64);
            jobs.push(Box::new(move || Run {
                rate,
                freq_hz: f,
                readings: dynamic(ctx, rate, f, ctx.lcr, seed),
            }));
        }
    }
    parallel(jobs)
}

/// Fig. 10: lumped capacitance at 500 Hz, 2 kHz and 6 kHz, 10 and 20 mm/s,
/// read by the LCR meter; returns the summary and the traces.
pub fn capacitance(ctx: &Ctx) -> Result<(String, Vec<Run>)> {
    let runs = lcr_runs(ctx);
    let mut md = String::from("### Lumped capacitance under periodic stretching (Fig. 10, LCR meter)\n\n| rate | f | Cs at rest | undershoot |\n|---:|---:|---:|---:|\n");
    let mut panels = vec![];
    for rate in RATES {
        let mut series = vec![];
        for Run {
            rate: r,
            freq_hz: f,
            readings: rs,
        } in runs.iter().filter(|x| x.rate == rate)
        {
            write_trace(&ctx.path(&format!("trace_{r:.0}mmps_{f:.0}hz.csv")), rs, true)?;
            let u = undershoot(first_period(rs), |x| x.cs);
            writeln!(
                md,
                "| {r} mm/s | {f} Hz | {:.1} pF | {:.1} pF |",
                pf(rs[0].cs),
                pf(u)
            )?;
            series.push(Series::dashed(
                format!("Cs {f} Hz"),
                rs.iter().map(|x| (x.t, pf(x.cs))).collect(),
            ));
        }
        let rs = &runs.iter().find(|x| x.rate == rate).expect("run").readings;
        series.push(Series::new(
            "C true",
            rs.iter().map(|x| (x.t, pf(x.c_true))).collect(),
        ));
        panels.push(Panel {
            title: format!("{rate} mm/s"),
            x_label: "time [s]".into(),
            y_label: "C [pF]".into(),
            log_x: false,
            series,
        });
    }
    figure(
        &ctx.path("fig10_capacitance.svg"),
        "Lumped capacitance under the paper's trapezoid (Fig. 10)",
        &panels,
    )?;
    Ok((md, runs))
}
