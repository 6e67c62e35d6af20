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

use crate::baseline::noise_sigma;
use crate::dataset::{DataSet, Kind};
use crate::model::{Effect, Line, Params, Prepared};
use anyhow::{Context, Result};

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

/// Noise-weighted residuals and statistics of `pred` against the data.
struct Evaluated {
    s: f64,
    residual: Vec<Vec<f64>>,
}

/// The problem: data, weights, line.
struct Problem<'a> {
    prep: &'a Prepared,
    line: Line,
    /// 1/σ per file.
    w: Vec<f64>,
    rows: usize,
}

impl Problem<'_> {
    fn eval(&self, params: Params) -> Option<Evaluated> {
        self.evaluate(&self.prep.predict(self.line, params).ok()?)
    }

    /// Residuals and weighted sum of squares of predictions `pred` (pF).
    fn evaluate(&self, pred: &[Vec<f64>]) -> Option<Evaluated> {
        let mut s = 0.0;
        let residual: Vec<Vec<f64>> = self
            .prep
            .files
            .iter()
            .zip(pred)
            .zip(&self.w)
            .map(|((f, p), w)| {
                f.cs.iter()
                    .zip(p)
                    .zip(&f.used)
                    .map(|((m, p), &u)| {
                        let e = m - p;
                        if u {
                            s += (e * w) * (e * w);
                        }
                        e
                    })
                    .collect()
            })
            .collect();
        s.is_finite().then_some(Evaluated { s, residual })
    }

    /// Weighted residual vector (for the Jacobian).
    fn weighted(&self, ev: &Evaluated) -> Vec<f64> {
        ev.residual
            .iter()
            .zip(&self.w)
            .zip(&self.prep.files)
            .flat_map(|((r, w), f)| r.iter().zip(&f.used).filter(|x| *x.1).map(move |(e, _)| e * w))
            .collect()
    }

    fn bic(&self, s: f64, k: usize) -> f64 {
        let n = self.rows as f64;
        n * (s / n).ln() + k as f64 * n.ln()
    }

    /// Summarize a model.
    fn fit_of(&self, effects: Vec<Effect>, params: Params, sigma: Vec<f64>, ev: Evaluated) -> Fit {
        let (mut ss, mut mx, mut ssp, mut mxp, mut n) = (0.0, 0.0f64, 0.0, 0.0f64, 0usize);
        let files = self
            .prep
            .files
            .iter()
            .zip(&ev.residual)
            .map(|(f, r)| {
                let (mut a, mut b, mut c, mut d) = (0.0, 0.0f64, 0.0, 0.0f64);
                let mut rows = 0usize;
                for ((e, m), _) in r.iter().zip(&f.cs).zip(&f.used).filter(|x| *x.1) {
                    rows += 1;
                    let pct = 100.0 * e / m;
                    a += e * e;
                    b = b.max(e.abs());
                    c += pct * pct;
                    d = d.max(pct.abs());
                }
                (ss, mx, ssp, mxp, n) = (ss + a, mx.max(b), ssp + c, mxp.max(d), n + rows);
                let k = rows.max(1) as f64;
                FileError {
                    file: f.name.clone(),
                    rows,
                    rms_pf: (a / k).sqrt(),
                    max_pf: b,
                    rms_pct: (c / k).sqrt(),
                    max_pct: d,
                }
            })
            .collect();
        let k = n.max(1) as f64;
        Fit {
            line: self.line,
            bic: self.bic(ev.s, effects.len()),
            effects,
            params,
            sigma,
            s: ev.s,
            rms_pf: (ss / k).sqrt(),
            max_pf: mx,
            rms_pct: (ssp / k).sqrt(),
            max_pct: mxp,
            files,
            residual: ev.residual,
        }
    }

    /// JᵀJ and Jᵀr of the noise-weighted residual r at `p` (evaluated as
    /// `at`), with J by one-sided differences of 10⁻⁴ of each effect's
    /// range (stepping inwards at the upper bound).
    fn normal_equations(
        &self,
        effects: &[Effect],
        p: Params,
        at: &Evaluated,
    ) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
        let r0 = self.weighted(at);
        let mut jac = Vec::with_capacity(effects.len());
        for &e in effects {
            let (lo, hi) = e.info().search;
            let h = 1e-4 * (hi - lo);
            let (v, sign) = if p.get(e) + h <= hi {
                (p.get(e) + h, 1.0)
            } else {
                (p.get(e) - h, -1.0)
            };
            let rj = self.weighted(&self.eval(p.with(e, v))?);
            jac.push(
                rj.iter()
                    .zip(&r0)
                    .map(|(a, b)| sign * (a - b) / h)
                    .collect::<Vec<f64>>(),
            );
        }
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
        let a = jac
            .iter()
            .map(|x| jac.iter().map(|y| dot(x, y)).collect())
            .collect();
        let g = jac.iter().map(|x| dot(x, &r0)).collect();
        Some((a, g))
    }

    /// Fit `effects` starting from `start` (the others held): a grid over
    /// the range of each effect not yet set in `start` (`scan`), then
    /// projected Levenberg–Marquardt on all of them.
    fn fit(&self, effects: &[Effect], start: Params, scan: &[Effect]) -> Option<Fit> {
        let mut p = start;
        let mut best = self.eval(p)?;
        for &e in scan {
            let mut at = p.get(e);
            for v in grid(e) {
                if let Some(ev) = self.eval(p.with(e, v)) {
                    if ev.s < best.s {
                        best = ev;
                        at = v;
                    }
                }
            }
            p = p.with(e, at);
        }
        let k = effects.len();
        let clamp = |e: Effect, v: f64| {
            let (lo, hi) = e.info().search;
            v.clamp(lo, hi)
        };
        let mut lambda = 1e-3;
        // JᵀJ at the current `p`, kept for the uncertainty when the last
        // iteration leaves `p` where it was.
        let mut jtj_at_p = None;
        for _ in 0..40 {
            let (a, g) = self.normal_equations(effects, p, &best)?;
            let mut improved = false;
            while lambda < 1e10 {
                let mut m = a.clone();
                for (i, row) in m.iter_mut().enumerate() {
                    row[i] += lambda * a[i][i].max(1e-300);
                }
                let Some(d) = solve(m, g.iter().map(|v| -v).collect()) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut q = p;
                for (i, &e) in effects.iter().enumerate() {
                    q = q.with(e, clamp(e, p.get(e) + d[i]));
                }
                match self.eval(q) {
                    Some(ev) if ev.s < best.s => {
                        let rel = (best.s - ev.s) / best.s;
                        p = q;
                        best = ev;
                        lambda = (lambda / 4.0).max(1e-9);
                        improved = rel > 1e-9;
                        break;
                    }
                    _ => lambda *= 4.0,
                }
            }
            if !improved {
                // `p` is unchanged only if no step was accepted.
                if lambda >= 1e10 {
                    jtj_at_p = Some(a);
                }
                break;
            }
        }
        // Uncertainty: s²·(JᵀJ)⁻¹, s² = S/(n − k), at the optimum.
        let a = match jtj_at_p {
            Some(a) => a,
            None => self.normal_equations(effects, p, &best)?.0,
        };
        let s2 = best.s / (self.rows.saturating_sub(k).max(1)) as f64;
        let sigma = (0..k)
            .map(|i| {
                let mut unit = vec![0.0; k];
                unit[i] = 1.0;
                solve(a.clone(), unit).map_or(f64::INFINITY, |col| (s2 * col[i]).max(0.0).sqrt())
            })
            .collect();
        Some(self.fit_of(effects.to_vec(), p, sigma, best))
    }
}

/// Starting points for an effect's parameter: 0 and log-spaced magnitudes
/// (factor 2) across its range, both signs where allowed, since some
/// effects act quadratically and a linear grid would miss small values.
fn grid(e: Effect) -> Vec<f64> {
    let (lo, hi) = e.info().search;
    let mut v = vec![0.0];
    let levels = if lo < 0.0 { 7 } else { 12 };
    for k in 0..levels {
        let m = 0.5f64.powi(k);
        v.push(hi * m);
        if lo < 0.0 {
            v.push(lo * m);
        }
    }
    v
}

/// Solve a small dense system by Gaussian elimination with partial pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 || !a[p][c].is_finite() {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            let pivot = a[c].clone();
            for (x, p) in a[r].iter_mut().zip(&pivot).skip(c) {
                *x -= f * p;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
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
    let prep = Prepared::new(ds, options.sweep)?;
    let rows: usize = prep
        .files
        .iter()
        .map(|f| f.used.iter().filter(|u| **u).count())
        .sum();
    anyhow::ensure!(rows > 0, "the data set has no trace rows to explain");
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
    let mut trace_noise: Vec<f64> = raw.iter().copied().filter(|&v| usable(v)).collect();
    trace_noise.sort_by(f64::total_cmp);
    let median = trace_noise.get(trace_noise.len() / 2).copied().unwrap_or(1e-3);
    let noise: Vec<f64> = raw.iter().map(|&v| if usable(v) { v } else { median }).collect();
    let noise_floor_pf = (prep
        .files
        .iter()
        .zip(&noise)
        .map(|(f, s)| f.used.iter().filter(|u| **u).count() as f64 * s * s)
        .sum::<f64>()
        / rows as f64)
        .sqrt();
    let problem = |line| Problem {
        prep: &prep,
        line,
        w: noise.iter().map(|s| 1.0 / s).collect(),
        rows,
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
        noise_pf: prep
            .files
            .iter()
            .map(|f| f.name.clone())
            .zip(noise.iter().copied())
            .collect(),
        noise_floor_pf,
        singles: vec![],
        pairs: vec![],
        accepted: None,
        unexplained: false,
        rows,
        resistance: resistance_of(ds),
        options,
    };
    if explained(&base) {
        return Ok(report);
    }
    // Every single effect, in parallel.
    let mut singles: Vec<Fit> = std::thread::scope(|sc| {
        let hs: Vec<_> = Effect::library()
            .map(|e| {
                let prob = &prob;
                sc.spawn(move || prob.fit(&[e], Params::NONE, &[e]))
            })
            .collect();
        hs.into_iter().filter_map(|h| h.join().ok().flatten()).collect()
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
        let mut pairs: Vec<Fit> = std::thread::scope(|sc| {
            let hs: Vec<_> = Effect::library()
                .filter(|&e| e != first)
                .map(|e| {
                    let prob = &prob;
                    let start = best.params;
                    sc.spawn(move || prob.fit(&[first, e], start, &[e]))
                })
                .collect();
            hs.into_iter().filter_map(|h| h.join().ok().flatten()).collect()
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

fn param_value(e: Effect, v: f64) -> String {
    let i = e.info();
    let text = format!("{:.*}", i.display_decimals, i.display(v));
    if i.display_unit.is_empty() {
        text
    } else {
        format!("{text} {}", i.display_unit)
    }
}

/// Parameters of a fit as "name = value ± σ".
pub fn params_text(f: &Fit) -> String {
    f.effects
        .iter()
        .zip(&f.sigma)
        .map(|(&e, s)| {
            format!(
                "{} = {} ± {}",
                e.info().key,
                param_value(e, f.params.get(e)),
                param_value(e, *s)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

impl Report {
    /// The JSON report.
    pub fn json(&self) -> serde_json::Value {
        use serde_json::json;
        let fit_json = |f: &Fit| {
            let params: serde_json::Map<String, serde_json::Value> = f
                .effects
                .iter()
                .map(|&e| (e.info().key.to_string(), json!(e.info().display(f.params.get(e)))))
                .collect();
            let sigma: serde_json::Map<String, serde_json::Value> = f
                .effects
                .iter()
                .zip(&f.sigma)
                .map(|(&e, s)| (e.info().key.to_string(), json!(e.info().display(*s))))
                .collect();
            (params, sigma)
        };
        let fin = self.final_fit();
        let effects: Vec<serde_json::Value> = self
            .accepted
            .iter()
            .flat_map(|f| {
                let (params, sigma) = fit_json(f);
                f.effects.iter().map(move |&e| {
                    json!({
                        "id": e.id(),
                        "params": {e.info().key: params[e.info().key]},
                        "uncertainty": {e.info().key: sigma[e.info().key]},
                        "static": e.is_static(),
                        "rms_pf_after": f.rms_pf,
                    })
                })
            })
            .collect();
        let stats = |f: &Fit| {
            json!({
                "model": f.label(),
                "rms_pf": f.rms_pf, "max_pf": f.max_pf,
                "rms_pct": f.rms_pct, "max_pct": f.max_pct,
                "bic": f.bic,
                "files": f.files,
            })
        };
        let candidates: Vec<serde_json::Value> = self
            .singles
            .iter()
            .chain(&self.pairs)
            .map(|f| {
                let (params, sigma) = fit_json(f);
                json!({
                    "ids": f.effects.iter().map(|e| e.id()).collect::<Vec<_>>(),
                    "params": params, "uncertainty": sigma,
                    "rms_pf": f.rms_pf, "bic": f.bic,
                    "delta_bic": f.bic - self.baseline().bic,
                })
            })
            .collect();
        json!({
            "baseline": stats(self.baseline()),
            "baselines": self.baselines.iter().map(stats).collect::<Vec<_>>(),
            "effects": effects,
            "final": stats(fin),
            "noise_floor_pf": self.noise_floor_pf,
            "noise_pf": self.noise_pf.iter().map(|(f, s)| json!({"file": f, "sigma_pf": s})).collect::<Vec<_>>(),
            "unexplained": self.unexplained,
            "best_attempt": self.best_attempt().map(stats),
            "candidates": candidates,
            "rows": self.rows,
            "resistance": self.resistance,
            "criterion": {
                "bic": "n·ln(S/n) + k·ln(n)",
                "explained_within_noise": self.options.explained,
                "bic_margin": self.options.bic_margin,
            },
        })
    }

    /// A short verdict line.
    pub fn verdict(&self) -> String {
        let nf = self.noise_floor_pf;
        match (&self.accepted, self.unexplained) {
            (Some(f), _) => format!(
                "explained by {} ({}): RMS {:.3} → {:.3} pF, noise floor {:.3} pF",
                f.label(),
                params_text(f),
                self.baseline().rms_pf,
                f.rms_pf,
                nf
            ),
            (None, false) => format!(
                "clean: the {} explains the data (RMS {:.3} pF, noise floor {:.3} pF)",
                self.baseline().line,
                self.baseline().rms_pf,
                nf
            ),
            (None, true) => format!(
                "unexplained: RMS {:.3} pF is {:.1}× the noise floor ({:.3} pF), and no candidate brings it within {}× (best attempt: {} at {:.3} pF)",
                self.baseline().rms_pf,
                self.baseline().rms_pf / nf,
                nf,
                self.options.explained,
                self.best_attempt().map_or("none".into(), Fit::label),
                self.best_attempt().map_or(f64::NAN, |f| f.rms_pf)
            ),
        }
    }

    /// The markdown report; `plot` is the residual figure's file name.
    pub fn markdown(&self, data: &str, plot: Option<&str>) -> String {
        use std::fmt::Write as _;
        let mut md = format!("# identify: {data}\n\n**{}**\n\n", self.verdict());
        let b = self.baseline();
        let f = self.final_fit();
        let _ = writeln!(md, "## Error before and after\n");
        let _ = writeln!(
            md,
            "Before: {}. After: {}. Noise floor: {:.3} pF ({} rows). Electrode resistance: {}.\n",
            b.label(),
            f.label(),
            self.noise_floor_pf,
            self.rows,
            self.resistance
        );
        let _ = writeln!(
            md,
            "| file | noise | RMS before | max before | RMS after | max after | RMS % before | RMS % after |"
        );
        let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|");
        for ((x, y), (_, n)) in b.files.iter().zip(&f.files).zip(&self.noise_pf) {
            let _ = writeln!(
                md,
                "| {} | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} % | {:.3} % |",
                x.file, n, x.rms_pf, x.max_pf, y.rms_pf, y.max_pf, x.rms_pct, y.rms_pct
            );
        }
        let _ = writeln!(
            md,
            "| **all** | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} % | {:.3} % |\n",
            self.noise_floor_pf, b.rms_pf, b.max_pf, f.rms_pf, f.max_pf, b.rms_pct, f.rms_pct
        );
        if let Some(p) = plot {
            let _ = writeln!(md, "![residual before and after]({p})\n");
        }
        let _ = writeln!(
            md,
            "## Baselines\n\n| model | RMS | max | BIC |\n|---|---:|---:|---:|"
        );
        for x in &self.baselines {
            let _ = writeln!(
                md,
                "| {} | {:.3} pF | {:.3} pF | {:.0} |",
                x.line, x.rms_pf, x.max_pf, x.bic
            );
        }
        if !self.singles.is_empty() {
            let _ = writeln!(
                md,
                "\n## Candidates\n\nModel selection by BIC = n·ln(S/n) + k·ln n; an effect is accepted when it lowers BIC by more than {} and leaves the RMS within {}× the noise floor.\n\n| effects | parameters (± 1σ) | RMS | RMS / noise | ΔBIC vs baseline |\n|---|---|---:|---:|---:|",
                self.options.bic_margin, self.options.explained
            );
            for x in self.singles.iter().chain(&self.pairs) {
                let _ = writeln!(
                    md,
                    "| {} | {} | {:.3} pF | {:.2} | {:.0} |",
                    x.label(),
                    params_text(x),
                    x.rms_pf,
                    x.rms_pf / self.noise_floor_pf,
                    x.bic - b.bic
                );
            }
        }
        md
    }
}

/// Residual figure: per file, measured − model before (baseline) and after
/// (final model) against time (traces) or frequency (sweep).
pub fn plot(report: &Report, ds: &DataSet, path: &std::path::Path) -> Result<()> {
    use crate::plot::{figure, Panel, Series};
    let prep = Prepared::new(ds, report.options.sweep)?;
    let (b, f) = (report.baseline(), report.final_fit());
    let panels: Vec<Panel> = prep
        .files
        .iter()
        .enumerate()
        .map(|(i, file)| {
            let x: Vec<f64> = if file.kind == Kind::Trace {
                file.t.clone()
            } else {
                file.f.clone()
            };
            let pts = |r: &[f64]| x.iter().copied().zip(r.iter().copied()).collect::<Vec<_>>();
            let mut series = vec![Series::new(format!("before: {}", b.label()), pts(&b.residual[i]))];
            if report.accepted.is_some() {
                series.push(Series::new(format!("after: {}", f.label()), pts(&f.residual[i])));
            }
            Panel {
                title: file.name.clone(),
                x_label: if file.kind == Kind::Trace {
                    "time (s)"
                } else {
                    "frequency (Hz)"
                }
                .into(),
                y_label: "measured − model (pF)".into(),
                log_x: file.kind != Kind::Trace,
                series,
            }
        })
        .collect();
    figure(path, "identify: residual before and after", &panels)
}
