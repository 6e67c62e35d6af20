//! The meter's integration window and time offset on a trace: the model
//! read as the meter reads it.

use super::prepared::File;
use super::{Effect, Model, Params};
use crate::numerics::interp;
use num_complex::Complex64;

/// The most grid points one trace's window integral uses (64 MiB of
/// admittances).
pub const MAX_GRID: usize = 1 << 22;

/// Predictions of a trace with time effects: with a window, the
/// admittance on a grid eight times finer than the rows, integrated over
/// each reading's window [t + δ − T, t + δ]; with an offset alone, the
/// model at t + δ directly.
pub(super) fn timed(file: &File, p: &Params, at: impl Fn(f64, f64, f64) -> Option<Complex64>) -> Vec<f64> {
    let n = file.t.len();
    let (t0, t1) = (file.t[0], file.t[n - 1]);
    let window = p.get(Effect::MeterLag);
    let offset = p.get(Effect::TimeOffset);
    let f = file.f[0];
    let inputs = |tau: f64| {
        (
            interp(&file.t, &file.r, &file.corner, tau),
            interp(&file.t, &file.s, &file.corner, tau),
        )
    };
    if window <= 1e-9 {
        return file
            .t
            .iter()
            .map(|&t| {
                let (r, s) = inputs(t + offset);
                at(r, s, f).map_or(f64::NAN, |z| Model::series(z, f) * 1e12)
            })
            .collect();
    }
    // Eight grid steps per row, but at most MAX_GRID points over the span
    // (rows packed closer than the window needs are over-resolved anyway).
    let span = t1 - t0 + window + offset.abs();
    let h = ((t1 - t0) / ((n - 1).max(1) as f64 * 8.0)).max(span / MAX_GRID as f64);
    let (lo, hi) = (t0 - window + offset.min(0.0) - h, t1 + offset.max(0.0) + h);
    let m = ((hi - lo) / h).ceil() as usize + 1;
    let grid: Vec<Complex64> = (0..m)
        .map(|j| {
            let (r, s) = inputs(lo + j as f64 * h);
            at(r, s, f).map_or(Complex64::new(f64::NAN, f64::NAN), |z| z.inv())
        })
        .collect();
    // Cumulative integral: trapezoids with the four-point cubic end
    // correction −h/24·(y[j+2] − y[j+1] − y[j] + y[j−1]).
    let mut cum = Vec::with_capacity(m);
    let mut acc = Complex64::default();
    cum.push(acc);
    for j in 1..m {
        let (a, b) = (j - 1, j);
        let mut seg = 0.5 * h * (grid[a] + grid[b]);
        if a >= 1 && b + 1 < m {
            seg -= h / 24.0 * (grid[b + 1] - grid[b] - grid[a] + grid[a - 1]);
        }
        acc += seg;
        cum.push(acc);
    }
    // Integral of y over [lo, x]: cum at the left node plus the partial
    // trapezoid of the linear segment.
    let integral = |x: f64| {
        let u = ((x - lo) / h).clamp(0.0, (m - 1) as f64);
        let j = (u.floor() as usize).min(m - 2);
        let a = u - j as f64;
        cum[j] + h * a * (grid[j] + 0.5 * a * (grid[j + 1] - grid[j]))
    };
    file.t
        .iter()
        .map(|&t| {
            let b = t + offset;
            let y = (integral(b) - integral(b - window)) / window;
            Model::series(y.inv(), f) * 1e12
        })
        .collect()
}
