//! `identify`: trace the residual of a measured data set to the effect the
//! uniform line lacks.
//!
//! 1. Baseline: the uniform line (the continuous limit, and the paper's
//!    n = 30 ladder for comparison), the recorded resistances, the
//!    calibration de-biased under the same model ([`crate::model`]).
//! 2. Residual (measured − model) per file; noise floor per file from the
//!    median absolute second difference of the baseline residual
//!    ([`noise_sigma`]).
//! 3. Every candidate effect of the library is fitted alone (grid over its
//!    range, then Levenberg–Marquardt, weighted by each file's noise).
//!    Models are compared by BIC = n·ln(S/n) + k·ln n (S: noise-weighted
//!    sum of squares, k: fitted parameters, n: rows). Forward selection: the
//!    best single effect by BIC; if it leaves the residual above the noise,
//!    the best pair containing it.
//! 4. An effect is accepted only with strong evidence (ΔBIC > 10 against
//!    the smaller model) *and* when the model with it explains the data
//!    (RMS ≤ [`Options::explained`] × noise floor). Otherwise the data set
//!    is reported as unexplained, with the best attempt kept apart.

//!
//! | module | what |
//! |---|---|
//! | `fit` | the weighted least-squares problem and its solver (grid, Levenberg–Marquardt, uncertainty) |
//! | `report` | the verdict, the markdown and JSON reports |
//! | `plot` | the residual figure ([`plot()`]) |

mod fit;
mod plot;
mod report;

pub use plot::plot;
pub use report::params_text;

use crate::baseline::noise_sigma;
use crate::dataset::{DataSet, Kind};
use crate::model::{Effect, Line, Params, Prepared};
use anyhow::{Context, Result};
use fit::Problem;
use indicatif::ProgressBar;

/// How `identify` decides.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Model the static sweep too (when the data set has one).
    pub sweep: bool,
    /// Explained: RMS within this factor of the noise floor.
    pub explained: f64,
    /// Strong evidence: BIC lower by at least this much.
    pub bic_margin: f64,
    /// Most effects combined.
    pub max_effects: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            sweep: true,
            explained: 1.5,
            bic_margin: 10.0,
            max_effects: 2,
        }
    }
}

/// Error of one file under one model.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FileError {
    /// File name.
    pub file: String,
    /// Rows.
    pub rows: usize,
    /// RMS of measured − model, pF.
    pub rms_pf: f64,
    /// Largest |measured − model|, pF.
    pub max_pf: f64,
    /// RMS relative to the measured Cs, %.
    pub rms_pct: f64,
    /// Largest relative error, %.
    pub max_pct: f64,
}

/// A fitted model.
#[derive(Clone, Debug)]
pub struct Fit {
    /// Line model.
    pub line: Line,
    /// Effects fitted (empty: the baseline).
    pub effects: Vec<Effect>,
    /// All parameters (fitted ones set).
    pub params: Params,
    /// 1σ uncertainty of each fitted parameter (same order as `effects`).
    pub sigma: Vec<f64>,
    /// Noise-weighted sum of squares.
    pub s: f64,
    /// Bayesian information criterion.
    pub bic: f64,
    /// Overall RMS, pF.
    pub rms_pf: f64,
    /// Overall max, pF.
    pub max_pf: f64,
    /// Overall RMS relative to the measured Cs, %.
    pub rms_pct: f64,
    /// Overall max relative error, %.
    pub max_pct: f64,
    /// Per file.
    pub files: Vec<FileError>,
    /// Residual (measured − model, pF) per file and row.
    pub residual: Vec<Vec<f64>>,
}

impl Fit {
    /// A label: the effects' ids joined by " + ".
    pub fn label(&self) -> String {
        if self.effects.is_empty() {
            format!("baseline ({})", self.line)
        } else {
            self.effects
                .iter()
                .map(|e| e.id())
                .collect::<Vec<_>>()
                .join(" + ")
        }
    }
}

/// The outcome.
#[derive(Clone, Debug)]
pub struct Report {
    /// Baselines: the continuous line (the base effects are added to),
    /// then the paper's n = 30 ladder.
    pub baselines: Vec<Fit>,
    /// Noise floor per file, pF.
    pub noise_pf: Vec<(String, f64)>,
    /// Overall noise floor (row-weighted RMS of the files' floors), pF.
    pub noise_floor_pf: f64,
    /// Single effects, best BIC first.
    pub singles: Vec<Fit>,
    /// Pairs tried (best BIC first; empty if a single effect explained).
    pub pairs: Vec<Fit>,
    /// The accepted model: effects found with strong evidence that explain
    /// the data (None: clean, or unexplained).
    pub accepted: Option<Fit>,
    /// The residual is above the noise and no candidate explains it.
    pub unexplained: bool,
    /// Rows modelled.
    pub rows: usize,
    /// Traces decimated to bound the work: (file, rows read, every k-th
    /// row kept).
    pub decimated: Vec<(String, usize, usize)>,
    /// Which electrode resistance the model used (the calibration's; the
    /// traces' where they differ).
    pub resistance: String,
    /// Options used.
    pub options: Options,
}

impl Report {
    /// The base model (the better baseline).
    pub fn baseline(&self) -> &Fit {
        &self.baselines[0]
    }

    /// The final model: the accepted one, or the baseline.
    pub fn final_fit(&self) -> &Fit {
        self.accepted.as_ref().unwrap_or(&self.baselines[0])
    }

    /// The best attempt when unexplained.
    pub fn best_attempt(&self) -> Option<&Fit> {
        if !self.unexplained {
            return None;
        }
        self.singles
            .iter()
            .chain(&self.pairs)
            .min_by(|a, b| a.bic.total_cmp(&b.bic))
    }
}

/// The fits of the candidate threads. A thread that panicked carries its
/// panic on: a candidate never vanishes from the report silently.
fn joined(hs: Vec<std::thread::ScopedJoinHandle<'_, Option<Fit>>>) -> Vec<Fit> {
    hs.into_iter()
        .filter_map(|h| match h.join() {
            Ok(fit) => fit,
            Err(panic) => std::panic::resume_unwind(panic),
        })
        .collect()
}

/// Which electrode resistance a data set gives the model.
fn resistance_of(ds: &DataSet) -> String {
    let cal = ds.calibration.resistance;
    match ds.traces.iter().find(|t| t.resistance != cal) {
        None => cal.to_string(),
        Some(t) => format!("{cal} (calibration), {} ({})", t.resistance, t.path.display()),
    }
}

/// Run `identify` on a data set.
pub fn identify(ds: &DataSet, options: Options) -> Result<Report> {
    identify_with(ds, options, &ProgressBar::hidden())
}

/// [`identify`], counting the candidate models fitted on `progress` (its
/// length grows as the search does: the single effects, then the pairs).
pub fn identify_with(ds: &DataSet, options: Options, progress: &ProgressBar) -> Result<Report> {
    progress.set_message("baseline");
    let prep = Prepared::new(ds, options.sweep)?;
    let rows: usize = prep
        .files
        .iter()
        .map(|f| f.used.iter().filter(|u| **u).count())
        .sum();
    anyhow::ensure!(rows > 0, "the data set has no trace or sweep rows to explain");
    // Baselines, unweighted first, to estimate the noise.
    let mut baselines = vec![];
    for line in [Line::Continuous, Line::Ladder(30)] {
        let pred = prep
            .predict(line, Params::NONE)
            .with_context(|| format!("baseline, {line}"))?;
        baselines.push((line, pred));
    }
    // Noise per trace from the continuous baseline's residual; the sweep
    // (a smooth curve over frequency, few points) takes the traces' median.
    let resid0: Vec<Vec<f64>> = prep
        .files
        .iter()
        .zip(&baselines[0].1)
        .map(|(f, p)| f.cs.iter().zip(p).map(|(m, p)| m - p).collect())
        .collect();
    let raw: Vec<f64> = prep
        .files
        .iter()
        .zip(&resid0)
        .map(|(f, r)| {
            if f.kind == Kind::Trace {
                noise_sigma(r)
            } else {
                f64::NAN
            }
        })
        .collect();
    let usable = |v: f64| v.is_finite() && v > 0.0;
    // A file whose every row states its uncertainty (cs_sigma_pf) is
    // weighted by it; the others by their measured noise floor.
    let declared: Vec<bool> = prep
        .files
        .iter()
        .map(|f| !f.sigma.is_empty() && f.sigma.iter().all(|&s| usable(s)))
        .collect();
    let mut trace_noise: Vec<f64> = raw.iter().copied().filter(|&v| usable(v)).collect();
    trace_noise.sort_by(f64::total_cmp);
    // The noise floor is measured on the traces (point-to-point scatter)
    // or stated row by row; without either there is nothing to judge a
    // fit against, and a made-up floor would make any fit look explained
    // or not at will.
    let median = trace_noise.get(trace_noise.len() / 2).copied();
    let mut w: Vec<Vec<f64>> = vec![];
    for ((f, &v), &d) in prep.files.iter().zip(&raw).zip(&declared) {
        w.push(if d {
            f.sigma.iter().map(|s| 1.0 / s).collect()
        } else {
            let sigma = if usable(v) {
                v
            } else {
                median.with_context(|| {
                    format!(
                        "{}: no trace with a measurable noise floor, and no stated uncertainty (cs_sigma_pf) on every row (a set of calibration and sweep points alone cannot tell an effect from noise): record at least one trace_*.csv of {} rows or more, or state each point's uncertainty; `residual` still compares the points with the baseline",
                        f.name,
                        crate::model::prepared::MIN_TRACE_ROWS
                    )
                })?
            };
            vec![1.0 / sigma; f.cs.len()]
        });
    }
    let row_sigma = |f: &crate::model::File, w: &[f64]| -> (f64, usize) {
        let (mut ss, mut n) = (0.0, 0usize);
        for (w, _) in w.iter().zip(&f.used).filter(|x| *x.1) {
            ss += 1.0 / (w * w);
            n += 1;
        }
        (ss, n)
    };
    let noise_floor_pf = (prep
        .files
        .iter()
        .zip(&w)
        .map(|(f, w)| row_sigma(f, w).0)
        .sum::<f64>()
        / rows as f64)
        .sqrt();
    let noise_pf: Vec<(String, f64)> = prep
        .files
        .iter()
        .zip(&w)
        .map(|(f, w)| {
            let (ss, n) = row_sigma(f, w);
            (f.name.clone(), (ss / n.max(1) as f64).sqrt())
        })
        .collect();
    let all_declared = declared.iter().all(|&d| d);
    let problem = |line| Problem {
        prep: &prep,
        line,
        w: w.clone(),
        rows,
        declared: all_declared,
    };
    let fits: Vec<Fit> = baselines
        .iter()
        .map(|(line, pred)| {
            let p = problem(*line);
            let ev = p.evaluate(pred).context("baseline")?;
            Ok(p.fit_of(vec![], Params::NONE, vec![], ev))
        })
        .collect::<Result<_>>()?;
    // The sensor is a continuous film: the continuous line is the base
    // that effects are added to; the paper's n = 30 ladder is reported as
    // its approximation.
    let base = fits[0].clone();
    let prob = problem(base.line);
    let explained = |f: &Fit| f.rms_pf <= options.explained * noise_floor_pf;
    let mut report = Report {
        baselines: fits,
        noise_pf,
        noise_floor_pf,
        singles: vec![],
        pairs: vec![],
        accepted: None,
        unexplained: false,
        rows,
        decimated: prep
            .files
            .iter()
            .filter(|f| f.stride > 1)
            .map(|f| (f.name.clone(), f.rows_read, f.stride))
            .collect(),
        resistance: resistance_of(ds),
        options,
    };
    if explained(&base) {
        return Ok(report);
    }
    // Every single effect, in parallel; the recording's time effects only
    // where there is a trace for them to act on.
    let traces = prep.files.iter().any(|f| f.kind == Kind::Trace);
    let library: Vec<Effect> = Effect::library()
        .filter(|e| traces || e.info().entry != instrument::effects::Entry::Time)
        .collect();
    progress.set_message("single effects");
    progress.inc_length(library.len() as u64);
    let mut singles: Vec<Fit> = std::thread::scope(|sc| {
        let hs: Vec<_> = library
            .iter()
            .map(|&e| {
                let prob = &prob;
                sc.spawn(move || {
                    let f = prob.fit(&[e], Params::NONE, &[e]);
                    progress.inc(1);
                    f
                })
            })
            .collect();
        joined(hs)
    });
    singles.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    report.singles = singles;
    let Some(best) = report.singles.first().cloned() else {
        report.unexplained = true;
        return Ok(report);
    };
    let strong = |big: &Fit, small: &Fit| small.bic - big.bic > options.bic_margin;
    if strong(&best, &base) && explained(&best) {
        report.accepted = Some(best);
        return Ok(report);
    }
    if options.max_effects >= 2 && strong(&best, &base) {
        let first = best.effects[0];
        progress.set_message(format!("pairs with {}", first.id()));
        progress.inc_length(library.len().saturating_sub(1) as u64);
        let mut pairs: Vec<Fit> = std::thread::scope(|sc| {
            let hs: Vec<_> = library
                .iter()
                .copied()
                .filter(|&e| e != first)
                .map(|e| {
                    let prob = &prob;
                    let start = best.params;
                    sc.spawn(move || {
                        let f = prob.fit(&[first, e], start, &[e]);
                        progress.inc(1);
                        f
                    })
                })
                .collect();
            joined(hs)
        });
        pairs.sort_by(|a, b| a.bic.total_cmp(&b.bic));
        report.pairs = pairs;
        if let Some(bp) = report.pairs.first() {
            if strong(bp, &best) && explained(bp) {
                report.accepted = Some(bp.clone());
                return Ok(report);
            }
        }
    }
    report.unexplained = true;
    Ok(report)
}
