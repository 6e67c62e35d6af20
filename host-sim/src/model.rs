//! The forward model of a measured data set, with the candidate effects the
//! uniform line lacks, in f64.
//!
//! What a series Cs–Rs meter reads on the sensor, given the recorded
//! end-to-end electrode resistances R_rec = R_top + R_bottom (Ω), the true
//! capacitance C (F) from the de-biased calibration, the stretch s (mm)
//! and the frequency f (Hz):
//!
//! ```text
//! R_line = R_rec − 4·R_c                          (ContactResistance)
//! Z      = line(R_line, C, G, weights) + 2·R_c
//! Z      = 1 / (1/Z + jω·C_p)                     (ParasiticCapacitance)
//! Cs     = −1 / (ω·Im Z)
//! ```
//!
//! `line` is the uniform continuous line √(z/y)·coth √(zy) with z = R and
//! y = G + jωC (G: [`Effect::DielectricLeakage`]), or a ladder of n elements (each
//! series R/n then shunt C/n), as in `dsp_core::tline`. Nonuniform lines
//! ([`Effect::ResistanceGradient`], [`Effect::NonuniformStretch`]) cascade [`SEGMENTS`] exact
//! uniform pieces (continuous) or weight the ladder's elements, with the
//! electrode resistance per length ∝ (1 + g·(2ξ − 1))·ρ(s(ξ)) and the
//! capacitance per length ∝ C_cal(s(ξ)), s(ξ) = s·(1 + u·(2ξ − 1)), ξ = 0 at
//! the read end. ρ(s) is the calibration's static R(s) and C_cal(s) its
//! (raw) quadratic, so a nonuniform stretch reshapes both as the sensor's
//! own static curves say, keeping the recorded totals.
//!
//! Time effects act on trace files only: the meter's reading at t is the
//! mean admittance over [t + δ − T, t + δ] ([`Effect::MeterLag`]: window T;
//! [`Effect::TimeOffset`]: δ > 0 when the capacitance channel is late), with the
//! stretch and resistance columns interpolated (Akima) between rows.

use crate::dataset::{DataSet, Kind, Row, Table};
use anyhow::{bail, Result};
use num_complex::Complex64;
use std::f64::consts::TAU;

/// Pieces of a nonuniform continuous line.
pub const SEGMENTS: usize = 32;

pub use instrument::effects::{Effect, EffectSet};

/// Parameters of every effect (0: absent), SI: the catalogue's
/// [`EffectSet`].
pub type Params = EffectSet;

fn has_time(p: &Params) -> bool {
    p.has(Effect::MeterLag) || p.has(Effect::TimeOffset)
}

fn nonuniform(p: &Params) -> bool {
    p.has(Effect::ResistanceGradient) || p.has(Effect::NonuniformStretch)
}

/// Line model of the baseline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line {
    /// The continuous limit.
    Continuous,
    /// A ladder of n elements (the paper used n = 30).
    Ladder(u8),
}

impl std::fmt::Display for Line {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Line::Continuous => write!(f, "continuous line"),
            Line::Ladder(n) => write!(f, "{n}-element ladder"),
        }
    }
}

/// The sensor's own static curves, from the calibration: the shape of
/// C(s) and R(s) along a nonuniformly stretched sensor.
#[derive(Clone, Debug)]
pub struct Shape {
    /// Raw C(s) quadratic (any unit: only ratios are used).
    c: [f64; 3],
    /// (stretch mm, R_top + R_bottom Ω), ascending.
    r: Vec<(f64, f64)>,
}

impl Shape {
    /// From a calibration table (at least two stretch points).
    pub fn from_calibration(cal: &Table) -> Result<Self> {
        let mut pts: Vec<(f64, f64)> = cal.rows.iter().map(|r| (r.stretch_mm(), r.cs_pf())).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 3 {
            bail!(
                "{}: a calibration needs at least three stretch points",
                cal.path.display()
            );
        }
        let mut r: Vec<(f64, f64)> = cal.rows.iter().map(|x| (x.stretch_mm(), x.r_rec())).collect();
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(Self {
            c: crate::baseline::quadratic_fit(&pts),
            r,
        })
    }

    /// The local curves of a sensor stretched nonuniformly by `u`: the
    /// calibration recorded each curve's mean along the sensor, so the
    /// local ones are found by undoing that mean. C: exact for the
    /// quadratic (c2 → c2/(1 + u²/3)). R: fixed-point iteration
    /// ρ ← ρ·R_cal/mean_ξ ρ(s(1 + u(2ξ − 1))) at the calibration points.
    pub fn local(&self, u: f64) -> Shape {
        let [a, b, c2] = self.c;
        let mut out = Shape {
            c: [a, b, c2 / (1.0 + u * u / 3.0)],
            r: self.r.clone(),
        };
        for _ in 0..6 {
            let next: Vec<(f64, f64)> = self
                .r
                .iter()
                .zip(&out.r)
                .map(|(&(s, r_cal), &(_, rho))| {
                    const K: usize = 32;
                    let mean = (0..K)
                        .map(|i| out.r_at(s * (1.0 + u * (2.0 * (i as f64 + 0.5) / K as f64 - 1.0))))
                        .sum::<f64>()
                        / K as f64;
                    (s, rho * r_cal / mean)
                })
                .collect();
            out.r = next;
        }
        out
    }

    fn c_at(&self, s: f64) -> f64 {
        let [a, b, c] = self.c;
        (a + s * (b + s * c)).max(1e-9 * a.abs())
    }

    /// Static R at `s`: Akima through the calibration points inside
    /// their range; outside it, the least-squares quadratic through the
    /// four end points (the curve's smooth continuation); at least 5 % of
    /// the largest.
    fn r_at(&self, s: f64) -> f64 {
        let r = &self.r;
        let n = r.len();
        let v = if s < r[0].0 {
            let q = crate::baseline::quadratic_fit(&r[..n.min(4)]);
            q[0] + s * (q[1] + s * q[2])
        } else if s > r[n - 1].0 {
            let q = crate::baseline::quadratic_fit(&r[n.saturating_sub(4)..]);
            q[0] + s * (q[1] + s * q[2])
        } else {
            let (t, y): (Vec<f64>, Vec<f64>) = r.iter().copied().unzip();
            interp(&t, &y, &[], s)
        };
        let top = r.iter().map(|p| p.1).fold(0.0, f64::max);
        v.max(0.05 * top)
    }
}

/// Continuous uniform line: Z = z / (γ·tanh γ), γ = √(z·y), z = R (Ω),
/// y = G + jωC (S).
fn continuous(r: f64, y: Complex64) -> Complex64 {
    let g = (y * r).sqrt();
    if g.norm() < 1e-6 {
        return y.inv() + r / 3.0;
    }
    r / (g * g.tanh())
}

/// A uniform piece (r Ω, y S) in front of a load (None: open end).
fn piece(r: f64, y: Complex64, load: Option<Complex64>) -> Complex64 {
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

/// The forward model: a line model, the effects' parameters, and the
/// sensor's static shape.
#[derive(Clone, Debug)]
pub struct Model<'a> {
    /// Line model.
    pub line: Line,
    /// Effect parameters.
    pub params: Params,
    /// The sensor's local static curves (for a nonuniform stretch u:
    /// [`Shape::local`]).
    pub shape: &'a Shape,
}

impl Model<'_> {
    /// The sensor's impedance at the meter (Ω) for recorded R_rec (Ω),
    /// true C (F) at stretch `s` (mm), frequency `f` (Hz); None if the
    /// contact resistance leaves no line.
    pub fn impedance(&self, r_rec: f64, c: f64, s: f64, f: f64) -> Option<Complex64> {
        let p = &self.params;
        let w = TAU * f;
        let rc = p.get(Effect::ContactResistance);
        let r = r_rec - 4.0 * rc;
        if !(r > 0.0 && c > 0.0 && w > 0.0) {
            return None;
        }
        let g = p.get(Effect::DielectricLeakage);
        let mut z = if !nonuniform(p) {
            match self.line {
                Line::Continuous => continuous(r, Complex64::new(g, w * c)),
                Line::Ladder(n) => {
                    let n = n.max(1) as usize;
                    let (rn, yn) = (r / n as f64, Complex64::new(g, w * c) / n as f64);
                    let mut z = yn.inv();
                    for _ in 1..n {
                        z = (yn + (z + rn).inv()).inv();
                    }
                    z + rn
                }
            }
        } else {
            self.nonuniform(r, c, g, s, w)
        };
        z += 2.0 * rc;
        let cp = p.get(Effect::ParasiticCapacitance);
        if cp != 0.0 {
            z = (z.inv() + Complex64::new(0.0, w * cp)).inv();
        }
        Some(z)
    }

    /// Nonuniform line of total R (Ω), C (F), G (S) at mean stretch s.
    fn nonuniform(&self, r: f64, c: f64, g: f64, s: f64, w: f64) -> Complex64 {
        let p = &self.params;
        let (grad, u) = (
            p.get(Effect::ResistanceGradient),
            p.get(Effect::NonuniformStretch),
        );
        let n = match self.line {
            Line::Continuous => SEGMENTS,
            Line::Ladder(n) => n.max(1) as usize,
        };
        let mut rw = [0.0f64; 64];
        let mut cw = [0.0f64; 64];
        // Each piece takes the mean of the profiles over its length
        // (Simpson's rule), so the totals are right to fourth order.
        let at = |xi: f64| {
            let sl = s * (1.0 + u * (2.0 * xi - 1.0));
            let (rho, cl) = if u != 0.0 {
                (self.shape.r_at(sl), self.shape.c_at(sl))
            } else {
                (1.0, 1.0)
            };
            ((1.0 + grad * (2.0 * xi - 1.0)).max(0.0) * rho, cl)
        };
        for i in 0..n {
            let (a, m, b) = (
                at(i as f64 / n as f64),
                at((i as f64 + 0.5) / n as f64),
                at((i + 1) as f64 / n as f64),
            );
            rw[i] = (a.0 + 4.0 * m.0 + b.0) / 6.0;
            cw[i] = (a.1 + 4.0 * m.1 + b.1) / 6.0;
        }
        let (rs, cs) = (rw[..n].iter().sum::<f64>(), cw[..n].iter().sum::<f64>());
        let mut z: Option<Complex64> = None;
        for i in (0..n).rev() {
            let (ri, ci) = (r * rw[i] / rs, c * cw[i] / cs);
            let yi = Complex64::new(g * ci / c, w * ci);
            z = Some(match self.line {
                Line::Continuous => piece(ri, yi, z),
                Line::Ladder(_) => ri + z.map_or(yi.inv(), |z| (yi + z.inv()).inv()),
            });
        }
        z.unwrap_or_default()
    }

    /// Series Cs (F) from an impedance at `f`.
    pub fn series(z: Complex64, f: f64) -> f64 {
        -1.0 / (TAU * f * z.im)
    }

    /// Series Cs (F) the meter reads on one static point.
    pub fn cs(&self, r_rec: f64, c: f64, s: f64, f: f64) -> Option<f64> {
        self.impedance(r_rec, c, s, f).map(|z| Self::series(z, f))
    }
}

/// A data set prepared for fast model evaluation.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Static curves.
    pub shape: Shape,
    /// The static calibration.
    calibration: Table,
    /// Files whose residual is modelled: the traces, then the sweep.
    pub files: Vec<File>,
}

/// One modelled file.
#[derive(Clone, Debug)]
pub struct File {
    /// File name.
    pub name: String,
    /// A dynamic trace (time effects apply) or a static sweep.
    pub kind: Kind,
    /// Time, s (traces).
    pub t: Vec<f64>,
    /// Stretch, mm.
    pub s: Vec<f64>,
    /// R_top + R_bottom, Ω.
    pub r: Vec<f64>,
    /// Frequency, Hz.
    pub f: Vec<f64>,
    /// Measured Cs, pF.
    pub cs: Vec<f64>,
    /// Rows where the stretch profile turns (traces).
    pub corner: Vec<bool>,
    /// Rows that enter the statistics: all but those at a trace's ends
    /// whose meter window, at the largest lag and offset searched, would
    /// reach outside the recording (no model can predict them).
    pub used: Vec<bool>,
}

/// Rows left out at the start of a trace (s): the longest window plus the
/// largest negative offset searched.
pub fn edge_start_s() -> f64 {
    Effect::MeterLag.info().search.1 - Effect::TimeOffset.info().search.0
}

/// Rows left out at the end of a trace (s): the largest positive offset.
pub fn edge_end_s() -> f64 {
    Effect::TimeOffset.info().search.1
}

fn file_of(t: &Table) -> File {
    let col = |g: fn(&Row) -> f64| t.rows.iter().map(g).collect::<Vec<f64>>();
    File {
        name: t
            .path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned()),
        kind: t.kind,
        t: if t.kind == Kind::Trace {
            col(Row::time_s)
        } else {
            vec![]
        },
        s: col(Row::stretch_mm),
        r: t.rows.iter().map(|r| r.r_rec()).collect(),
        f: col(Row::freq_hz),
        cs: col(Row::cs_pf),
        corner: vec![],
        used: vec![],
    }
    .finish()
}

impl File {
    fn finish(mut self) -> Self {
        if self.kind == Kind::Trace {
            self.corner = corners(&self.t, &self.s);
            let (a, b) = (
                self.t[0] + edge_start_s(),
                self.t[self.t.len() - 1] - edge_end_s(),
            );
            self.used = self.t.iter().map(|&t| t >= a && t <= b).collect();
        } else {
            self.used = vec![true; self.cs.len()];
        }
        self
    }
}

impl Prepared {
    /// Prepare `ds`; the sweep is modelled too when `sweep` is set.
    pub fn new(ds: &DataSet, sweep: bool) -> Result<Self> {
        let mut files: Vec<File> = ds.traces.iter().map(file_of).collect();
        if let (true, Some(sw)) = (sweep, &ds.sweep) {
            files.push(file_of(sw));
        }
        Ok(Self {
            shape: Shape::from_calibration(&ds.calibration)?,
            calibration: ds.calibration.clone(),
            files,
        })
    }

    /// C(s) = c0 + c1·s + c2·s² (F) from the calibration de-biased under
    /// `m` ([`crate::baseline::debiased_points`] with `m.cs`).
    pub fn calibrate(&self, m: &Model) -> Result<[f64; 3]> {
        let what = format!("{} with {:?}", m.line, m.params);
        let pts = crate::baseline::debiased_points(&self.calibration, &what, |r, c| {
            m.cs(r.r_rec(), c, r.stretch_mm(), r.freq_hz())
        })?;
        Ok(crate::baseline::quadratic_fit(&pts))
    }

    /// Predicted Cs (pF) of every row of every file under `line` and
    /// `params`, after de-biasing the calibration under the same model.
    pub fn predict(&self, line: Line, params: Params) -> Result<Vec<Vec<f64>>> {
        let u = params.get(Effect::NonuniformStretch);
        let local = (u != 0.0).then(|| self.shape.local(u));
        let m = Model {
            line,
            params,
            shape: local.as_ref().unwrap_or(&self.shape),
        };
        let [a, b, c2] = self.calibrate(&m)?;
        let cap = |s: f64| a + s * (b + s * c2);
        let at = |r: f64, s: f64, f: f64| m.impedance(r, cap(s), s, f);
        Ok(self
            .files
            .iter()
            .map(|file| {
                if file.kind == Kind::Trace && has_time(&params) {
                    timed(file, &params, at)
                } else {
                    (0..file.cs.len())
                        .map(|k| {
                            at(file.r[k], file.s[k], file.f[k])
                                .map_or(f64::NAN, |z| Model::series(z, file.f[k]) * 1e12)
                        })
                        .collect()
                }
            })
            .collect())
    }
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
    let is_corner = |i: usize| i == 0 || i == n - 1 || corner.get(i).copied().unwrap_or(false);
    // Tangent at i from the points i, i + dir, i + 2·dir (one-sided), or
    // the secant to i + dir when there is no third point on that side.
    let one_sided = |i: usize, fwd: bool| {
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
    };
    let tangent = |i: usize, fwd: bool| {
        if is_corner(i) {
            one_sided(i, fwd)
        } else {
            (y[i + 1] - y[i - 1]) / (t[i + 1] - t[i - 1])
        }
    };
    let h = t[k + 1] - t[k];
    let u = (x - t[k]) / h;
    let (m0, m1) = (tangent(k, true) * h, tangent(k + 1, false) * h);
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

/// Predictions of a trace with time effects: with a window, the
/// admittance on a grid eight times finer than the rows, integrated over
/// each reading's window [t + δ − T, t + δ]; with an offset alone, the
/// model at t + δ directly.
fn timed(file: &File, p: &Params, at: impl Fn(f64, f64, f64) -> Option<Complex64>) -> Vec<f64> {
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
    let h = (t1 - t0) / ((n - 1).max(1) as f64 * 8.0);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn shape() -> Shape {
        Shape {
            c: [210.0, 2.1, 0.0],
            r: vec![(0.0, 711e3), (15.0, 711e3), (30.0, 560e3)],
        }
    }

    #[test]
    fn ladder_approaches_the_continuous_line_and_pieces_cascade_exactly() {
        let sh = shape();
        let m = |line, params| Model {
            line,
            params,
            shape: &sh,
        };
        let (r, c, f) = (711e3, 210e-12, 6e3);
        // The same topologies as dsp-core's fixed-point kernels (1e-4).
        for (line, core) in [
            (Line::Continuous, dsp_core::tline::LineModel::Continuous),
            (Line::Ladder(1), dsp_core::tline::LineModel::Ladder(1)),
            (Line::Ladder(30), dsp_core::tline::LineModel::Ladder(30)),
            (Line::Ladder(64), dsp_core::tline::LineModel::Ladder(64)),
        ] {
            for f in [100.0, 2e3, 6e3, 30e3] {
                let z = m(line, Params::NONE).impedance(r, c, 0.0, f).unwrap();
                let zq = core.impedance(r as f32, c as f32, f as f32).unwrap();
                let e = (z - Complex64::new(zq.re as f64, zq.im as f64)).norm() / z.norm();
                assert!(e < 2e-4, "{line} {f} Hz: {e}");
            }
        }
        let zc = m(Line::Continuous, Params::NONE).impedance(r, c, 0.0, f).unwrap();
        // A "nonuniform" line with an infinitesimal gradient is the uniform
        // line cut into exact pieces.
        let p = Params::NONE.with(Effect::ResistanceGradient, 1e-12);
        let zn = m(Line::Continuous, p).impedance(r, c, 0.0, f).unwrap();
        assert!((zn - zc).norm() / zc.norm() < 1e-12, "{zn} vs {zc}");
        let zl = m(Line::Ladder(30), p).impedance(r, c, 0.0, f).unwrap();
        let z30 = m(Line::Ladder(30), Params::NONE).impedance(r, c, 0.0, f).unwrap();
        assert!((zl - z30).norm() / z30.norm() < 1e-12);
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
        assert!((super::interp(&t, &y, &none, x) / (5.0 * x).exp() - 1.0).abs() < 1e-5);
    }
}
