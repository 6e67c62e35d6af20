//! The forward model of a measured data set, with the candidate effects the
//! uniform line lacks, in f64.
//!
//! What a series Cs–Rs meter reads on the sensor, given the recorded
//! end-to-end electrode resistances R_rec = R_top + R_bottom (Ω), the true
//! capacitance C (F) from the de-biased calibration, the stretch s (mm)
//! and the frequency f (Hz):
//!
//! ```text
//! R_el   = R_rec − 4·R_c                          (ContactResistance)
//! R_line = (1 − β)·R_el                           (LeadResistance)
//! k      = 1 / (1 + jωτ)                          (ElectrodeDispersion)
//! Z      = line(k·R_line, C, G, weights) + 2·R_c + k·β/2·R_el
//! Z      = 1 / (1/Z + jω·C_p)                     (ParasiticCapacitance)
//! Cs     = −1 / (ω·Im Z)
//! ```
//!
//! `line` is the uniform continuous line √(z/y)·coth √(zy) with z = R and
//! y = G + jωC (G = (σ/ε)·C: [`Effect::DielectricLeakage`]), or a ladder of n elements (each
//! series R/n then shunt C/n), as in `dsp_core::tline`. Nonuniform lines
//! ([`Effect::ResistanceGradient`], [`Effect::ResistanceBulge`],
//! [`Effect::NonuniformStretch`], [`Effect::StretchBulge`]) cascade [`SEGMENTS`] exact
//! uniform pieces (continuous) or weight the ladder's elements, with the
//! electrode resistance per length ∝ (1 + g·(2ξ − 1) + b·(6ξ(1 − ξ) − 1))·ρ(s(ξ)) and the
//! capacitance per length ∝ C_cal(s(ξ)), s(ξ) = s·(1 + u·(2ξ − 1)), ξ = 0 at
//! the read end. ρ(s) is the calibration's static R(s) and C_cal(s) its
//! (raw) quadratic, so a nonuniform stretch reshapes both as the sensor's
//! own static curves say, keeping the recorded totals.
//!
//! Time effects act on trace files only: the meter's reading at t is the
//! model at t + δ ([`Effect::TimeOffset`]: δ > 0 when the capacitance
//! channel is late) averaged over a window T ([`Effect::MeterLag`]) or by
//! a first-order response τ ([`Effect::MeterResponse`]), either the
//! admittance or the Cs readings ([`Averaging`]; `timed`), with the
//! stretch and resistance columns interpolated between rows (corner-aware
//! cubic Hermite, [`crate::numerics::interp`]).

//!
//! | module | what |
//! |---|---|
//! | [`shape`] | the sensor's static C(s) and R(s), and their local curves under a nonuniform stretch |
//! | `line` | uniform line pieces: the continuous line and a piece in front of a load |
//! | [`prepared`] | a data set prepared for fast evaluation, and its predictions |
//! | [`search`] | the ranges searched on a data set: the time effects' as far as its traces hold |
//! | `timed` | the meter's averaging and offset on a trace |

mod file;
mod line;
pub mod prepared;
pub mod search;
pub mod shape;
mod timed;

pub use prepared::{File, Prepared};
pub use search::Search;
pub use shape::Shape;
pub use timed::Averaging;

use crate::numerics::series_cs;
pub(crate) use line::continuous;
use line::piece;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// Pieces of a nonuniform continuous line.
pub const SEGMENTS: usize = 24;

pub use instrument::effects::{Effect, EffectSet};

/// Parameters of every effect (0: absent), SI: the catalogue's
/// [`EffectSet`].
pub type Params = EffectSet;

pub(crate) fn has_time(p: &Params) -> bool {
    p.has(Effect::MeterLag)
        || p.has(Effect::TimeOffset)
        || p.has(Effect::MeterResponse)
        || p.has(Effect::MeterMean)
        || p.has(Effect::MeterEwma)
}

pub(crate) fn nonuniform(p: &Params) -> bool {
    p.nonuniform()
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
    /// The profiles along a nonuniform line at its 2n + 1 points (local
    /// stretch over mean, resistance weight): the same for every row, so
    /// computed on first use.
    profiles: std::sync::OnceLock<Vec<(f64, f64)>>,
}

impl<'a> Model<'a> {
    /// A model of `line` with the effects `params` on the sensor's
    /// static curves `shape`.
    pub fn new(line: Line, params: Params, shape: &'a Shape) -> Self {
        Self {
            line,
            params,
            shape,
            profiles: std::sync::OnceLock::new(),
        }
    }
}

impl Model<'_> {
    /// The sensor's impedance at the meter (Ω) for recorded R_rec (Ω),
    /// true C (F) at stretch `s` (mm), frequency `f` (Hz); None if the
    /// contact resistance leaves no line.
    pub fn impedance(&self, r_rec: f64, c: f64, s: f64, f: f64) -> Option<Complex64> {
        let p = &self.params;
        let w = TAU * f;
        let rc = p.get(Effect::ContactResistance);
        let beta = p.get(Effect::LeadResistance);
        let r_el = r_rec - 4.0 * rc;
        let r = (1.0 - beta) * r_el;
        if !(r > 0.0 && c > 0.0 && w > 0.0) {
            return None;
        }
        // Bulk leakage G = (σ/ε)·C.
        let g = p.get(Effect::DielectricLeakage) * c;
        let film = Complex64::new(1.0, w * p.get(Effect::ElectrodeDispersion)).inv();
        let mut z = if !nonuniform(p) {
            match self.line {
                Line::Continuous => continuous(film * r, Complex64::new(g, w * c)),
                Line::Ladder(n) => {
                    let n = n.max(1) as usize;
                    let (rn, yn) = (film * (r / n as f64), Complex64::new(g, w * c) / n as f64);
                    let mut z = yn.inv();
                    for _ in 1..n {
                        z = (yn + (z + rn).inv()).inv();
                    }
                    z + rn
                }
            }
        } else {
            let n = match self.line {
                // A bump (as narrow as a fifth of the sensor) on twice as
                // many pieces.
                Line::Continuous if p.has(Effect::StretchBump) || p.has(Effect::ResistanceBump) => {
                    2 * SEGMENTS
                }
                Line::Continuous => SEGMENTS,
                Line::Ladder(n) => (n.max(1) as usize).min(64),
            };
            self.nonuniform(r, c, g, s, w, film, n)
        };
        z += 2.0 * rc + film * (0.5 * beta * r_el);
        let cp = p.get(Effect::ParasiticCapacitance);
        if cp != 0.0 {
            z = (z.inv() + Complex64::new(0.0, w * cp)).inv();
        }
        Some(z)
    }

    /// Nonuniform line of total R (Ω), C (F), G (S) at mean stretch s.
    ///
    /// Continuous: [`SEGMENTS`] exact uniform pieces (twice as many with
    /// a localized bump, which may be a fifth of the sensor wide), each with the mean
    /// of the profiles over its length (Simpson's rule, so the totals are
    /// right to fourth order), and half as many; piecewise-uniform
    /// cascades err by O(1/n²), so (4·Z(n) − Z(n/2))/3 is the line to
    /// fourth order: from 16 and 8 pieces within 0.013 pF of that from 64
    /// and 32 up to 6 kHz (0.038 pF at 30 kHz) over every mode's search
    /// range, where 32 pieces alone are up to 0.03 pF off (test
    /// `richardson_from_16_pieces_is_the_line`). A ladder weights its
    /// `n` elements (n ≤ 64).
    #[allow(clippy::too_many_arguments)]
    fn nonuniform(&self, r: f64, c: f64, g: f64, s: f64, w: f64, film: Complex64, n: usize) -> Complex64 {
        let p = &self.params;
        let stretched = p.stretched();
        let compute = || -> Vec<(f64, f64)> {
            (0..=2 * n)
                .map(|k| {
                    let xi = k as f64 / (2 * n) as f64;
                    (p.stretch_profile(xi), p.resistance_profile(xi))
                })
                .collect()
        };
        // Cached for the model's own n (a test may ask for another).
        let cached = self.profiles.get_or_init(compute);
        let fresh;
        let profiles = if cached.len() == 2 * n + 1 {
            cached
        } else {
            fresh = compute();
            &fresh
        };
        let at = |k: usize| {
            let (phi, weight) = profiles[k];
            let sl = s * phi;
            let (rho, cl) = if stretched {
                (self.shape.r_at(sl), self.shape.c_at(sl))
            } else {
                (1.0, 1.0)
            };
            (weight * rho, cl)
        };
        let continuous = self.line == Line::Continuous;
        // The profiles at 2n + 1 points: piece i of n spans points 2i to
        // 2i + 2, piece j of n/2 points 4j to 4j + 4.
        let mut pts = [(0.0f64, 0.0f64); 129];
        for (k, v) in pts.iter_mut().enumerate().take(2 * n + 1) {
            *v = at(k);
        }
        let cascade = |pieces: usize| -> Complex64 {
            let step = 2 * n / pieces;
            let mut rw = [0.0f64; 64];
            let mut cw = [0.0f64; 64];
            for i in 0..pieces {
                let (a, m, b) = (pts[i * step], pts[i * step + step / 2], pts[(i + 1) * step]);
                rw[i] = (a.0 + 4.0 * m.0 + b.0) / 6.0;
                cw[i] = (a.1 + 4.0 * m.1 + b.1) / 6.0;
            }
            let (rs, cs) = (rw[..pieces].iter().sum::<f64>(), cw[..pieces].iter().sum::<f64>());
            let mut z: Option<Complex64> = None;
            for i in (0..pieces).rev() {
                let (ri, ci) = (film * (r * rw[i] / rs), c * cw[i] / cs);
                let yi = Complex64::new(g * ci / c, w * ci);
                z = Some(if continuous {
                    piece(ri, yi, z)
                } else {
                    ri + z.map_or(yi.inv(), |z| (yi + z.inv()).inv())
                });
            }
            z.unwrap_or_default()
        };
        if continuous {
            (4.0 * cascade(n) - cascade(n / 2)) / 3.0
        } else {
            cascade(n)
        }
    }

    #[cfg(test)]
    fn nonuniform_at(&self, r: f64, c: f64, s: f64, f: f64, n: usize) -> Complex64 {
        self.nonuniform(r, c, 0.0, s, TAU * f, Complex64::new(1.0, 0.0), n)
    }

    /// Series Cs (F) from an impedance at `f`
    /// ([`crate::numerics::series_cs`]).
    pub fn series(z: Complex64, f: f64) -> f64 {
        series_cs(z, f)
    }

    /// Series Cs (F) the meter reads on one static point.
    pub fn cs(&self, r_rec: f64, c: f64, s: f64, f: f64) -> Option<f64> {
        self.impedance(r_rec, c, s, f).map(|z| Self::series(z, f))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape() -> Shape {
        Shape::new(
            [210.0, 2.1, 0.0],
            vec![(0.0, 711e3), (15.0, 711e3), (30.0, 560e3)],
        )
    }

    #[test]
    fn ladder_approaches_the_continuous_line_and_pieces_cascade_exactly() {
        let sh = shape();
        let m = |line, params| Model::new(line, params, &sh);
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

    /// The extrapolated cascade of [`SEGMENTS`] pieces against that of 64
    /// (fourth order, so 256× closer to the line), over each mode at its
    /// search range's ends (the bulges at their power's too) and combined, wherever the local stretch stays
    /// within the calibration (0–30 mm; beyond it the static curves are
    /// extrapolated with a kink, and no piece count converges): within
    /// 0.015 pF up to 6 kHz, 0.05 pF at 30 kHz.
    #[test]
    fn richardson_from_16_pieces_is_the_line() {
        let sh = shape();
        let (r, c) = (711e3, 210e-12);
        let modes = [
            Effect::ResistanceGradient,
            Effect::ResistanceBulge,
            Effect::NonuniformStretch,
            Effect::StretchBulge,
        ];
        let mut sets = vec![];
        for e in modes {
            let (lo, hi) = e.info().search;
            sets.push(Params::NONE.with(e, lo));
            sets.push(Params::NONE.with(e, hi));
        }
        // The bulges at the ends of their power's range.
        let (k_lo, k_hi) = Effect::BulgePower.info().search;
        for (e, v) in [
            (Effect::StretchBulge, 0.5),
            (Effect::ResistanceBulge, 0.9),
            (Effect::ResistanceBulge, -0.9),
        ] {
            for k in [k_lo, k_hi] {
                sets.push(Params::NONE.with(e, v).with(Effect::BulgePower, k));
            }
        }
        sets.push(
            Params::NONE
                .with(Effect::ResistanceGradient, 0.6)
                .with(Effect::ResistanceBulge, -0.8)
                .with(Effect::StretchBulge, 0.5),
        );
        let (mut low, mut high, mut points) = (0.0f64, 0.0f64, 0);
        for p in sets {
            let m = Model::new(Line::Continuous, p, &sh);
            for s in [0.0, 10.0, 15.0, 20.0, 30.0] {
                let local = (0..=100).map(|k| s * p.stretch_profile(k as f64 / 100.0));
                if local.clone().any(|x| !(0.0..=30.0 + 1e-9).contains(&x)) {
                    continue;
                }
                for f in [500.0, 2e3, 6e3, 30e3] {
                    let a = Model::series(m.nonuniform_at(r, c, s, f, SEGMENTS), f);
                    let b = Model::series(m.nonuniform_at(r, c, s, f, 64), f);
                    let e = (a - b).abs() * 1e12;
                    if f <= 6e3 {
                        low = low.max(e);
                    } else {
                        high = high.max(e);
                    }
                    points += 1;
                }
            }
        }
        println!("{points} points: worst |Z(16) − Z(64)| as Cs {low:.4} pF to 6 kHz, {high:.4} pF at 30 kHz");
        assert!(points > 100);
        assert!(low < 0.015 && high < 0.05, "{low} pF, {high} pF");
    }
}
