//! Uniform line pieces in f64.

use num_complex::Complex64;

/// Continuous uniform line: Z = z / (γ·tanh γ), γ = √(z·y), z = R (Ω,
/// complex where the film's conductivity relaxes), y = G + jωC (S).
pub(crate) fn continuous(r: impl Into<Complex64>, y: Complex64) -> Complex64 {
    let r: Complex64 = r.into();
    let g = (y * r).sqrt();
    if g.norm() < 1e-6 {
        return y.inv() + r / 3.0;
    }
    r / (g * g.tanh())
}

/// cosh γ and sinh(γ)/γ as power series in x = γ² (both entire):
/// Σ xᵏ/(2k)! and Σ xᵏ/(2k + 1)!, to 8 terms, for |x| ≤ [`SERIES_X`]
/// (truncation below 0.5⁸/16! ≈ 2·10⁻¹⁶).
fn cosh_sinhc(x: Complex64) -> (Complex64, Complex64) {
    // 1/(2k)! and 1/(2k + 1)!, k = 0..8.
    const EVEN: [f64; 8] = [
        1.0,
        1.0 / 2.0,
        1.0 / 24.0,
        1.0 / 720.0,
        1.0 / 40320.0,
        1.0 / 3628800.0,
        1.0 / 479001600.0,
        1.0 / 87178291200.0,
    ];
    const ODD: [f64; 8] = [
        1.0,
        1.0 / 6.0,
        1.0 / 120.0,
        1.0 / 5040.0,
        1.0 / 362880.0,
        1.0 / 39916800.0,
        1.0 / 6227020800.0,
        1.0 / 1307674368000.0,
    ];
    (real_poly(&EVEN, x), real_poly(&ODD, x))
}

/// Σ aₖxᵏ, real aₖ, at complex x, by the second-order Horner scheme
/// (Goertzel; Knuth, TAOCP 4.6.4): the remainder of the polynomial
/// divided by (z − x)(z − x̄) = z² − 2Re(x)·z + |x|², in real arithmetic
/// (two real products a coefficient, where complex Horner takes four).
fn real_poly(a: &[f64; 8], x: Complex64) -> Complex64 {
    let (r, s) = (2.0 * x.re, x.norm_sqr());
    let (mut b1, mut b2) = (a[7], 0.0);
    for &ak in a[1..7].iter().rev() {
        (b1, b2) = (ak + r * b1 - s * b2, b1);
    }
    // p(x) = b₁·x + (a₀ − |x|²·b₂).
    Complex64::new(b1 * x.re + a[0] - s * b2, b1 * x.im)
}

/// The largest |γ²| = |r·y| of a piece computed by [`cosh_sinhc`]'s
/// series (no square root or hyperbolic functions: a piece of a
/// 24-piece cascade at 6 kHz has |γ²| ≈ 0.01).
const SERIES_X: f64 = 0.5;

/// A uniform piece (r Ω, y S) in front of a load (None: open end).
///
/// With C = cosh γ, S = sinh(γ)/γ (so Z₀·sinh γ = r·S, sinh γ/Z₀ = y·S):
/// Z = (Z_L·C + r·S)/(Z_L·y·S + C), open end C/(y·S).
pub(super) fn piece(r: impl Into<Complex64>, y: Complex64, load: Option<Complex64>) -> Complex64 {
    let r: Complex64 = r.into();
    let x = r * y;
    if x.norm_sqr() <= SERIES_X * SERIES_X {
        let (c, s) = cosh_sinhc(x);
        return match load {
            None => c / (y * s),
            Some(zl) => (zl * c + r * s) / (zl * y * s + c),
        };
    }
    let Some(zl) = load else {
        return continuous(r, y);
    };
    let g = (y * r).sqrt();
    if g.norm() < 1e-6 {
        return r + (y + zl.inv()).inv();
    }
    let z0 = g / y;
    let t = g.tanh();
    z0 * (zl + z0 * t) / (z0 + zl * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The series against the hyperbolic functions over |r·y| ≤ 0.5, all
    /// phases (open end and loaded, loads from 10⁻³ to 10³ of |Z₀|):
    /// relative error under 10⁻¹².
    #[test]
    fn series_piece_matches_the_hyperbolic_one() {
        let exact = |r: Complex64, y: Complex64, load: Option<Complex64>| {
            let g = (y * r).sqrt();
            let z0 = g / y;
            let t = g.tanh();
            match load {
                None => z0 / t,
                Some(zl) => z0 * (zl + z0 * t) / (z0 + zl * t),
            }
        };
        let mut worst = 0.0f64;
        for m in [1e-4, 1e-2, 0.1, 0.3, 0.5] {
            for k in 0..24 {
                let ph = k as f64 / 24.0 * std::f64::consts::TAU;
                let x = Complex64::from_polar(m, ph);
                let r = Complex64::new(3e4, -2e3);
                let y = x / r;
                let z0 = (r / y).sqrt();
                for l in [None, Some(1e-3), Some(1.0), Some(1e3)] {
                    let load = l.map(|a| z0 * Complex64::from_polar(a, 0.7 * ph));
                    let (a, b) = (piece(r, y, load), exact(r, y, load));
                    worst = worst.max((a - b).norm() / b.norm());
                }
            }
        }
        assert!(worst < 1e-12, "{worst}");
    }

    /// The second-order Horner scheme against complex Horner over the
    /// series' whole domain (|x| ≤ 0.5, all phases): within 10⁻¹⁵ of the
    /// value's size.
    #[test]
    fn real_poly_is_complex_horner() {
        let a = [1.0, -0.5, 0.25, 3.0, -2.0, 1e-3, 7.0, -1.5];
        let mut worst = 0.0f64;
        for m in [0.0, 1e-6, 1e-3, 0.1, 0.3, 0.5] {
            for k in 0..36 {
                let x = Complex64::from_polar(m, k as f64 / 36.0 * std::f64::consts::TAU);
                let mut h = Complex64::new(a[7], 0.0);
                for &c in a[..7].iter().rev() {
                    h = h * x + c;
                }
                worst = worst.max((real_poly(&a, x) - h).norm() / h.norm());
            }
        }
        assert!(worst < 1e-15, "{worst}");
    }
}
