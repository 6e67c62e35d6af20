//! The weighted least-squares problem of `identify`: a model's
//! predictions against the data, weighted by each file's noise, fitted by
//! a grid over each effect's search range and then projected
//! Levenberg–Marquardt; 1σ from the covariance.

use super::{FileError, Fit};
use crate::baseline::noise_sigma;
use crate::dataset::Kind;
use crate::model::{Averaging, Effect, Line, Params, Prepared, Search};
use crate::numerics::solve;

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

    /// JᵀJ and Jᵀr of the noise-weighted residual r at `p` (evaluated as
    /// `at`), with J by one-sided differences of 10⁻⁴ of each effect's
    /// range (stepping inwards at the upper bound).
    pub(super) fn normal_equations(
        &self,
        effects: &[Effect],
        p: Params,
        at: &Evaluated,
    ) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
        let r0 = self.weighted(at);
        // The columns on the machine's cores (each is a model
        // evaluation on every row).
        let jac = par_map(effects, |&e| {
            let (lo, hi) = self.prep.search.range(e);
            let h = 1e-4 * (hi - lo);
            let (v, sign) = if p.get(e) + h <= hi {
                (p.get(e) + h, 1.0)
            } else {
                (p.get(e) - h, -1.0)
            };
            let rj = self.weighted(&self.eval(p.with(e, v))?);
            Some(
                rj.iter()
                    .zip(&r0)
                    .map(|(a, b)| sign * (a - b) / h)
                    .collect::<Vec<f64>>(),
            )
        })
        .into_iter()
        .collect::<Option<Vec<Vec<f64>>>>()?;
        let a = jac
            .iter()
            .map(|x| jac.iter().map(|y| dot(x, y)).collect())
            .collect();
        let g = jac.iter().map(|x| dot(x, &r0)).collect();
        Some((a, g))
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
            if let Some(ev) = coarse.eval(p) {
                p = coarse.levenberg_marquardt(effects, p, ev, LM_STEPS).0;
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
                // At each place and width, the best amplitude by
                // Gauss–Newton on it alone (the bump is near linear in
                // its amplitude): a probe, then two secant steps.
                let (lo, hi) = coarse.prep.search.range(b);
                let r0 = coarse.eval(p).map(|ev| coarse.weighted(&ev));
                let places: Vec<(f64, f64)> = BUMP_CENTRES
                    .iter()
                    .flat_map(|&c| BUMP_WIDTHS.iter().map(move |&w| (c, w)))
                    .collect();
                let mut at: Vec<(f64, Params)> = par_map(&places, |&(c, w)| {
                    let q = p.with(Effect::BumpCentre, c).with(Effect::BumpWidth, w);
                    let (s, a) = secant_amplitude(
                        |a| coarse.eval(q.with(b, a)).map(|ev| (ev.s, coarse.weighted(&ev))),
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
                // bottom (on the coarse copy).
                let walked = par_map(&starts, |&q| {
                    let ev = coarse.eval(q)?;
                    let (q, ev, _) = coarse.levenberg_marquardt(effects, q, ev, WALK_STEPS);
                    Some((ev, q))
                })
                .into_iter()
                .flatten()
                .min_by(|a, b| a.0.s.total_cmp(&b.0.s))
                .map(|(ev, q)| {
                    let (q, ev, _) = coarse.levenberg_marquardt(effects, q, ev, WALK_STEPS * 3);
                    (ev.s, q)
                });
                if let Some((s, q)) = walked {
                    if s < s_best {
                        (s_best, p) = (s, q);
                    }
                }
            }
            // A response with its order: its time constant's grid at each
            // whole order (the two trade along n·τ, the kernel's
            // centroid).
            let orders: &[f64] = if scan.contains(&Effect::MeterOrder) {
                &ORDERS
            } else {
                &[0.0]
            };
            let start = p;
            for &order in orders {
                let mut q = start;
                if order > 0.0 {
                    q = q.with(Effect::MeterOrder, order);
                }
                for &e in scan.iter().filter(|e| {
                    **e != Effect::MeterOrder
                        && (bump.is_none() || !(Effect::BUMPS.contains(e) || bump_shape(e)))
                }) {
                    let mut at = q.get(e);
                    let mut found = false;
                    for v in grid(&coarse.prep.search, e) {
                        if let Some(ev) = coarse.eval(q.with(e, v)) {
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
            // No order improved on the start: the response starts first
            // order.
            if scan.contains(&Effect::MeterOrder) && p.get(Effect::MeterOrder) == 0.0 {
                p = p.with(Effect::MeterOrder, 1.0);
            }
        }
        let k = effects.len();
        let (p, best, jtj_at_p) = self.levenberg_marquardt(effects, p, self.eval(p)?, LM_STEPS);
        // Uncertainty: s²·(JᵀJ)⁻¹, s² = S/(n − k), at the optimum.
        let a = match jtj_at_p {
            Some(a) => a,
            None => self.normal_equations(effects, p, &best)?.0,
        };
        let mut s2 = best.s / (self.rows.saturating_sub(k).max(1)) as f64;
        if self.declared {
            s2 = s2.max(1.0);
        }
        // (JᵀJ)⁻¹ by columns (None: singular, nothing pinned down).
        let inv: Vec<Option<Vec<f64>>> = (0..k)
            .map(|i| {
                let mut unit = vec![0.0; k];
                unit[i] = 1.0;
                solve(a.clone(), unit)
            })
            .collect();
        let sigma: Vec<f64> = inv
            .iter()
            .enumerate()
            .map(|(i, col)| {
                col.as_ref()
                    .map_or(f64::INFINITY, |c| (s2 * c[i]).max(0.0).sqrt())
            })
            .collect();
        // Correlations ρᵢⱼ = Cᵢⱼ/√(CᵢᵢCⱼⱼ) (NaN where singular).
        let correlation = (0..k)
            .map(|i| {
                (0..k)
                    .map(|j| match (&inv[i], &inv[j]) {
                        (Some(ci), Some(cj)) => ci[j] / (ci[i] * cj[j]).sqrt(),
                        _ => f64::NAN,
                    })
                    .collect()
            })
            .collect();
        let mut fit = self.fit_of(effects.to_vec(), p, sigma, best);
        fit.correlation = correlation;
        Some(fit)
    }

    /// Projected Levenberg–Marquardt on `effects` from `p` (evaluated as
    /// `best`): the optimum, its evaluation, and JᵀJ there when the last
    /// iteration left `p` where it was.
    #[allow(clippy::type_complexity)]
    fn levenberg_marquardt(
        &self,
        effects: &[Effect],
        mut p: Params,
        mut best: Evaluated,
        steps: usize,
    ) -> (Params, Evaluated, Option<Vec<Vec<f64>>>) {
        let clamp = |e: Effect, v: f64| {
            let (lo, hi) = self.prep.search.range(e);
            v.clamp(lo, hi)
        };
        let mut lambda = 1e-3;
        for _ in 0..steps {
            let Some((a, g)) = self.normal_equations(effects, p, &best) else {
                break;
            };
            let (mut improved, mut moved) = (false, false);
            // A parameter at a bound that the step pushes outward is held
            // there for the step (the active set), and the step solved
            // again for the others, until none more is held: a step for
            // all of them, clamped after, moves the free ones too little
            // and crawls along the bound (a bump's width at 1, its centre
            // at an end: over a hundred evaluations).
            let at_edge = |i: usize, di: f64| {
                let e = effects[i];
                let (lo, hi) = self.prep.search.range(e);
                let (v, edge) = (p.get(e), 1e-9 * (hi - lo));
                (v <= lo + edge && di < 0.0) || (v >= hi - edge && di > 0.0)
            };
            while lambda < 1e10 {
                let step = bounded_step(&a, &g, lambda, at_edge);
                let Some(d) = step else {
                    lambda *= 10.0;
                    continue;
                };
                let mut q = p;
                for (i, &e) in effects.iter().enumerate() {
                    q = q.with(e, clamp(e, p.get(e) + d[i]));
                }
                // A step (after the bounds) below 10⁻⁹ of every range
                // moves nothing the data can see: converged.
                if effects.iter().all(|&e| {
                    let (lo, hi) = self.prep.search.range(e);
                    (q.get(e) - p.get(e)).abs() <= 1e-9 * (hi - lo)
                }) {
                    break;
                }
                match self.eval(q) {
                    Some(ev) if ev.s < best.s => {
                        // Converged when a step lowers BIC = n·ln(S/n) +
                        // … by under 0.01 (n·ΔS/S), and S by under 0.01
                        // (S is noise-weighted: BIC decides on differences
                        // of 10, σ on differences of 1). A model far from
                        // the data (S/n in the thousands) is not walked
                        // along its valley for changes BIC cannot see.
                        improved = best.s - ev.s > 1e-2 * (best.s / self.rows.max(1) as f64).max(1.0);
                        moved = true;
                        p = q;
                        best = ev;
                        lambda = (lambda / 4.0).max(1e-9);
                        break;
                    }
                    _ => lambda *= 4.0,
                }
            }
            if !improved {
                // `p` is unchanged only if no step was accepted.
                return (p, best, (!moved).then_some(a));
            }
        }
        (p, best, None)
    }
}

/// The damped Gauss–Newton step d of (A + λ·diag A)·d = −g, a parameter
/// `at_edge(i, dᵢ)` (at a bound the step pushes it past) held at zero and
/// the step solved again for the others, until none more is held (the
/// active set); None where the matrix is singular.
fn bounded_step(
    a: &[Vec<f64>],
    g: &[f64],
    lambda: f64,
    at_edge: impl Fn(usize, f64) -> bool,
) -> Option<Vec<f64>> {
    let mut held = vec![false; g.len()];
    loop {
        let mut m = a.to_vec();
        let mut rhs: Vec<f64> = g.iter().map(|v| -v).collect();
        for i in 0..m.len() {
            m[i][i] += lambda * a[i][i].max(1e-300);
            if held[i] {
                // Its row and column those of the identity.
                m.iter_mut().for_each(|row| row[i] = 0.0);
                m[i].fill(0.0);
                m[i][i] = 1.0;
                rhs[i] = 0.0;
            }
        }
        let d = solve(m, rhs)?;
        let more: Vec<usize> = (0..d.len()).filter(|&i| !held[i] && at_edge(i, d[i])).collect();
        if more.is_empty() {
            return Some(d);
        }
        more.into_iter().for_each(|i| held[i] = true);
    }
}

/// The whole orders a response's time constant is scanned at
/// ([`Effect::MeterOrder`]).
const ORDERS: [f64; 4] = [1.0, 2.0, 3.0, 4.0];

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

/// `f` over `items`, in order, on as many scoped threads as the machine
/// has cores (the items in contiguous runs, the first on the calling
/// thread). A fit's model evaluations are independent of each other and
/// take milliseconds each: where one candidate is left running (the
/// longest of a round), its Jacobian's columns and its bump's grid use
/// the cores the others have finished with. The result is the same as
/// a sequential map's, whatever the core count.
fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per = items.len().div_ceil(cores.max(1)).max(1);
    if items.len() <= 1 || cores <= 1 {
        return items.iter().map(&f).collect();
    }
    let f = &f;
    std::thread::scope(|sc| {
        let mut runs = items.chunks(per);
        let first = runs.next().unwrap_or_default();
        let rest: Vec<_> = runs
            .map(|run| sc.spawn(move || run.iter().map(f).collect::<Vec<R>>()))
            .collect();
        let mut out: Vec<R> = first.iter().map(f).collect();
        for h in rest {
            match h.join() {
                Ok(v) => out.extend(v),
                Err(e) => std::panic::resume_unwind(e),
            }
        }
        out
    })
}

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

    /// The active set on S = (x − x₀, y − y₀)·A·(…) with x ≥ 0 and the
    /// free optimum at x₀ < 0, from x = 0: the step holds x and takes y
    /// to its optimum given x = 0 (y₀ − A₀₁/A₁₁·(0 − x₀)), exactly; a
    /// step for both, clamped after, leaves y short of it.
    #[test]
    fn a_parameter_pushed_past_its_bound_is_held_and_the_rest_solved() {
        let a = vec![vec![2.0, 0.9], vec![0.9, 1.0]];
        let (x0, y0) = (-1.0, 2.0);
        // At (0, 0): g = A·((0, 0) − (x0, y0)).
        let g = [a[0][0] * -x0 + a[0][1] * -y0, a[1][0] * -x0 + a[1][1] * -y0];
        let at_edge = |i: usize, d: f64| i == 0 && d < 0.0;
        let d = bounded_step(&a, &g, 0.0, at_edge).unwrap();
        let want = y0 - a[1][0] / a[1][1] * (0.0 - x0);
        assert_eq!(d[0], 0.0);
        assert!((d[1] - want).abs() < 1e-12, "{} against {want}", d[1]);
        // Free: the full step to (x0, y0); clamped after, y stops short.
        let free = bounded_step(&a, &g, 0.0, |_, _| false).unwrap();
        assert!((free[0] - x0).abs() < 1e-12 && (free[1] - y0).abs() < 1e-12);
        assert!((free[1] - want).abs() > 0.5);
        // Damped, the held row stays the identity's.
        let damped = bounded_step(&a, &g, 10.0, at_edge).unwrap();
        assert_eq!(damped[0], 0.0);
        assert!((damped[1] - -g[1] / (11.0 * a[1][1])).abs() < 1e-12);
        // Singular: None.
        assert!(bounded_step(&[vec![0.0; 2], vec![0.0; 2]], &g, 0.0, |_, _| false).is_none());
    }

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

    /// The parallel map is the sequential one, in order, for every
    /// length (around the core count and its multiples).
    #[test]
    fn par_map_is_the_sequential_map_in_order() {
        for n in 0..40usize {
            let items: Vec<usize> = (0..n).collect();
            let got = par_map(&items, |&i| i * i + 1);
            let want: Vec<usize> = items.iter().map(|&i| i * i + 1).collect();
            assert_eq!(got, want, "n = {n}");
        }
    }

    /// A model that cannot be evaluated gives no amplitude, not a panic.
    #[test]
    fn secant_amplitude_passes_on_a_failed_evaluation() {
        let r0 = vec![1.0, 2.0];
        assert_eq!(secant_amplitude(|_| None, r0, (-1.0, 1.0)), None);
    }
}
