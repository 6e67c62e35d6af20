//! The weighted least-squares problem of `identify`: a model's
//! predictions against the data, weighted by each file's noise, fitted by
//! a grid over each effect's search range and then projected
//! Levenberg–Marquardt; 1σ from the covariance.

use super::{FileError, Fit};
use crate::baseline::noise_sigma;
use crate::dataset::Kind;
use crate::lsq::{self, par_map};
use crate::model::{Averaging, Effect, Line, Params, Prepared, Search};

/// Noise-weighted residuals and statistics of `pred` against the data.
pub(super) struct Evaluated {
    pub(super) s: f64,
    pub(super) residual: Vec<Vec<f64>>,
}

/// The problem: data, weights, line.
pub(super) struct Problem<'a> {
    pub(super) prep: &'a Prepared,
    pub(super) line: Line,
    /// What the meter averages (time effects only).
    pub(super) averaging: Averaging,
    /// 1/σ per file and row.
    pub(super) w: Vec<Vec<f64>>,
    pub(super) rows: usize,
    /// The σ are stated uncertainties (not a noise floor measured on the
    /// residual): a parameter's uncertainty is scaled up by the fit's
    /// √(χ²/(n − k)) only when that exceeds 1 (the Birge ratio).
    pub(super) declared: bool,
    /// Per file: its rows state their σ (`cs_sigma_pf`).
    pub(super) stated: Vec<bool>,
}

impl Problem<'_> {
    pub(super) fn eval(&self, params: Params) -> Option<Evaluated> {
        self.evaluate(&self.prep.predict_as(self.line, params, self.averaging).ok()?)
    }

    /// Residuals and weighted sum of squares of predictions `pred` (pF).
    pub(super) fn evaluate(&self, pred: &[Vec<f64>]) -> Option<Evaluated> {
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
                    .zip(w)
                    .map(|(((m, p), &u), w)| {
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
    pub(super) fn weighted(&self, ev: &Evaluated) -> Vec<f64> {
        ev.residual
            .iter()
            .zip(&self.w)
            .zip(&self.prep.files)
            .flat_map(|((r, w), f)| {
                r.iter()
                    .zip(&f.used)
                    .zip(w)
                    .filter(|x| *x.0 .1)
                    .map(|((e, _), w)| e * w)
            })
            .collect()
    }

    pub(super) fn bic(&self, s: f64, k: usize) -> f64 {
        let n = self.rows as f64;
        n * (s / n).ln() + k as f64 * n.ln()
    }

    /// The noise floor (pF) of the data seen through a model whose
    /// residual is `residual`: per trace, the point-to-point scatter of the
    /// residual on the rows used ([`noise_sigma`]: the meter's Cs noise
    /// and the recorded resistances' noise as the model carries it into
    /// its prediction, which a misfit smooth in time does not raise); a
    /// sweep takes the traces' median; stated σ as stated. Row-weighted
    /// RMS over the files.
    pub(super) fn floor_of(&self, residual: &[Vec<f64>]) -> f64 {
        let usable = |v: f64| v.is_finite() && v > 0.0;
        let per: Vec<Option<f64>> = self
            .prep
            .files
            .iter()
            .zip(residual)
            .zip(&self.stated)
            .map(|((f, r), &stated)| {
                if stated || f.kind != Kind::Trace {
                    return None;
                }
                let used: Vec<f64> = r.iter().zip(&f.used).filter(|x| *x.1).map(|x| *x.0).collect();
                Some(noise_sigma(&used)).filter(|&v| usable(v))
            })
            .collect();
        let mut traces: Vec<f64> = per.iter().flatten().copied().collect();
        traces.sort_by(f64::total_cmp);
        let median = traces.get(traces.len() / 2).copied();
        let (mut ss, mut n) = (0.0, 0usize);
        for ((f, w), s) in self.prep.files.iter().zip(&self.w).zip(&per) {
            for (w, _) in w.iter().zip(&f.used).filter(|x| *x.1) {
                // A file without a scatter of its own: its weight's σ
                // (stated), or the traces' median.
                let sigma = s.or(median.filter(|_| f.kind != Kind::Trace)).unwrap_or(1.0 / w);
                ss += sigma * sigma;
                n += 1;
            }
        }
        (ss / n.max(1) as f64).sqrt()
    }

    /// Summarize a model whose parameters `fitted` (1σ `sigma`) are set
    /// in `params`; it names them all until told otherwise.
    pub(super) fn fit_of(&self, fitted: Vec<Effect>, params: Params, sigma: Vec<f64>, ev: Evaluated) -> Fit {
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
            search: self.prep.search,
            noise_pf: self.floor_of(&ev.residual),
            line: self.line,
            bic: self.bic(ev.s, fitted.len()),
            effects: fitted.clone(),
            fitted,
            averaging: None,
            unresolved: None,
            params,
            sigma,
            correlation: vec![],
            s: ev.s,
            rms_pf: (ss / k).sqrt(),
            max_pf: mx,
            rms_pct: (ssp / k).sqrt(),
            max_pct: mxp,
            files,
            residual: ev.residual,
        }
    }

    /// Fit `effects` starting from `start` (the others held): a grid over
    /// the range of each effect not yet set in `start` (`scan`), evaluated
    /// on `coarse` (the same data, traces decimated: the grid only picks
    /// the basin), then projected Levenberg–Marquardt on all of them on
    /// the full data.
    pub(super) fn fit(
        &self,
        coarse: &Problem,
        effects: &[Effect],
        start: Params,
        scan: &[Effect],
    ) -> Option<Fit> {
        let mut p = start;
        // A bump carried over from a smaller model: walked to its new
        // optimum on the coarse copy first (its place and width trade
        // against its amplitude along a long valley), then on all rows.
        let bump_shape = |e: &Effect| Effect::BUMP_SHAPES.contains(e);
        let carried = effects.iter().any(bump_shape) && !scan.iter().any(bump_shape);
        if carried {
            if let Some((q, _, _)) = coarse.levenberg_marquardt(effects, p, LM_STEPS) {
                p = q;
            }
        }
        if !scan.is_empty() {
            let mut s_best = coarse.eval(p).map_or(f64::INFINITY, |ev| ev.s);
            // A bump with its place and width (a second bump takes the
            // first's, and its amplitude's grid below): on a joint grid of
            // places and widths, each with its best amplitude (which does
            // nothing without a width, and the place and width trade
            // against each other), then walked down on the coarse copy
            // from the [`BUMP_STARTS`] best places and the best of the
            // other sign (a narrow bump at one end and a wide one of the
            // other sign over the rest read alike on a grid, and each is
            // a valley of its own).
            let bump = scan
                .iter()
                .copied()
                .find(|e| Effect::BUMPS.contains(e))
                .filter(|_| scan.contains(&Effect::BumpCentre));
            if let Some(b) = bump {
                if let Some((s, q)) = coarse.bump_start(effects, p, b) {
                    if s < s_best {
                        (s_best, p) = (s, q);
                    }
                }
            }
            p = coarse.grid_start(scan, p, s_best, bump.is_some());
        }
        let k = effects.len();
        let (p, best, jtj_at_p) = self.levenberg_marquardt(effects, p, LM_STEPS)?;
        // Uncertainty: s²·(JᵀJ)⁻¹, s² = S/(n − k), at the optimum.
        let unknowns = Unknowns::of(self, effects, p);
        let a = match jtj_at_p {
            Some(a) => a,
            None => lsq::normal_equations(&unknowns, &lsq::Point::at(&unknowns, unknowns.start())?)?.0,
        };
        let mut s2 = best.s / (self.rows.saturating_sub(k).max(1)) as f64;
        if self.declared {
            s2 = s2.max(1.0);
        }
        let (sigma, correlation) = lsq::sigma_correlation(lsq::covariance(&a, s2).as_deref(), k);
        let mut fit = self.fit_of(effects.to_vec(), p, sigma, best);
        fit.correlation = correlation;
        Some(fit)
    }

    /// A bump `b` with its place and width, on this (coarse) copy: the
    /// best amplitude at each place and width of a joint grid, then the
    /// [`BUMP_STARTS`] best places and the best of the other sign walked
    /// down from `p`, the best of them to the bottom: its S and
    /// parameters.
    fn bump_start(&self, effects: &[Effect], p: Params, b: Effect) -> Option<(f64, Params)> {
        // At each place and width, the best amplitude by
        // Gauss–Newton on it alone (the bump is near linear in
        // its amplitude): a probe, then two secant steps.
        let (lo, hi) = self.prep.search.range(b);
        let r0 = self.eval(p).map(|ev| self.weighted(&ev));
        let places: Vec<(f64, f64)> = BUMP_CENTRES
            .iter()
            .flat_map(|&c| BUMP_WIDTHS.iter().map(move |&w| (c, w)))
            .collect();
        let mut at: Vec<(f64, Params)> = par_map(&places, |&(c, w)| {
            let q = p.with(Effect::BumpCentre, c).with(Effect::BumpWidth, w);
            let (s, a) = secant_amplitude(
                |a| self.eval(q.with(b, a)).map(|ev| (ev.s, self.weighted(&ev))),
                r0.clone()?,
                (lo, hi),
            )?;
            Some((s, q.with(b, a)))
        })
        .into_iter()
        .flatten()
        .collect();
        at.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The best [`BUMP_STARTS`] places, and the best of the
        // other sign if none of them has it (a bump's mirror).
        let sign = |q: &Params| q.get(b) > 0.0;
        let mut starts: Vec<Params> = vec![];
        for (_, q) in &at {
            let c = q.get(Effect::BumpCentre);
            if starts.len() < BUMP_STARTS && starts.iter().all(|x| x.get(Effect::BumpCentre) != c) {
                starts.push(*q);
            }
        }
        if let Some(mirror) = at.iter().find(|x| starts.iter().all(|q| sign(q) != sign(&x.1))) {
            starts.push(mirror.1);
        }
        // Each walked a few steps down, the best of them to the
        // bottom (on this coarse copy).
        par_map(&starts, |&q| {
            let (q, ev, _) = self.levenberg_marquardt(effects, q, WALK_STEPS)?;
            Some((ev, q))
        })
        .into_iter()
        .flatten()
        .min_by(|a, b| a.0.s.total_cmp(&b.0.s))
        .and_then(|(_, q)| {
            let (q, ev, _) = self.levenberg_marquardt(effects, q, WALK_STEPS * 3)?;
            Some((ev.s, q))
        })
    }

    /// Each effect of `scan` on its grid from `p` (S `s_best` there), on
    /// this (coarse) copy, a response's time constant at each whole order
    /// and a bulge's amplitude at each of [`POWERS`];
    /// a bump's effects left to [`Problem::bump_start`] when `bump`: the
    /// best parameters found.
    fn grid_start(&self, scan: &[Effect], mut p: Params, mut s_best: f64, bump: bool) -> Params {
        let bump_shape = |e: &Effect| Effect::BUMP_SHAPES.contains(e);
        // A response with its order: its time constant's grid at each
        // whole order (the two trade along n·τ, the kernel's
        // centroid); a bulge with its power: its amplitude's grid at
        // each power alike (the peak moves with both).
        let (shape, values): (Option<Effect>, &[f64]) = if scan.contains(&Effect::MeterOrder) {
            (Some(Effect::MeterOrder), &ORDERS)
        } else if scan.contains(&Effect::BulgePower) {
            (Some(Effect::BulgePower), &POWERS)
        } else {
            (None, &[0.0])
        };
        let start = p;
        for &value in values {
            let mut q = start;
            if let Some(e) = shape {
                q = q.with(e, value);
            }
            for &e in scan
                .iter()
                .filter(|e| Some(**e) != shape && (!bump || !(Effect::BUMPS.contains(e) || bump_shape(e))))
            {
                let mut at = q.get(e);
                let mut found = false;
                for v in grid(&self.prep.search, e) {
                    if let Some(ev) = self.eval(q.with(e, v)) {
                        if ev.s < s_best {
                            (s_best, at, found) = (ev.s, v, true);
                        }
                    }
                }
                q = q.with(e, at);
                if found {
                    p = q;
                }
            }
        }
        // No value improved on the start: the response starts first
        // order, the bulge a parabola.
        if let Some(e) = shape.filter(|&e| p.get(e) == 0.0) {
            p = p.with(e, 1.0);
        }
        p
    }

    /// The bounded fit ([`lsq::fit`]) of `effects` from `p` for at most
    /// `steps` iterations: the optimum, its evaluation, and JᵀJ there
    /// when the last iteration left `p` where it was. None where `p`
    /// cannot be evaluated.
    #[allow(clippy::type_complexity)]
    fn levenberg_marquardt(
        &self,
        effects: &[Effect],
        p: Params,
        steps: usize,
    ) -> Option<(Params, Evaluated, Option<Vec<Vec<f64>>>)> {
        let unknowns = Unknowns::of(self, effects, p);
        let fitted = lsq::fit(&unknowns, lsq::Point::at(&unknowns, unknowns.start())?, steps);
        let q = unknowns.params(&fitted.best.x);
        Some((q, self.eval(q)?, fitted.jtj))
    }
}

/// A model's `effects` as the unknowns of a least-squares problem, the
/// other parameters held at `base`'s; each bounded by its search range.
struct Unknowns<'a, 'p> {
    problem: &'a Problem<'p>,
    effects: &'a [Effect],
    base: Params,
    bounds: Vec<(f64, f64)>,
}

impl<'a, 'p> Unknowns<'a, 'p> {
    fn of(problem: &'a Problem<'p>, effects: &'a [Effect], base: Params) -> Self {
        let bounds = effects.iter().map(|&e| problem.prep.search.range(e)).collect();
        Self {
            problem,
            effects,
            base,
            bounds,
        }
    }

    /// The unknowns at `base`.
    fn start(&self) -> Vec<f64> {
        self.effects.iter().map(|&e| self.base.get(e)).collect()
    }

    /// `base` with the unknowns `x`.
    fn params(&self, x: &[f64]) -> Params {
        self.effects
            .iter()
            .zip(x)
            .fold(self.base, |p, (&e, &v)| p.with(e, v))
    }
}

impl lsq::Problem for Unknowns<'_, '_> {
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }

    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        let ev = self.problem.eval(self.params(x))?;
        Some(self.problem.weighted(&ev))
    }
}

/// The whole orders a response's time constant is scanned at
/// ([`Effect::MeterOrder`]).
const ORDERS: [f64; 4] = [1.0, 2.0, 3.0, 4.0];

/// The powers a bulge's amplitude is scanned at
/// ([`Effect::BulgePower`]): the parabola, and toward a sin²-like bell.
const POWERS: [f64; 3] = [1.0, 2.0, 3.0];

/// A bump's places on its joint grid (fractions of the sensor).
const BUMP_CENTRES: [f64; 10] = [0.05, 0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 0.75, 0.85, 0.95];

/// Levenberg–Marquardt's most steps (each solves the normal equations).
const LM_STEPS: usize = 40;

/// The steps each of a bump's starts is walked down on the coarse copy
/// before the best of them is walked three times as far (the coarse
/// copy only picks the valley: all rows take it to the bottom).
const WALK_STEPS: usize = 6;

/// The places a bump is walked down from on the coarse copy.
const BUMP_STARTS: usize = 3;

/// A bump's widths on its joint grid (fractions of the sensor).
const BUMP_WIDTHS: [f64; 4] = [0.25, 0.4, 0.65, 1.0];

/// Σ xᵢ·yᵢ.
fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// The least-squares amplitude `a` of a model whose weighted residual
/// `r(a)` is near linear in it, within `[lo, hi]` (`lo < 0 < hi`):
/// `r(0) = r0` is known, a probe at a sixteenth of the nearer end of
/// the range gives the slope, and Gauss–Newton steps on the secant
/// slope (at most three evaluations) go to the minimum of `S = |r|²`,
/// exactly in one step where `r` is linear in `a`. `eval(a)` returns
/// `(S, r)`, or `None` where the model cannot be evaluated. Returns the
/// best `(S, a)` evaluated (never `a = 0`, the caller's own point).
fn secant_amplitude(
    eval: impl Fn(f64) -> Option<(f64, Vec<f64>)>,
    r0: Vec<f64>,
    (lo, hi): (f64, f64),
) -> Option<(f64, f64)> {
    let (mut a0, mut r_prev, mut a) = (0.0, r0, hi.min(-lo) / 16.0);
    let mut best: Option<(f64, f64)> = None;
    for _ in 0..3 {
        let (s, r) = eval(a)?;
        if best.is_none_or(|x| s < x.0) {
            best = Some((s, a));
        }
        let j: Vec<f64> = r.iter().zip(&r_prev).map(|(x, y)| (x - y) / (a - a0)).collect();
        let jj = dot(&j, &j);
        let next = (a - dot(&j, &r) / jj).clamp(lo, hi);
        if !(jj > 0.0 && next.is_finite()) || (next - a).abs() <= 1e-6 * (hi - lo) {
            break;
        }
        (a0, r_prev, a) = (a, r, next);
    }
    best
}

/// Starting points for an effect's parameter: 0 and log-spaced magnitudes
/// (factor 2) across its range in `search`, from its end down to the
/// finest the data resolve (a time effect: half a row interval,
/// [`Search::finest_time_s`]), both signs where allowed, since some effects act
/// quadratically and a linear grid would miss small values.
pub(super) fn grid(search: &Search, e: Effect) -> Vec<f64> {
    let (lo, hi) = search.range(e);
    let top = hi.max(-lo);
    let mut v = vec![0.0];
    if top <= 0.0 {
        return v;
    }
    // Signed ranges: 9 magnitudes (1/256 of the range), one-sided: 12
    // (1/2048); time effects down to half a row interval, at most 16.
    let levels = if e.info().entry == instrument::effects::Entry::Time && search.row_s > 0.0 {
        ((top / search.finest_time_s()).log2().ceil() as i32 + 1).clamp(2, 16)
    } else if lo < 0.0 {
        9
    } else {
        12
    };
    for k in 0..levels {
        let m = 0.5f64.powi(k);
        if hi > 0.0 {
            v.push(hi * m);
        }
        if lo < 0.0 {
            v.push(lo * m);
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(S, r)` of a model `r(a) = y − a·x − κ·a²·x` on a fixed row set.
    fn model<'a>(x: &'a [f64], y: &'a [f64], kappa: f64) -> impl Fn(f64) -> Option<(f64, Vec<f64>)> + 'a {
        move |a| {
            let r: Vec<f64> = x
                .iter()
                .zip(y)
                .map(|(x, y)| y - a * x - kappa * a * a * x)
                .collect();
            Some((r.iter().map(|v| v * v).sum(), r))
        }
    }

    /// Against the f64 reference (a dense scan of the range, 10⁻⁴
    /// apart): the linear model's amplitude is the exact least-squares
    /// one (Σxy/Σx², to 1e-9); a model that bends its residual by κ·a²
    /// (κ = 0.05 and 0.2 over a range of ±1: 5 % and 20 % at the ends)
    /// is a start for Levenberg–Marquardt, within 0.004 and 0.06 of the
    /// scan's best and of its sign. True amplitudes from a sixteenth of
    /// the range to its end, both signs.
    #[test]
    fn secant_amplitude_finds_the_least_squares_amplitude() {
        let n = 200;
        let x: Vec<f64> = (0..n).map(|i| ((i as f64) * 0.37).sin() + 0.3).collect();
        let noise: Vec<f64> = (0..n).map(|i| 1e-3 * ((i as f64) * 1.91).cos()).collect();
        let (lo, hi) = (-1.0, 1.0);
        for truth in [-1.0, -0.6, -0.2, -0.0625, 0.0625, 0.2, 0.6, 0.95] {
            for (kappa, bound) in [(0.0, 1e-9), (0.05, 0.004), (0.2, 0.06)] {
                let y: Vec<f64> = x
                    .iter()
                    .zip(&noise)
                    .map(|(x, e)| truth * x + kappa * truth * truth * x + e)
                    .collect();
                let f = model(&x, &y, kappa);
                let (_, a) = secant_amplitude(&f, f(0.0).unwrap().1, (lo, hi)).unwrap();
                let reference = if kappa == 0.0 {
                    let xy = x.iter().zip(&y).map(|(x, y)| x * y).sum::<f64>();
                    (xy / x.iter().map(|x| x * x).sum::<f64>()).clamp(lo, hi)
                } else {
                    (0..=20000)
                        .map(|i| lo + (hi - lo) * i as f64 / 20000.0)
                        .map(|a| (f(a).unwrap().0, a))
                        .min_by(|p, q| p.0.total_cmp(&q.0))
                        .unwrap()
                        .1
                };
                assert!(
                    (a - reference).abs() <= bound && a.signum() == reference.signum(),
                    "truth {truth} κ {kappa}: {a} against {reference}"
                );
            }
        }
    }

    /// A model that cannot be evaluated gives no amplitude, not a panic.
    #[test]
    fn secant_amplitude_passes_on_a_failed_evaluation() {
        let r0 = vec![1.0, 2.0];
        assert_eq!(secant_amplitude(|_| None, r0, (-1.0, 1.0)), None);
    }
}
