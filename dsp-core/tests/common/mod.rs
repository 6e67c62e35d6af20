//! f64 reference models shared by the integration tests, independent of
//! the fixed-point kernels.
#![allow(dead_code)]

use num_complex::Complex64;

/// ζ = ωC·Z of an n-element ladder by the impedance (Möbius) recursion.
pub fn ladder_ref(n: u32, x: f64) -> Complex64 {
    let (r, y) = (1.0 / n as f64, Complex64::new(0.0, x / n as f64));
    let mut z = r + 1.0 / y;
    for _ in 1..n {
        z = r + 1.0 / (y + 1.0 / z);
    }
    z * x
}

/// ζ of the continuous line, x/(γ·tanh γ) with γ = √(jx).
pub fn continuous_ref(x: f64) -> Complex64 {
    let g = Complex64::new(0.0, x).sqrt();
    x / (g * g.tanh())
}

/// Reference ζ for a model.
pub fn zeta_ref(model: dsp_core::tline::LineModel, x: f64) -> Complex64 {
    match model {
        dsp_core::tline::LineModel::Ladder(n) => ladder_ref(n as u32, x),
        dsp_core::tline::LineModel::Continuous => continuous_ref(x),
    }
}

/// Log-spaced points from a to b inclusive.
pub fn log_grid(a: f64, b: f64, points: usize) -> Vec<f64> {
    (0..points)
        .map(|k| (a.ln() + (b / a).ln() * k as f64 / (points - 1) as f64).exp())
        .collect()
}

/// RMS and max of |e|.
pub fn rms_max(e: &[f64]) -> (f64, f64) {
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
    (rms, e.iter().fold(0f64, |m, v| m.max(v.abs())))
}

/// The continuous line with leads ℓ on a lossy film, f64, Ω:
/// ℓ·R + √(R/Y)·coth √(RY), Y = jωC·(1 − j·tan δ).
#[allow(dead_code)]
pub fn z_lossy(lead: f64, r: f64, c: f64, f: f64, tan_d: f64) -> Complex64 {
    let y = Complex64::new(0.0, std::f64::consts::TAU * f * c) * Complex64::new(1.0, -tan_d);
    let g = (r * y).sqrt();
    lead * r + (r / y).sqrt() / g.tanh()
}
