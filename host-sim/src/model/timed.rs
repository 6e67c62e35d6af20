//! The meter's averaging and time offset on a trace: the model read as
//! the meter reads it.
//!
//! A reading stamped t is the model at t + δ (δ: [`Effect::TimeOffset`])
//! averaged by the meter's kernel, in one of two domains ([`Averaging`]):
//!
//! ```text
//! window  T (MeterLag):      ȳ(t) = 1/T ∫₀ᵀ y(t + δ − u) du
//! first order τ (MeterResponse): ȳ(t) = ∫₀^∞ y(t + δ − u) e^(−u/τ)/τ du
//! order n (MeterOrder):          ȳ(t) = ∫₀^∞ y(t + δ − u) uⁿ⁻¹e^(−u/τ)/((n − 1)!·τⁿ) du
//! ```
//!
//! A response of order n is n first-order sections in cascade (a
//! lock-in's output filter at 6·n dB/octave); a fractional order n + a
//! is (1 − a)·(order n) + a·(order n + 1).
//!
//! y is the admittance (a detector integrating the current at a fixed
//! excitation, or a lock-in's RC output filter on I and Q) or the series
//! Cs reading itself (a meter averaging its own readings). For small
//! changes over the kernel the two agree; over a second of stretching
//! they differ by tenths of a pF, which the data resolve.
//!
//! A meter that takes one reading per row of the data and averages its
//! readings is a kernel in discrete time, on the data's own row grid
//! (interval Δ, the trace's median step before decimation):
//!
//! ```text
//! mean of N readings (MeterMean):  ȳ(t) = 1/N Σ_{j<N} y(t + δ − jΔ)   (a fraction of N weighs the oldest in part)
//! weighted mean (MeterEwma):       ȳ(t) = Σ_j (1 − m)·mʲ·y(t + δ − jΔ)
//! ```
//!
//! δ, fitted with either, is the meter's delay. A discrete kernel is not
//! combined with a continuous one (`identify` fits one kernel at a time).
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
/// The grid, its spacing and its node map ([`Grid`]) are shared by the
/// windowed and first-order paths.
pub(super) fn timed(
    file: &File,
    p: &Params,
    averaging: Averaging,
    at: impl Fn(f64, f64, f64) -> Option<Complex64>,
) -> Vec<f64> {
    let window = p.get(Effect::MeterLag);
    let tau = p.get(Effect::MeterResponse);
    let order = p.get(Effect::MeterOrder);
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
    let y_at = |x: f64| {
        let (r, s) = inputs(x);
        at(r, s, f).map_or(nan, sample)
    };
    let (mean_n, memory) = (p.get(Effect::MeterMean), p.get(Effect::MeterEwma));
    if mean_n > 0.0 || memory > 0.0 {
        return discrete(file, offset, mean_n, memory, y_at, reading);
    }
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
    let grid = Grid::new(file, window, tau, offset, y_at);
    if window > 1e-9 {
        return windowed(file, &grid, window, (tau, order), offset, reading);
    }
    first_order(
        &grid.y,
        (tau, order),
        grid.h,
        |x| grid.node(x),
        file,
        offset,
        reading,
    )
}

/// The averaged quantity on a uniform grid of time around a trace.
struct Grid {
    /// The first node's time, s.
    lo: f64,
    /// The spacing, s.
    h: f64,
    /// The samples at the nodes.
    y: Vec<Complex64>,
}

impl Grid {
    /// Eight grid steps per row of `file`, but at most [`MAX_GRID`]
    /// points over the span (rows packed closer than the kernel needs
    /// are over-resolved anyway), reaching back as far as the kernels
    /// (`window`, then `tau`) and `offset` need; the samples `y_at`.
    /// With both kernels the window's own reach comes first.
    fn new(file: &File, window: f64, tau: f64, offset: f64, y_at: impl Fn(f64) -> Complex64) -> Self {
        let n = file.t.len();
        let (t0, t1) = (file.t[0], file.t[n - 1]);
        let reach = window.max(0.0) * if tau > 1e-9 { 2.0 } else { 1.0 };
        let span = t1 - t0 + reach + offset.abs();
        let h = ((t1 - t0) / ((n - 1).max(1) as f64 * 8.0)).max(span / MAX_GRID as f64);
        let (lo, hi) = (t0 - reach + offset.min(0.0) - h, t1 + offset.max(0.0) + h);
        let m = ((hi - lo) / h).ceil() as usize + 1;
        let y = (0..m).map(|j| y_at(lo + j as f64 * h)).collect();
        Self { lo, h, y }
    }

    /// The node left of time `x` and the fraction of the step beyond it
    /// (the sample at x is linear between nodes).
    fn node(&self, x: f64) -> (usize, f64) {
        let m = self.y.len();
        let u = ((x - self.lo) / self.h).clamp(0.0, (m - 1) as f64);
        let j = (u.floor() as usize).min(m - 2);
        (j, u - j as f64)
    }
}

/// The window's average of the samples `grid` (length `window`, s),
/// then, where `tau` > 0, the first-order sections of `(tau, order)` on
/// its output; read at every row's t + `offset`.
fn windowed(
    file: &File,
    grid: &Grid,
    window: f64,
    (tau, order): (f64, f64),
    offset: f64,
    reading: impl Fn(Complex64) -> f64,
) -> Vec<f64> {
    let (h, y, m) = (grid.h, &grid.y, grid.y.len());
    let cum = cumulative(y, h);
    // Integral over [lo, x]: cum at the left node plus the partial
    // trapezoid of the linear segment.
    let integral = |x: f64| {
        let (j, a) = grid.node(x);
        cum[j] + h * a * (y[j] + 0.5 * a * (y[j + 1] - y[j]))
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
    // Both kernels (a window, then a first-order filter on its output):
    // the window's average at every node, filtered below. Nodes whose
    // window reaches before the grid hold the first full window's value
    // (the filter starts settled on it).
    let first = ((window / h).ceil() as usize).min(m - 1);
    let windowed: Vec<Complex64> = (0..m)
        .map(|j| {
            let x = grid.lo + j.max(first) as f64 * h;
            (integral(x) - integral(x - window)) / window
        })
        .collect();
    first_order(
        &windowed,
        (tau, order),
        h,
        |x| grid.node(x),
        file,
        offset,
        reading,
    )
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

/// The response of `order` (1…4, [`Effect::MeterOrder`]; 0 is 1)
/// first-order sections of time constant `tau` (s) in cascade, of the
/// samples `grid` (spacing `h`, s), read at every row's t + `offset`.
/// Each section sees the one before it as linear over a step.
fn first_order(
    grid: &[Complex64],
    (tau, order): (f64, f64),
    h: f64,
    node: impl Fn(f64) -> (usize, f64),
    file: &File,
    offset: f64,
    reading: impl Fn(Complex64) -> f64,
) -> Vec<f64> {
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
    let order = order.clamp(1.0, 4.0);
    let (whole, part) = (order.floor() as usize, order - order.floor());
    let sections = whole + usize::from(part > 0.0);
    // Each section's output at every node, settled on the first: the
    // input of section k is the samples (k = 0) or stages[k − 1].
    fn input_of<'a>(grid: &'a [Complex64], stages: &'a [Vec<Complex64>], k: usize) -> &'a [Complex64] {
        if k == 0 {
            grid
        } else {
            &stages[k - 1]
        }
    }
    let mut stages: Vec<Vec<Complex64>> = Vec::with_capacity(sections);
    for k in 0..sections {
        let input = input_of(grid, &stages, k);
        let mut out = Vec::with_capacity(input.len());
        let mut state = input[0];
        out.push(state);
        for j in 1..input.len() {
            state = step(state, input[j - 1], input[j], h);
            out.push(state);
        }
        stages.push(out);
    }
    file.t
        .iter()
        .map(|&t| {
            let (j, a) = node(t + offset);
            // Each section stepped from node j to the reading, its input
            // linear from the node to the previous section's reading.
            let mut x = grid[j] + (grid[j + 1] - grid[j]) * a;
            let mut outs = [Complex64::default(); 5];
            for k in 0..sections {
                x = step(stages[k][j], input_of(grid, &stages, k)[j], x, a * h);
                outs[k] = x;
            }
            let y = if part > 0.0 {
                outs[whole - 1] * (1.0 - part) + outs[whole] * part
            } else {
                outs[whole - 1]
            };
            reading(y)
        })
        .collect()
}

/// A discrete kernel ([`Effect::MeterMean`] of `mean_n` readings, or
/// [`Effect::MeterEwma`] of memory `memory`) on the trace's own row grid,
/// read at every row's t + `offset`: the samples `y_at` on a grid of the
/// row interval from far enough back, a running mean by prefix sums or
/// the recursion of the weighted mean, linear between grid nodes (the
/// readings of a meter whose delay is not whole rows).
fn discrete(
    file: &File,
    offset: f64,
    mean_n: f64,
    memory: f64,
    y_at: impl Fn(f64) -> Complex64,
    reading: impl Fn(Complex64) -> f64,
) -> Vec<f64> {
    let n = file.t.len();
    let mut steps: Vec<f64> = file.t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied().unwrap_or(1.0);
    let (t0, t1) = (file.t[0] + offset, file.t[n - 1] + offset);
    // The row interval before decimation, but at most MAX_GRID samples.
    let dt = (median / file.stride.max(1) as f64).max((t1 - t0) / MAX_GRID as f64);
    let nn = mean_n.max(1.0);
    let back_rows = if mean_n > 0.0 {
        nn.ceil() as usize + 1
    } else {
        // Until the weights fall under 10⁻⁶ (and at most a grid's worth).
        ((1e-6f64).ln() / memory.clamp(1e-9, 0.999_999).ln())
            .ceil()
            .min(MAX_GRID as f64) as usize
            + 1
    };
    let lo = t0 - back_rows as f64 * dt;
    let m = ((t1 - lo) / dt).ceil() as usize + 2;
    let grid: Vec<Complex64> = (0..m).map(|j| y_at(lo + j as f64 * dt)).collect();
    let pos = |t: f64| {
        let u = ((t + offset - lo) / dt).clamp(0.0, (m - 2) as f64);
        let i = u.floor() as usize;
        (i, u - i as f64)
    };
    let kernel: Vec<Complex64> = if mean_n > 0.0 {
        // Mean of the readings ending at node i: the whole ones, and the
        // next older one weighed by the fraction of N.
        let whole = nn.floor() as usize;
        let part = nn - whole as f64;
        let mut prefix = Vec::with_capacity(m + 1);
        let mut acc = Complex64::default();
        prefix.push(acc);
        for y in &grid {
            acc += y;
            prefix.push(acc);
        }
        (0..m)
            .map(|i| {
                let a = (i + 1).saturating_sub(whole);
                let mut sum = prefix[i + 1] - prefix[a];
                if part > 0.0 {
                    sum += grid[a.saturating_sub(1)] * part;
                }
                sum / nn
            })
            .collect()
    } else {
        let mut state = grid[0];
        grid.iter()
            .map(|&y| {
                state = y * (1.0 - memory) + state * memory;
                state
            })
            .collect()
    };
    file.t
        .iter()
        .map(|&t| {
            let (i, a) = pos(t);
            reading(kernel[i] * (1.0 - a) + kernel[i + 1] * a)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::Kind;

    /// A trace of `rows` rows every `dt` (decimated by `stride`).
    fn trace(rows: usize, dt: f64, stride: usize) -> File {
        let t: Vec<f64> = (0..rows).map(|k| k as f64 * dt * stride as f64).collect();
        File {
            name: "t".into(),
            kind: Kind::Trace,
            s: vec![0.0; rows],
            r: vec![1e6; rows],
            f: vec![1e3; rows],
            cs: vec![0.0; rows],
            sigma: vec![f64::NAN; rows],
            corner: vec![false; rows],
            rows_read: rows * stride,
            stride,
            used: vec![true; rows],
            t,
        }
    }

    /// The discrete kernels against the f64 sums they stand for, on a
    /// smooth signal: a running mean of N (whole and fractional) and a
    /// weighted mean, read with a delay of whole rows (exact: the grid's
    /// nodes) and of a fraction of a row (linear between nodes: within
    /// the signal's curvature over a row).
    #[test]
    fn discrete_kernels_are_their_sums() {
        let dt = 0.02;
        let y = |t: f64| Complex64::new((3.0 * t).sin() + 0.2 * t, 0.5 * (1.7 * t).cos());
        for stride in [1, 3] {
            let file = trace(200, dt, stride);
            for (mean_n, memory) in [(5.0, 0.0), (4.4, 0.0), (0.0, 0.8)] {
                for delay in [0.0, -2.0 * dt, -0.37 * dt] {
                    let got = discrete(&file, delay, mean_n, memory, y, |v| v.re + 10.0 * v.im);
                    let (mut sq, mut max) = (0.0f64, 0.0f64);
                    for (k, &t) in file.t.iter().enumerate() {
                        let x = t + delay;
                        let want = if mean_n > 0.0 {
                            let whole = mean_n.floor() as usize;
                            let part = mean_n - whole as f64;
                            let mut s: Complex64 = (0..whole).map(|j| y(x - j as f64 * dt)).sum();
                            s += y(x - whole as f64 * dt) * part;
                            s / mean_n
                        } else {
                            // Σ (1 − m)·mʲ·y(x − jΔ) until mʲ < 10⁻¹²,
                            // settled far before the trace.
                            let mut s = Complex64::default();
                            let mut w = 1.0 - memory;
                            let mut j = 0;
                            while w > 1e-12 {
                                s += y(x - j as f64 * dt) * w;
                                w *= memory;
                                j += 1;
                            }
                            s
                        };
                        let e = got[k] - (want.re + 10.0 * want.im);
                        // Past the kernel's start-up (settled on the
                        // first sample, 10⁻⁶ of a reading).
                        if k * stride > 80 {
                            sq += e * e;
                            max = max.max(e.abs());
                        }
                    }
                    let rms = (sq / 200.0).sqrt();
                    // Whole rows: rounding only; a fraction of a row:
                    // linear interpolation of a signal of curvature ≤ 15
                    // over Δ = 20 ms, ≤ Δ²/8·15·11 ≈ 8·10⁻³.
                    let bound = if (delay / dt).fract().abs() < 1e-9 {
                        1e-6
                    } else {
                        8e-3
                    };
                    assert!(
                        max <= bound,
                        "stride {stride} N {mean_n} m {memory} delay {delay}: rms {rms:e} max {max:e}"
                    );
                }
            }
        }
    }
}
