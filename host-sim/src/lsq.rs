//! Bounded weighted least squares: the one fit of the host tools
//! (`identify`'s models, `live calibrate`'s sensors).
//!
//! Minimises S(x) = Σ rᵢ(x)² over box bounds lo ≤ x ≤ hi, where the
//! residuals r are noise-weighted (each divided by its 1σ), so that S is
//! a χ². Projected Levenberg–Marquardt:
//!
//! - the Jacobian by one-sided differences of 10⁻⁴ of each unknown's
//!   range, stepping inwards at its upper bound; its columns on the
//!   machine's cores ([`par_map`]);
//! - each step solves (JᵀJ + λ·diag JᵀJ)·d = −Jᵀr with an active set: an
//!   unknown at a bound that the step pushes outward is held there and
//!   the step solved again for the others, until none more is held (a
//!   step for all, clamped after, crawls along the bound);
//! - λ starts at 10⁻³, grows ×4 on a step that does not lower S (×10 on
//!   a singular system) and shrinks ÷4 on one that does;
//! - converged when a step lowers S by under 0.01·max(S/n, 1) (n
//!   residuals: S/n far above 1 is a model far from the data, not walked
//!   along its valley for changes no criterion sees), or moves every
//!   unknown by under 10⁻⁹ of its range.
//!
//! [`covariance`] gives s²·(JᵀJ)⁻¹ at the optimum.

use crate::numerics::solve;

/// A least-squares problem: its unknowns' bounds and its weighted
/// residuals.
pub trait Problem: Sync {
    /// Each unknown's bounds (lo < hi, both finite: the Jacobian's step
    /// and the convergence test are fractions of the range).
    fn bounds(&self) -> &[(f64, f64)];

    /// The noise-weighted residuals at `x`, in a fixed order; None where
    /// the model cannot be evaluated.
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>>;
}

/// A point and what it leaves.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// The unknowns.
    pub x: Vec<f64>,
    /// The weighted residuals there.
    pub r: Vec<f64>,
    /// S = Σ r².
    pub s: f64,
}

impl Point {
    /// `x` evaluated on `p`; None where it cannot be, or S is not finite.
    pub fn at(p: &impl Problem, x: Vec<f64>) -> Option<Self> {
        let r = p.residuals(&x)?;
        let s = r.iter().fold(0.0, |s, v| s + v * v);
        s.is_finite().then_some(Self { x, r, s })
    }
}

/// The outcome of [`fit`].
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The lowest point found.
    pub best: Point,
    /// JᵀJ there, when the last iteration computed it at that point.
    pub jtj: Option<Vec<Vec<f64>>>,
}

/// Levenberg–Marquardt on `p` from `start` (within the bounds) for at
/// most `steps` iterations (module docs).
pub fn fit(p: &impl Problem, start: Point, steps: usize) -> Fitted {
    let bounds = p.bounds();
    let mut best = start;
    let mut lambda = 1e-3;
    for _ in 0..steps {
        let Some((a, g)) = normal_equations(p, &best) else {
            break;
        };
        let (mut improved, mut moved) = (false, false);
        let at_edge = |i: usize, di: f64| {
            let (lo, hi) = bounds[i];
            let (v, edge) = (best.x[i], 1e-9 * (hi - lo));
            (v <= lo + edge && di < 0.0) || (v >= hi - edge && di > 0.0)
        };
        while lambda < 1e10 {
            let Some(d) = bounded_step(&a, &g, lambda, at_edge) else {
                lambda *= 10.0;
                continue;
            };
            let q: Vec<f64> = (0..d.len())
                .map(|i| (best.x[i] + d[i]).clamp(bounds[i].0, bounds[i].1))
                .collect();
            let still = |i: usize| (q[i] - best.x[i]).abs() <= 1e-9 * (bounds[i].1 - bounds[i].0);
            if (0..q.len()).all(still) {
                break;
            }
            match Point::at(p, q) {
                Some(next) if next.s < best.s => {
                    let n = best.r.len().max(1) as f64;
                    improved = best.s - next.s > 1e-2 * (best.s / n).max(1.0);
                    moved = true;
                    best = next;
                    lambda = (lambda / 4.0).max(1e-9);
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !improved {
            // The point is unchanged only if no step was taken.
            return Fitted {
                best,
                jtj: (!moved).then_some(a),
            };
        }
    }
    Fitted { best, jtj: None }
}

/// JᵀJ and Jᵀr at `at` (module docs for J); None where a column cannot be
/// evaluated.
pub fn normal_equations(p: &impl Problem, at: &Point) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let bounds = p.bounds();
    let unknowns: Vec<usize> = (0..at.x.len()).collect();
    let jac = par_map(&unknowns, |&i| {
        let (lo, hi) = bounds[i];
        let h = 1e-4 * (hi - lo);
        let (v, sign) = if at.x[i] + h <= hi {
            (at.x[i] + h, 1.0)
        } else {
            (at.x[i] - h, -1.0)
        };
        let mut x = at.x.clone();
        x[i] = v;
        let rj = p.residuals(&x)?;
        Some(
            rj.iter()
                .zip(&at.r)
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
    let g = jac.iter().map(|x| dot(x, &at.r)).collect();
    Some((a, g))
}

/// The covariance s²·(JᵀJ)⁻¹ of the unknowns (None: singular, nothing
/// pinned down).
pub fn covariance(jtj: &[Vec<f64>], s2: f64) -> Option<Vec<Vec<f64>>> {
    let k = jtj.len();
    let cols = (0..k)
        .map(|i| {
            let mut unit = vec![0.0; k];
            unit[i] = 1.0;
            solve(jtj.to_vec(), unit)
        })
        .collect::<Option<Vec<Vec<f64>>>>()?;
    Some(
        (0..k)
            .map(|i| (0..k).map(|j| s2 * cols[j][i]).collect())
            .collect(),
    )
}

/// Each unknown's 1σ (∞ without a covariance) and the correlations
/// ρᵢⱼ = Cᵢⱼ/√(CᵢᵢCⱼⱼ) (NaN without one), from `covariance` of `k`
/// unknowns.
pub fn sigma_correlation(cov: Option<&[Vec<f64>]>, k: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    let Some(c) = cov else {
        return (vec![f64::INFINITY; k], vec![vec![f64::NAN; k]; k]);
    };
    let sigma = (0..k).map(|i| c[i][i].max(0.0).sqrt()).collect();
    let rho = (0..k)
        .map(|i| (0..k).map(|j| c[i][j] / (c[i][i] * c[j][j]).sqrt()).collect())
        .collect();
    (sigma, rho)
}

/// The damped Gauss–Newton step d of (A + λ·diag A)·d = −g, an unknown
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

/// `f` over `items`, in order, on as many scoped threads as the machine
/// has cores (the items in contiguous runs, the first on the calling
/// thread): model evaluations are independent of each other, and where
/// one fit is left running its Jacobian's columns use the cores the
/// others have finished with. The result is a sequential map's, whatever
/// the core count.
pub fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a·exp(−b·t), noise-free data weighted as of σ = 10⁻³: the fit
    /// finds a and b to a small fraction of their 1σ (≈ 4·10⁻⁴), and its
    /// covariance matches the f64 reference (JᵀJ)⁻¹ from the analytic
    /// Jacobian to 0.5 % of σᵢσⱼ (the one-sided differences' error, of
    /// the order of the step, 10⁻⁴ of the range, times t).
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
        bounds: Vec<(f64, f64)>,
    }

    impl Problem for Decay {
        fn bounds(&self) -> &[(f64, f64)] {
            &self.bounds
        }
        fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
            Some(
                self.t
                    .iter()
                    .zip(&self.y)
                    .map(|(t, y)| (x[0] * (-x[1] * t).exp() - y) / SIGMA)
                    .collect(),
            )
        }
    }

    const SIGMA: f64 = 1e-3;

    fn decay(a: f64, b: f64, bounds: Vec<(f64, f64)>) -> Decay {
        let t: Vec<f64> = (0..40).map(|k| k as f64 * 0.1).collect();
        let y = t.iter().map(|t| a * (-b * t).exp()).collect();
        Decay { t, y, bounds }
    }

    #[test]
    fn finds_the_optimum_and_its_covariance() {
        let p = decay(3.0, 0.7, vec![(0.0, 10.0), (0.0, 5.0)]);
        let start = Point::at(&p, vec![1.0, 2.0]).unwrap();
        let f = fit(&p, start, 100);
        assert!(
            (f.best.x[0] - 3.0).abs() < 1e-4 && (f.best.x[1] - 0.7).abs() < 1e-4,
            "{:?}",
            f.best.x
        );
        // The analytic JᵀJ at the optimum.
        let (a, b) = (3.0, 0.7);
        let cols: [Vec<f64>; 2] = [
            p.t.iter().map(|t| (-b * t).exp() / SIGMA).collect(),
            p.t.iter().map(|t| -a * t * (-b * t).exp() / SIGMA).collect(),
        ];
        let jtj: Vec<Vec<f64>> = (0..2)
            .map(|i| (0..2).map(|j| dot(&cols[i], &cols[j])).collect())
            .collect();
        let exact = covariance(&jtj, 1.0).unwrap();
        let (num, _) = normal_equations(&p, &f.best).unwrap();
        let got = covariance(&num, 1.0).unwrap();
        for i in 0..2 {
            for j in 0..2 {
                let rel =
                    (got[i][j] - exact[i][j]).abs() / exact[i][i].abs().sqrt() / exact[j][j].abs().sqrt();
                assert!(rel < 5e-3, "C[{i}][{j}] {} vs {}", got[i][j], exact[i][j]);
            }
        }
    }

    #[test]
    fn an_optimum_beyond_a_bound_stops_on_it() {
        // b's optimum (0.7) lies below its lower bound 1: the fit ends on
        // the bound and a still reaches the best value there.
        let p = decay(3.0, 0.7, vec![(0.0, 10.0), (1.0, 5.0)]);
        let f = fit(&p, Point::at(&p, vec![1.0, 3.0]).unwrap(), 100);
        assert_eq!(f.best.x[1], 1.0);
        let grid = (0..=2000).map(|k| k as f64 * 0.005);
        let best_a = grid
            .map(|a| (a, Point::at(&p, vec![a, 1.0]).unwrap().s))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap();
        assert!(
            (f.best.x[0] - best_a.0).abs() <= 0.005,
            "{} vs {}",
            f.best.x[0],
            best_a.0
        );
    }

    #[test]
    fn singular_problems_have_no_covariance() {
        let (sigma, rho) =
            sigma_correlation(covariance(&[vec![1.0, 1.0], vec![1.0, 1.0]], 1.0).as_deref(), 2);
        assert!(sigma.iter().all(|s| s.is_infinite()));
        assert!(rho.iter().flatten().all(|r| r.is_nan()));
    }

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
}
