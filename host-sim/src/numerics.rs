//! The numerical helpers every analysis shares, each written once:
//! linear algebra, fits, interpolation, statistics, and what a series
//! meter reads from an impedance.

use num_complex::Complex64;
use std::f64::consts::TAU;

/// Series capacitance (F) a meter reads from an impedance `z` (Ω) at
/// `f` (Hz): Cs = −1/(ω·Im Z).
pub fn series_cs(z: Complex64, f: f64) -> f64 {
    -1.0 / (TAU * f * z.im)
}

/// Solve a small dense system by Gaussian elimination with partial pivoting.
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
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

/// Robust noise σ of a residual series (its unit): the median absolute
/// second difference ×1.4826/√6. White noise passes, smooth model errors
/// cancel, and sparse jumps do not move a median.
pub fn noise_sigma(e: &[f64]) -> f64 {
    let mut d2: Vec<f64> = e.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs()).collect();
    d2.sort_by(f64::total_cmp);
    d2.get(d2.len() / 2).copied().unwrap_or(f64::NAN) * 1.4826 / 6f64.sqrt()
}

/// Least-squares c0 + c1·x + c2·x² through `pts` (normal equations,
/// centred and scaled for conditioning).
pub fn quadratic_fit(pts: &[(f64, f64)]) -> [f64; 3] {
    let n = pts.len() as f64;
    let xm = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let xs = pts
        .iter()
        .map(|p| (p.0 - xm).abs())
        .fold(0.0, f64::max)
        .max(1e-12);
    let ym = pts.iter().map(|p| p.1).sum::<f64>() / n;
    // Fit y − ym = a + b·u + c·u², u = (x − xm)/xs: normal equations.
    let (mut m, mut rhs) = (vec![vec![0.0f64; 3]; 3], vec![0.0f64; 3]);
    for &(x, y) in pts {
        let u = (x - xm) / xs;
        let row = [1.0, u, u * u];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += row[i] * row[j];
            }
            rhs[i] += row[i] * (y - ym);
        }
    }
    // Fewer than three distinct points leave the system singular: fall
    // back to the lower orders that are determined.
    let [a, b, c] = match solve(m.clone(), rhs.clone()) {
        Some(x) => [x[0], x[1], x[2]],
        None => match solve(vec![m[0][..2].to_vec(), m[1][..2].to_vec()], rhs[..2].to_vec()) {
            Some(x) => [x[0], x[1], 0.0],
            None => [rhs[0] / m[0][0].max(1.0), 0.0, 0.0],
        },
    };
    // Back to x: y = ym + a + b(x − xm)/xs + c(x − xm)²/xs².
    let (b1, c1) = (b / xs, c / (xs * xs));
    [ym + a - b1 * xm + c1 * xm * xm, b1 - 2.0 * c1 * xm, c1]
}

/// RMS and max of |e| over the finite values, and how many were not finite.
pub fn rms_max(e: impl IntoIterator<Item = f64>) -> (f64, f64, usize) {
    let (mut ss, mut mx, mut n, mut bad) = (0.0, 0.0f64, 0usize, 0usize);
    for v in e {
        if v.is_finite() {
            ss += v * v;
            mx = mx.max(v.abs());
            n += 1;
        } else {
            bad += 1;
        }
    }
    (if n > 0 { (ss / n as f64).sqrt() } else { f64::NAN }, mx, bad)
}

/// Piecewise-linear interpolation through `pts` (ascending in x),
/// extrapolating the end segments.
pub fn lerp(pts: &[(f64, f64)], x: f64) -> f64 {
    let k = pts.partition_point(|p| p.0 <= x).clamp(1, pts.len() - 1);
    let (a, b) = (pts[k - 1], pts[k]);
    a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
}

/// Cubic Hermite interpolation of `y` sampled at ascending `t`, at `x`
/// (clamped to the ends), aware of corners: at a sample flagged in
/// `corner` (where the stretch profile turns), each side's tangent is
/// taken from its own side only (three-point one-sided difference), so a
/// piecewise-smooth signal keeps its kink; elsewhere tangents are central
/// differences. Exact on lines and on piecewise lines with corners at
/// samples.
pub fn interp(t: &[f64], y: &[f64], corner: &[bool], x: f64) -> f64 {
    let n = t.len();
    if n == 1 || x <= t[0] {
        return y[0];
    }
    if x >= t[n - 1] {
        return y[n - 1];
    }
    let k = t.partition_point(|&v| v <= x).clamp(1, n - 1) - 1;
    let (m0, m1) = (
        tangent(t, y, corner, k, true),
        tangent(t, y, corner, k + 1, false),
    );
    hermite(t, y, k, (m0, m1), x)
}

/// [`interp`]'s tangent at sample `i` (per unit of t) on the side
/// `fwd` (towards i + 1) or not: one-sided at a corner and at the ends
/// (from the points i, i ± 1, i ± 2, or the secant to i ± 1 when there is
/// no third point on that side), central elsewhere.
pub fn tangent(t: &[f64], y: &[f64], corner: &[bool], i: usize, fwd: bool) -> f64 {
    let n = t.len();
    let is_corner = |i: usize| i == 0 || i == n - 1 || corner.get(i).copied().unwrap_or(false);
    if !is_corner(i) {
        return (y[i + 1] - y[i - 1]) / (t[i + 1] - t[i - 1]);
    }
    let (a, b) = if fwd {
        (i + 1, i + 2)
    } else {
        (i.wrapping_sub(1), i.wrapping_sub(2))
    };
    let b_ok = if fwd {
        b < n && !is_corner(a)
    } else {
        i >= 2 && !is_corner(a)
    };
    let da = (y[a] - y[i]) / (t[a] - t[i]);
    if b_ok {
        let db = (y[b] - y[i]) / (t[b] - t[i]);
        // Derivative at t_i of the parabola through the three points.
        let (ha, hb) = (t[a] - t[i], t[b] - t[i]);
        (da * hb - db * ha) / (hb - ha)
    } else {
        da
    }
}

/// The cubic Hermite piece from sample `k` to `k + 1` with the tangents
/// `m` (per unit of t, at each end) at `x` in it.
#[inline]
pub fn hermite(t: &[f64], y: &[f64], k: usize, m: (f64, f64), x: f64) -> f64 {
    let h = t[k + 1] - t[k];
    let u = (x - t[k]) / h;
    let (m0, m1) = (m.0 * h, m.1 * h);
    let (u2, u3) = (u * u, u * u * u);
    (2.0 * u3 - 3.0 * u2 + 1.0) * y[k]
        + (u3 - 2.0 * u2 + u) * m0
        + (-2.0 * u3 + 3.0 * u2) * y[k + 1]
        + (u3 - u2) * m1
}

/// Samples where the (piecewise-linear) stretch profile turns: a second
/// difference above 1 % of the largest step.
pub fn corners(t: &[f64], s: &[f64]) -> Vec<bool> {
    let n = s.len();
    let step = s.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    (0..n)
        .map(|i| {
            if i == 0 || i + 1 >= n {
                return true;
            }
            let (h0, h1) = (t[i] - t[i - 1], t[i + 1] - t[i]);
            let d2 = (s[i + 1] - s[i]) / h1 * h0 - (s[i] - s[i - 1]);
            d2.abs() > 0.01 * step
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_fit_recovers_an_exact_quadratic() {
        let f = |x: f64| 210e-12 + 2.1e-12 * x - 0.01e-12 * x * x;
        let pts: Vec<(f64, f64)> = (0..=10).map(|k| (3.0 * k as f64, f(3.0 * k as f64))).collect();
        let [a, b, c] = quadratic_fit(&pts);
        for x in [0.0, 7.5, 30.0] {
            let got = a + x * (b + x * c);
            assert!((got / f(x) - 1.0).abs() < 1e-12, "{x}: {got} vs {}", f(x));
        }
    }

    #[test]
    fn hermite_is_exact_on_lines_and_keeps_corners() {
        let t: Vec<f64> = (0..10).map(|k| 0.02 * k as f64).collect();
        let y: Vec<f64> = t.iter().map(|&x| 3.0 - 2.0 * x).collect();
        let none = vec![false; 10];
        let interp = |t: &[f64], y: &[f64], x: f64| interp(t, y, &corners(t, y), x);
        for x in [0.0, 0.013, 0.1, 0.177, 0.18] {
            assert!((interp(&t, &y, x) - (3.0 - 2.0 * x)).abs() < 1e-12);
        }
        assert_eq!(interp(&t, &y, -1.0), 3.0);
        assert_eq!(interp(&t, &y, 9.0), y[9]);
        // A trapezoid corner at a sample: both sides stay exact.
        let y: Vec<f64> = t.iter().map(|&x| if x < 0.1 { 20.0 * x } else { 2.0 }).collect();
        for x in [0.05, 0.07, 0.09, 0.11, 0.13, 0.15] {
            let want = if x < 0.1 { 20.0 * x } else { 2.0 };
            assert!(
                (interp(&t, &y, x) - want).abs() < 1e-9,
                "{x}: {}",
                interp(&t, &y, x)
            );
        }
        // Smooth data: close to the function (error O(h³) here).
        let y: Vec<f64> = t.iter().map(|&x| (5.0 * x).exp()).collect();
        let x = 0.07;
        assert!((self::interp(&t, &y, &none, x) / (5.0 * x).exp() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn solve_and_statistics() {
        let x = solve(vec![vec![2.0, 1.0], vec![1.0, 3.0]], vec![3.0, 5.0]).unwrap();
        assert!((x[0] - 0.8).abs() < 1e-15 && (x[1] - 1.4).abs() < 1e-15);
        assert_eq!(solve(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]), None);
        let (rms, max, bad) = rms_max([3.0, -4.0, f64::NAN]);
        assert_eq!((rms, max, bad), ((12.5f64).sqrt(), 4.0, 1));
        assert_eq!(lerp(&[(0.0, 1.0), (2.0, 5.0)], 3.0), 7.0);
        let z = Complex64::new(0.0, -1.0 / (TAU * 1e3 * 200e-12));
        assert!((series_cs(z, 1e3) / 200e-12 - 1.0).abs() < 1e-15);
    }
}
