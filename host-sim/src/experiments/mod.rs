//! The paper's experiments on the simulated skin, each writing CSV (the
//! interchange format of `docs/data-format.md`, plus truth columns the
//! readers ignore), an SVG figure, and a markdown summary.

mod accuracy;
mod capacitance;
mod claims;
mod consistency;
mod dataset;
mod elements;
mod resistance;
mod sweep;
mod writers;

pub use accuracy::{accuracy, Accuracy};
pub use capacitance::{capacitance, lcr_runs};
pub use claims::{
    compare, fig13_order, misses, parse_claims, predict_paper, provenance, provenance_table, table, Claim,
    Known, Outcome, CLAIMS_CSV,
};
pub use consistency::{consistency, Mechanism};
pub use dataset::{dataset, dense_trace};
pub use elements::{calibration, elements};
pub use resistance::resistance;
pub use sweep::{sweep, sweep_freqs};
pub use writers::{write_trace, write_trace_to};

use crate::chain::{self, undershoot, Meter, Reading};
use crate::dataset::{STATIC_HEADER, TRACE_HEADER};
use crate::numerics::{rms_max, series_cs};
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

pub(super) fn pf(c: f64) -> f64 {
    c * 1e12
}

/// A static sensor at `stretch` mm in the electrodes' steady state.
pub(super) fn static_sensor(p: SensorParams, stretch: f64) -> Sensor {
    // At its static resistances; a millisecond to take the stretch.
    let mut s = Sensor::at_static(p);
    s.advance(&Profile::Constant(stretch), 1e-3);
    s
}

/// The prior of the line correction: the rest capacitance as a static
/// 500 Hz calibration reads it (biased low by ~0.5 %, which is harmless:
/// the prior only picks between lines tens of percent apart).
pub fn rest_calibration(p: SensorParams) -> f64 {
    let s = static_sensor(p, 0.0);
    series_cs(s.impedance(500.0), 500.0)
}

/// Series reading of an ideal meter at `f` on `s`.
pub(super) fn lcr(s: &Sensor, f: f64, rng: &mut Rng) -> (f64, f64) {
    let z = s.impedance(f);
    let cs = series_cs(z, f);
    (
        cs * (1.0 + 2e-4 * rng.gaussian()) + 0.02e-12 * rng.gaussian(),
        z.re * (1.0 + 2e-4 * rng.gaussian()),
    )
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
        lead_ratio: ctx.sensor.effects.statics().lead_ratio(),
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
pub(super) type Job<'a, T> = Box<dyn FnOnce() -> T + Send + 'a>;

/// One dynamic run: its rate, frequency and readings.
pub struct Run {
    /// Stretch rate, mm/s.
    pub rate: f64,
    /// Requested excitation frequency, Hz.
    pub freq_hz: f64,
    /// The readings.
    pub readings: Vec<Reading>,
}

/// Run `jobs` in parallel on the available cores, keeping their order.
pub(super) fn parallel<T: Send>(jobs: Vec<Job<T>>) -> Vec<T> {
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
pub(super) fn first_period(rs: &[Reading]) -> &[Reading] {
    let n = rs.iter().position(|r| r.t >= 10.0).unwrap_or(rs.len());
    &rs[..n]
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
    let cal = calibration(ctx)?;
    md += &elements(ctx, &runs, &cal)?;
    let claims = parse_claims(CLAIMS_CSV)?;
    let outcomes = compare(ctx, &claims, &runs, &cal)?;
    md += "\n";
    md += &table(&outcomes);
    md += "\n";
    md += &provenance_table(&ctx.sensor);
    ctx.progress.set_message("accuracy, ADC chain");
    let (m, acc) = accuracy(ctx)?;
    md += "\n";
    md += &m;
    ctx.progress.finish_and_clear();
    std::fs::write(ctx.path("summary.md"), &md)?;
    Ok((md, acc))
}
