//! The paper's experiments on the simulated skin, each writing CSV (the
//! interchange format of `shared/data-format.md`, plus truth columns the
//! readers ignore), an SVG figure, and a markdown summary.

use crate::chain::{self, rms_max, undershoot, Meter, Reading};
use crate::dataset::{STATIC_HEADER, TRACE_HEADER};
use crate::plot::{figure, Panel, Series};
use anyhow::{Context, Result};
use dsp_core::lumped::SeriesRc;
use dsp_core::tline::LineModel;
use indicatif::{ProgressBar, ProgressStyle};
use instrument::effects::EffectSet;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Excitation frequencies of the paper's dynamic experiments, Hz.
pub const FREQS: [f64; 3] = [500.0, 2000.0, 6000.0];
/// Stretch rates of the paper, mm/s.
pub const RATES: [f64; 2] = [10.0, 20.0];

/// Where and how to run.
pub struct Ctx {
    /// Output folder.
    pub out: PathBuf,
    /// Sensor under test.
    pub sensor: SensorParams,
    /// Seed of all noise.
    pub seed: u64,
    /// Trapezoid periods per dynamic run.
    pub periods: u32,
    /// The LCR meter of the dynamic runs.
    pub lcr: Meter,
    /// Progress bar over simulated seconds (hidden when not a terminal).
    pub progress: ProgressBar,
}

impl Ctx {
    /// A context writing to `out`.
    pub fn new(out: impl Into<PathBuf>, seed: u64) -> Result<Self> {
        let out = out.into();
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
        Ok(Self {
            out,
            sensor: SensorParams::REFERENCE,
            seed,
            periods: 2,
            lcr: Meter::LCR,
            progress: ProgressBar::hidden(),
        })
    }

    /// Show a progress bar of `total` simulated seconds.
    pub fn with_progress(mut self, total: f64) -> Self {
        let pb = ProgressBar::new(total as u64);
        pb.set_style(
            ProgressStyle::with_template("{spinner} {msg:<28} [{bar:40}] {pos}/{len} s simulated, {eta}")
                .expect("template")
                .progress_chars("=> "),
        );
        self.progress = pb;
        self
    }

    fn path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }
}

fn pf(c: f64) -> f64 {
    c * 1e12
}

/// Write readings as a trace file of the interchange format, with the
/// truth and the line-corrected values as extra columns.
pub fn write_trace(path: &Path, rs: &[Reading], truth: bool) -> Result<()> {
    let file = std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
    write_trace_to(std::io::BufWriter::new(file), rs, truth)
}

/// [`write_trace`] to any writer.
pub fn write_trace_to(out: impl std::io::Write, rs: &[Reading], truth: bool) -> Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let mut head = TRACE_HEADER.to_vec();
    if truth {
        head.extend([
            "c_true_pf",
            "c_corrected_pf",
            "r_corrected_ohm",
            "r_line_ohm",
            "adc_clipped",
        ]);
    }
    w.write_record(&head)?;
    for r in rs {
        let mut row = vec![
            format!("{:.5}", r.t),
            format!("{:.4}", r.stretch_mm),
            format!("{:.0}", r.r_top),
            format!("{:.0}", r.r_bottom),
            format!("{}", r.freq_hz),
            format!("{:.4}", pf(r.cs)),
            format!("{:.0}", r.rs),
        ];
        if truth {
            let opt = |v: f64, s: String| if v.is_finite() { s } else { String::new() };
            row.extend([
                format!("{:.4}", pf(r.c_true)),
                opt(r.c_corr, format!("{:.4}", pf(r.c_corr))),
                opt(r.r_corr, format!("{:.0}", r.r_corr)),
                format!("{:.0}", r.r_line),
                format!("{}", r.clipped as u8),
            ]);
        }
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}

/// A static sensor at `stretch` mm in the electrodes' steady state.
fn static_sensor(p: SensorParams, stretch: f64) -> Sensor {
    let mut s = Sensor::settled(p);
    s.advance(&Profile::Constant(stretch), 0.5);
    s
}

/// The prior of the line correction: the rest capacitance as a static
/// 500 Hz calibration reads it (biased low by ~0.5 %, which is harmless:
/// the prior only picks between lines tens of percent apart).
pub fn rest_calibration(p: SensorParams) -> f64 {
    let s = static_sensor(p, 0.0);
    -1.0 / (std::f64::consts::TAU * 500.0 * s.impedance(500.0).im)
}

/// Series reading of an ideal meter at `f` on `s`.
fn lcr(s: &Sensor, f: f64, rng: &mut Rng) -> (f64, f64) {
    let z = s.impedance(f);
    let cs = -1.0 / (std::f64::consts::TAU * f * z.im);
    (
        cs * (1.0 + 2e-4 * rng.gaussian()) + 0.02e-12 * rng.gaussian(),
        z.re * (1.0 + 2e-4 * rng.gaussian()),
    )
}

/// Log-spaced frequencies of the static sweep (500 Hz – 30 kHz, as Fig. 7).
pub fn sweep_freqs() -> Vec<f64> {
    (0..=24).map(|k| 500.0 * (60f64).powf(k as f64 / 24.0)).collect()
}

/// One stretch of the static sweep: stretch (mm), the sensor, (f Hz, Cs pF).
type SweepAt = (f64, Sensor, Vec<(f64, f64)>);

/// Write `sweep.csv`: the LCR meter over [`sweep_freqs`] on the static
/// sensor at 0, 15 and 30 mm (with a `c_true_pf` column if `truth`).
fn write_sweep(ctx: &Ctx, truth: bool) -> Result<Vec<SweepAt>> {
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
        let at = |f: f64| pf(-1.0 / (std::f64::consts::TAU * f * s.impedance(f).im));
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

/// Fig. 8 and 9: electrode resistance approaching a steady state, and in
/// steady state at 10 and 20 mm/s.
pub fn resistance(ctx: &Ctx) -> Result<String> {
    // Fig. 8: a rested sensor cycled at 10 mm/s for 10 minutes.
    let mut s = Sensor::rested(ctx.sensor);
    let p = Profile::paper(10.0);
    let mut w = csv::Writer::from_path(ctx.path("resistance_settling.csv"))?;
    w.write_record(["time_s", "stretch_mm", "r_top_ohm", "r_bottom_ohm"])?;
    let (mut pts, mut rest_vals) = (vec![], vec![]);
    let mut t = 0.0;
    while t <= 600.0 {
        s.advance(&p, t);
        let tr = s.truth();
        w.write_record([
            format!("{t:.2}"),
            format!("{:.3}", tr.stretch_mm),
            format!("{:.0}", tr.r_top_ohm),
            format!("{:.0}", tr.r_bottom_ohm),
        ])?;
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
    // Fig. 9: one steady-state period at each rate.
    let mut panels = vec![Panel {
        title: "top electrode, rested sensor cycled at 10 mm/s (Fig. 8)".into(),
        x_label: "time [s]".into(),
        y_label: "R top [kΩ]".into(),
        log_x: false,
        series: vec![Series::new("R top", pts)],
    }];
    let mut md = String::from("### Electrode resistance (Fig. 8, 9)\n\n");
    writeln!(
        md,
        "A rested sensor cycled at 10 mm/s settles to within 3 % of its steady state after {settled:.0} s.\n"
    )?;
    md.push_str("| rate | R top at rest | peak | peak at stretch | R top at 30 mm (end of hold) |\n|---:|---:|---:|---:|---:|\n");
    for rate in RATES {
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
            w.write_record([
                format!("{:.2}", t - 20.0),
                format!("{:.3}", tr.stretch_mm),
                format!("{:.0}", tr.r_top_ohm),
                format!("{:.0}", tr.r_bottom_ohm),
            ])?;
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
        writeln!(
            md,
            "| {rate} mm/s | {:.0} kΩ | {:.0} kΩ | {s_at_peak:.1} mm | {hold_end:.0} kΩ |",
            top[0].1, peak.1
        )?;
        panels.push(Panel {
            title: format!("steady state at {rate} mm/s (Fig. 9)"),
            x_label: "time [s]".into(),
            y_label: "R [kΩ]".into(),
            log_x: false,
            series: vec![Series::new("R top", top), Series::new("R bottom", bot)],
        });
    }
    figure(
        &ctx.path("fig8_9_resistance.svg"),
        "Electrode resistance under periodic stretching",
        &panels,
    )?;
    Ok(md)
}

/// Run one dynamic trace in steady state; readings of the last `periods`.
pub fn dynamic(ctx: &Ctx, rate: f64, f: f64, meter: Meter, seed: u64) -> Vec<Reading> {
    let mut s = Sensor::settled(ctx.sensor);
    let p = Profile::paper(rate);
    // Reach the periodic steady state first.
    s.advance(&p, 20.0 - meter.lookback_s());
    let t_end = 20.0 + 10.0 * ctx.periods as f64;
    let mut last = 20.0;
    let pb = ctx.progress.clone();
    let setup = chain::Setup {
        freq_hz: f,
        meter,
        model: LineModel::Continuous,
        prior_farad: rest_calibration(ctx.sensor),
        seed,
    };
    let mut rs = chain::run(&mut s, &p, setup, 20.0, t_end, |t| {
        if t - last >= 1.0 {
            pb.inc(1);
            last += 1.0;
        }
    });
    for r in rs.iter_mut() {
        r.t -= 20.0;
    }
    rs
}

/// A job for [`parallel`].
type Job<'a, T> = Box<dyn FnOnce() -> T + Send + 'a>;

/// One dynamic run: its rate, frequency and readings.
pub struct Run {
    /// Stretch rate, mm/s.
    pub rate: f64,
    /// Requested excitation frequency, Hz.
    pub freq_hz: f64,
    /// The readings.
    pub readings: Vec<Reading>,
}

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

/// Run `jobs` in parallel on the available cores, keeping their order.
fn parallel<T: Send>(jobs: Vec<Job<T>>) -> Vec<T> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut out: Vec<Option<T>> = (0..jobs.len()).map(|_| None).collect();
    let mut jobs: Vec<_> = jobs.into_iter().enumerate().collect();
    while !jobs.is_empty() {
        let batch: Vec<_> = jobs.drain(..cores.min(jobs.len())).collect();
        let done: Vec<(usize, T)> = std::thread::scope(|sc| {
            let hs: Vec<_> = batch
                .into_iter()
                .map(|(i, j)| sc.spawn(move || (i, j())))
                .collect();
            hs.into_iter()
                .map(|h| h.join().expect("worker panicked"))
                .collect()
        });
        for (i, v) in done {
            out[i] = Some(v);
        }
    }
    out.into_iter().map(|v| v.expect("job ran")).collect()
}

/// One period of readings (the first) for undershoot measurements.
fn first_period(rs: &[Reading]) -> &[Reading] {
    let n = rs.iter().position(|r| r.t >= 10.0).unwrap_or(rs.len());
    &rs[..n]
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

/// The paper's simulation (Fig. 6): C from the recorded stretch through a
/// static 500 Hz calibration, R = R_top + R_bottom as recorded, an n-element
/// ladder, read as a series meter would.
fn paper_simulation(cal: &[(f64, f64)], r: &Reading, n: u8) -> f64 {
    let c = interp(cal, r.stretch_mm);
    LineModel::Ladder(n)
        .impedance((r.r_top + r.r_bottom) as f32, c as f32, r.freq_hz as f32)
        .ok()
        .and_then(|z| SeriesRc::from_impedance(z, r.freq_hz as f32).ok())
        .map_or(f64::NAN, |m| m.cs_farad as f64)
}

fn interp(pts: &[(f64, f64)], x: f64) -> f64 {
    let k = pts.partition_point(|p| p.0 <= x).clamp(1, pts.len() - 1);
    let (a, b) = (pts[k - 1], pts[k]);
    a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
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
/// against the (simulated) measurement.
pub fn elements(ctx: &Ctx, runs: &[Run]) -> Result<String> {
    let cal = calibration(ctx)?;
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
        let sim: Vec<f64> = meas.iter().map(|r| paper_simulation(&cal, r, n)).collect();
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
        let sim: Vec<f64> = rs.iter().map(|r| paper_simulation(&cal, r, 30)).collect();
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

fn errors(rs: &[Reading], v: impl Fn(&Reading) -> f64 + Copy) -> ([f64; 5], usize) {
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

/// Write a data set in the interchange format (calibration, sweep and six
/// traces) for `params`, read by the LCR meter; no truth columns.
/// The recording's meter is `lcr` (its window and time offset).
pub fn dataset(dir: &Path, params: SensorParams, lcr: Meter, seed: u64, progress: ProgressBar) -> Result<()> {
    let ctx = Ctx {
        out: dir.to_path_buf(),
        sensor: params,
        lcr,
        seed,
        periods: 3,
        progress,
    };
    std::fs::create_dir_all(dir)?;
    calibration(&ctx)?;
    // The sweep at 0, 15, 30 mm, without the truth column.
    write_sweep(&ctx, false)?;
    for Run {
        rate,
        freq_hz: f,
        readings,
    } in lcr_runs(&ctx)
    {
        write_trace(
            &dir.join(format!("trace_{rate:.0}mmps_{f:.0}hz.csv")),
            &readings,
            false,
        )?;
    }
    Ok(())
}

/// Sensor parameters with `effects` switched on.
pub fn with_effects(effects: EffectSet) -> SensorParams {
    SensorParams {
        effects,
        ..SensorParams::REFERENCE
    }
}

/// Everything: all experiments into `ctx.out`, and `summary.md`.
pub fn paper(ctx: &Ctx) -> Result<(String, Vec<Accuracy>)> {
    let mut md = String::from("# The paper's experiments on the simulated skin\n\n");
    ctx.progress.set_message("frequency sweep (Fig. 7)");
    md += &sweep(ctx)?;
    ctx.progress.set_message("resistance (Fig. 8, 9)");
    md += "\n";
    md += &resistance(ctx)?;
    ctx.progress.set_message("capacitance (Fig. 10)");
    let (m, runs) = capacitance(ctx)?;
    md += "\n";
    md += &m;
    ctx.progress.set_message("elements (Fig. 13, 14)");
    md += "\n";
    md += &elements(ctx, &runs)?;
    ctx.progress.set_message("accuracy, ADC chain");
    let (m, acc) = accuracy(ctx)?;
    md += "\n";
    md += &m;
    ctx.progress.finish_and_clear();
    std::fs::write(ctx.path("summary.md"), &md)?;
    Ok((md, acc))
}
