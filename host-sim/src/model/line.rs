//! Uniform line pieces in f64.

use num_complex::Complex64;

/// Continuous uniform line: Z = z / (γ·tanh γ), γ = √(z·y), z = R (Ω,
/// complex where the film's conductivity relaxes), y = G + jωC (S).
pub(super) fn continuous(r: impl Into<Complex64>, y: Complex64) -> Complex64 {
    let r: Complex64 = r.into();
    let g = (y * r).sqrt();
    if g.norm() < 1e-6 {
        return y.inv() + r / 3.0;
    }
    r / (g * g.tanh())
}

/// A uniform piece (r Ω, y S) in front of a load (None: open end).
pub(super) fn piece(r: impl Into<Complex64>, y: Complex64, load: Option<Complex64>) -> Complex64 {
    let r: Complex64 = r.into();
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
