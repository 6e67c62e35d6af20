//! The meter's averaging and time offset on a trace: the model read as
//! the meter reads it.
//!
//! A reading stamped t is the model at t + δ (δ: [`Effect::TimeOffset`])
//! averaged by the meter's kernel, in one of two domains ([`Averaging`]):
//!
//! ```text
//! window  T (MeterLag):      ȳ(t) = 1/T ∫₀ᵀ y(t + δ − u) du
//! first order τ (MeterResponse): ȳ(t) = ∫₀^∞ y(t + δ − u) e^(−u/τ)/τ du
//! ```
//!
//! y is the admittance (a detector integrating the current at a fixed
//! excitation, or a lock-in's RC output filter on I and Q) or the series
//! Cs reading itself (a meter averaging its own readings). For small
//! changes over the kernel the two agree; over a second of stretching
//! they differ by tenths of a pF, which the data resolve.
//!
//! The first-order filter starts settled on the trace's first instant;
//! the rows at a trace's ends whose reading could reach past the
//! recording are left out of the statistics ([`super::search`]).

use super::file::File;
use super::{Effect, Model, Params};
use crate::numerics::interp;
use num_complex::Complex64;

/// The most grid points one trace's kernel integral uses (64 MiB of
/// admittances).
pub const MAX_GRID: usize = 1 << 22;

/// What the meter averages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Averaging {
    /// The admittance (the current at a fixed excitation): Cs of the mean.
    #[default]
    Admittance,
    /// Its series Cs readings: the mean of Cs.
    Readings,
}

impl std::fmt::Display for Averaging {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Averaging::Admittance => "admittance averaged",
            Averaging::Readings => "readings averaged",
        })
    }
}

/// Predictions (pF) of a trace with time effects, the model `at(R, s, f)`
/// sampled on a grid eight times finer than the rows (cubic-corrected
/// trapezoids for the window, the exact first-order response of the
/// piecewise-linear samples for τ); with an offset alone, the model at
/// t + δ directly.
///
/// About 90 lines on purpose: the grid, its spacing and its node map are
/// shared by the instant, windowed and first-order paths; the parts that
/// stand alone ([`cumulative`], [`first_order`]) are functions of their
/// own.
pub(super) fn timed(
    file: &File,
    p: &Params,
    averaging: Averaging,
    at: impl Fn(f64, f64, f64) -> Option<Complex64>,
) -> Vec<f64> {
    let n = file.t.len();
    let (t0, t1) = (file.t[0], file.t[n - 1]);
    let window = p.get(Effect::MeterLag);
    let tau = p.get(Effect::MeterResponse);
    let offset = p.get(Effect::TimeOffset);
    let f = file.f[0];
    let inputs = |x: f64| {
        (
            interp(&file.t, &file.r, &file.corner, x),
            interp(&file.t, &file.s, &file.corner, x),
        )
    };
    let nan = Complex64::new(f64::NAN, f64::NAN);
    // The averaged quantity of an impedance, and the reading (pF) of an
    // average.
    let sample = |z: Complex64| match averaging {
        Averaging::Admittance => z.inv(),
        Averaging::Readings => Complex64::new(Model::series(z, f), 0.0),
    };
    let reading = |y: Complex64| match averaging {
        Averaging::Admittance => Model::series(y.inv(), f) * 1e12,
        Averaging::Readings => y.re * 1e12,
    };
    if window <= 1e-9 && tau <= 1e-9 {
        // An offset alone: the model at t + δ directly.
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
    // (rows packed closer than the kernel needs are over-resolved anyway).
    // With both kernels the window's own reach comes first.
    let reach = window.max(0.0) * if tau > 1e-9 { 2.0 } else { 1.0 };
    let span = t1 - t0 + reach + offset.abs();
    let h = ((t1 - t0) / ((n - 1).max(1) as f64 * 8.0)).max(span / MAX_GRID as f64);
    let (lo, hi) = (t0 - reach + offset.min(0.0) - h, t1 + offset.max(0.0) + h);
    let m = ((hi - lo) / h).ceil() as usize + 1;
    let grid: Vec<Complex64> = (0..m)
        .map(|j| {
            let (r, s) = inputs(lo + j as f64 * h);
            at(r, s, f).map_or(nan, sample)
        })
        .collect();
    // The sample at x, linear between grid nodes.
    let node = |x: f64| -> (usize, f64) {
        let u = ((x - lo) / h).clamp(0.0, (m - 1) as f64);
        let j = (u.floor() as usize).min(m - 2);
        (j, u - j as f64)
    };
    if window > 1e-9 {
        let cum = cumulative(&grid, h);
        // Integral over [lo, x]: cum at the left node plus the partial
        // trapezoid of the linear segment.
        let integral = |x: f64| {
            let (j, a) = node(x);
            cum[j] + h * a * (grid[j] + 0.5 * a * (grid[j + 1] - grid[j]))
        };
        if tau <= 1e-9 {
            return file
                .t
                .iter()
                .map(|&t| {
                    let b = t + offset;
                    reading((integral(b) - integral(b - window)) / window)
                })
                .collect();
        }
        // Both kernels (a window, then a first-order filter on its
        // output): the window's average at every node, filtered below.
        // Nodes whose window reaches before the grid hold the first full
        // window's value (the filter starts settled on it).
        let first = ((window / h).ceil() as usize).min(m - 1);
        let windowed: Vec<Complex64> = (0..m)
            .map(|j| {
                let x = lo + j.max(first) as f64 * h;
                (integral(x) - integral(x - window)) / window
            })
            .collect();
        return first_order(&windowed, tau, h, node, file, offset, reading);
    }
    first_order(&grid, tau, h, node, file, offset, reading)
}

/// The cumulative integral of the samples `grid` (spacing `h`) from its
/// first node: trapezoids with the four-point cubic end correction
/// −h/24·(y[j+2] − y[j+1] − y[j] + y[j−1]).
fn cumulative(grid: &[Complex64], h: f64) -> Vec<Complex64> {
    let m = grid.len();
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
    cum
}

/// The first-order response (time constant `tau`, s) of the samples
/// `grid` (spacing `h`, s), read at every row's t + `offset`.
fn first_order(
    grid: &[Complex64],
    tau: f64,
    h: f64,
    node: impl Fn(f64) -> (usize, f64),
    file: &File,
    offset: f64,
    reading: impl Fn(Complex64) -> f64,
) -> Vec<f64> {
    let m = grid.len();
    // First order: F' = (y − F)/τ, exact for y linear over each step of
    // length d from y_a to y_b, with E = e^(−d/τ):
    // F ← E·F + (1 − E)·y_b + (y_a − y_b)·(τ(1 − E) − d·E)/d.
    let step = |state: Complex64, ya: Complex64, yb: Complex64, d: f64| {
        if d <= 0.0 {
            return state;
        }
        let e = (-d / tau).exp();
        state * e + yb * (1.0 - e) + (ya - yb) * ((tau * (1.0 - e) - d * e) / d)
    };
    let mut filtered = Vec::with_capacity(m);
    let mut state = grid[0];
    filtered.push(state);
    for j in 1..m {
        state = step(state, grid[j - 1], grid[j], h);
        filtered.push(state);
    }
    file.t
        .iter()
        .map(|&t| {
            let (j, a) = node(t + offset);
            let yx = grid[j] + (grid[j + 1] - grid[j]) * a;
            reading(step(filtered[j], grid[j], yx, a * h))
        })
        .collect()
}
