//! Inversion: the true line capacitance C and electrode resistance R from
//! one measured impedance at one frequency.
//!
//! The normalized impedance ζ = ωC·Z depends on x = ωRC alone, and so does
//! the dissipation factor D = Re Z/(−Im Z) = Re ζ/(−Im ζ). Solving
//! D_model(x) = D_measured gives x; then C = |ζ(x)|/(ω|Z|) and R = x/(ωC).
//!
//! * Small x (x ≤ [`X_ASYMPTOTE`]): ζ = −j + a·x + O(x²) with a the model's
//!   [`low_freq_resistance_fraction`](LineModel::low_freq_resistance_fraction),
//!   so x = D/a and C = Cs to within 10⁻⁵; no model evaluation is needed.
//! * Otherwise the root is bracketed in a log-spaced grid of D values that
//!   [`Inverter::new`] computes once, and refined by Illinois regula falsi
//!   in ln x (a handful of model evaluations).
//!
//! # Two branches
//! D(x) is not monotone: for the continuous line it rises to a peak of
//! 1.057 at x ≈ 7.71 and falls back towards 1 (ladders behave alike: the
//! 30-element one peaks at x ≈ 8.3), so
//! between the peak and [`Inverter::x_max`] one impedance fits two lines
//! whose capacitances differ by tens of percent. [`Inverter::invert`]
//! reports [`InvertError::Ambiguous`] there; [`Inverter::invert_near`] picks
//! the root whose C is closer to a prior (a calibration value or the
//! previous block's result), which is always available on a running sensor.
//! Close to the peak the problem is ill-conditioned (dD/dx = 0): keep the
//! excitation frequency such that x stays below ~5 for noisy data.

use crate::tline::{LineModel, ModelError};
use crate::Complex32;
use core::f32::consts::TAU;

/// Below this x the inversion uses the small-x asymptote.
pub const X_ASYMPTOTE: f32 = 0.01;
/// Default upper end of the inversion range (x = ωRC).
pub const X_MAX_DEFAULT: f32 = 10.0;
/// Number of grid points from [`X_ASYMPTOTE`] to `x_max`.
const GRID: usize = 33;

/// Why an impedance could not be inverted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InvertError {
    /// Re Z < 0, Im Z ≥ 0 or not finite: not an R-C line (shorted sensor,
    /// wiring fault, or no signal).
    NotCapacitive,
    /// Frequency not finite and positive.
    BadFrequency,
    /// D is larger than the model reaches for x ≤ `x_max`: ωRC is beyond
    /// the inversion range (lower the excitation frequency).
    OutOfRange,
    /// D fits two lines in range (see the module docs); use
    /// [`Inverter::invert_near`].
    Ambiguous,
    /// The line found differs from the tracked one by more than a sensor
    /// changes in one block ([`crate::track::Tracker::MAX_JUMP`]): a
    /// branch error or a fault, rejected by the tracker.
    Jump,
    /// The model could not be evaluated.
    Model(ModelError),
}

impl core::fmt::Display for InvertError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            InvertError::NotCapacitive => f.write_str("not an R-C line (Re Z < 0, Im Z ≥ 0 or not finite)"),
            InvertError::BadFrequency => f.write_str("the frequency is not finite and positive"),
            InvertError::OutOfRange => f.write_str("ωRC is beyond the inversion range: lower the frequency"),
            InvertError::Ambiguous => {
                f.write_str("two lines fit this reading: give the expected capacitance")
            }
            InvertError::Jump => f.write_str("the line jumped further than a sensor changes in one block"),
            InvertError::Model(e) => write!(f, "model: {e}"),
        }
    }
}

impl core::error::Error for InvertError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            InvertError::Model(e) => Some(e),
            _ => None,
        }
    }
}

impl From<ModelError> for InvertError {
    fn from(e: ModelError) -> Self {
        InvertError::Model(e)
    }
}

/// A recovered line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// Total electrode resistance R (top + bottom), Ω.
    pub r_ohm: f32,
    /// Line capacitance C, F.
    pub c_farad: f32,
    /// x = ωRC at the measurement frequency (dimensionless).
    pub x: f32,
}

/// Inverter configuration: the model and its precomputed D(x) grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inverter {
    model: LineModel,
    x_max: f32,
    /// ln x at the grid points.
    u: [f32; GRID],
    /// D at the grid points.
    d: [f32; GRID],
    /// Index of the grid point with the largest D.
    peak: usize,
}

impl Inverter {
    /// Inverter for `model` over x ≤ [`X_MAX_DEFAULT`].
    ///
    /// Panics only if `model` is an invalid ladder (n = 0 or n > 64); use
    /// [`Inverter::with_x_max`] to handle that as an error.
    pub fn new(model: LineModel) -> Self {
        match Self::with_x_max(model, X_MAX_DEFAULT) {
            Ok(s) => s,
            Err(_) => panic!("invalid line model"),
        }
    }

    /// Inverter for `model` over x ≤ `x_max` (clamped to 1..=100).
    pub fn with_x_max(model: LineModel, x_max: f32) -> Result<Self, ModelError> {
        let x_max = x_max.clamp(1.0, 100.0);
        let (u0, u1) = (libm::logf(X_ASYMPTOTE), libm::logf(x_max));
        let mut s = Self {
            model,
            x_max,
            u: [0.0; GRID],
            d: [0.0; GRID],
            peak: 0,
        };
        for k in 0..GRID {
            let u = u0 + (u1 - u0) * k as f32 / (GRID - 1) as f32;
            s.u[k] = u;
            s.d[k] = dissipation(model.zeta(libm::expf(u))?);
            if s.d[k] > s.d[s.peak] {
                s.peak = k;
            }
        }
        // Move the grid point of the largest D onto the true peak
        // (golden-section search between its neighbours), so that every D
        // up to the peak lies inside the grid.
        let k = s.peak;
        if k > 0 && k < GRID - 1 {
            const R: f32 = 0.618_034;
            let (mut a, mut b) = (s.u[k - 1], s.u[k + 1]);
            let f = |u: f32| model.zeta(libm::expf(u)).map(dissipation);
            let (mut c, mut d) = (b - R * (b - a), a + R * (b - a));
            let (mut fc, mut fd) = (f(c)?, f(d)?);
            for _ in 0..30 {
                if fc > fd {
                    (b, d, fd) = (d, c, fc);
                    c = b - R * (b - a);
                    fc = f(c)?;
                } else {
                    (a, c, fc) = (c, d, fd);
                    d = a + R * (b - a);
                    fd = f(d)?;
                }
            }
            let (u, du) = if fc > fd { (c, fc) } else { (d, fd) };
            if du > s.d[k] {
                s.u[k] = u;
                s.d[k] = du;
            }
        }
        Ok(s)
    }

    /// The model this inverter fits.
    pub fn model(&self) -> LineModel {
        self.model
    }

    /// Upper end of the inversion range (x = ωRC).
    pub fn x_max(&self) -> f32 {
        self.x_max
    }

    /// The peak of D(x) in range: (x, D) at the largest dissipation factor
    /// (the top of the grid when D rises all the way). Near it the
    /// inversion is ill-conditioned: dD/dx = 0.
    pub fn peak(&self) -> (f32, f32) {
        (libm::expf(self.u[self.peak]), self.d[self.peak])
    }

    /// Largest x up to which one impedance fits only one line in range:
    /// `x_max` if D(x) rises all the way, else the x on the rising branch
    /// where D equals D(x_max). Frequency policies keep x below this.
    pub fn x_unique(&self) -> f32 {
        let last = GRID - 1;
        if self.peak == last {
            return self.x_max;
        }
        match self.root(self.d[last], 0, self.peak) {
            Ok((x, _)) => x,
            Err(_) => libm::expf(self.u[0]),
        }
    }

    /// The line that explains `z` (Ω) at `f_hz`, from the rising branch of
    /// D(x); [`InvertError::Ambiguous`] if the falling branch fits too.
    pub fn invert(&self, z: Complex32, f_hz: f32) -> Result<Line, InvertError> {
        self.solve(z, f_hz, None)
    }

    /// As [`invert`](Self::invert), but where two lines fit, the one whose
    /// capacitance is closer (in ratio) to `c_hint_farad`.
    pub fn invert_near(&self, z: Complex32, f_hz: f32, c_hint_farad: f32) -> Result<Line, InvertError> {
        self.solve(z, f_hz, Some(c_hint_farad))
    }

    /// [`Self::solve_unchecked`], with every returned line finite and
    /// positive: an impedance whose ω|Z| is beyond `f32` would give C = 0
    /// and R = ∞, which is no reading.
    fn solve(&self, z: Complex32, f_hz: f32, hint: Option<f32>) -> Result<Line, InvertError> {
        let line = self.solve_unchecked(z, f_hz, hint)?;
        let finite = |v: f32| v.is_finite() && v > 0.0;
        if finite(line.c_farad) && finite(line.r_ohm) && finite(line.x) {
            Ok(line)
        } else {
            Err(InvertError::OutOfRange)
        }
    }

    fn solve_unchecked(&self, z: Complex32, f_hz: f32, hint: Option<f32>) -> Result<Line, InvertError> {
        if !(f_hz.is_finite() && f_hz > 0.0) {
            return Err(InvertError::BadFrequency);
        }
        if !(z.re.is_finite() && z.im.is_finite() && z.re >= 0.0 && z.im < 0.0) {
            return Err(InvertError::NotCapacitive);
        }
        let w = TAU * f_hz;
        let zabs = libm::hypotf(z.re, z.im);
        let d = z.re / -z.im;
        let line = |x: f32, zeta: Complex32| {
            let c = libm::hypotf(zeta.re, zeta.im) / (w * zabs);
            Line {
                r_ohm: x / (w * c),
                c_farad: c,
                x,
            }
        };
        if d <= self.d[0] {
            // Small x: ζ = −j + a·x, scaled so that it meets the grid at x_lo.
            let x = d * (X_ASYMPTOTE / self.d[0]);
            let a = self.model.low_freq_resistance_fraction();
            return Ok(line(x, Complex32::new(a * x, -1.0)));
        }
        // Rounding may put an impedance at the very top a hair above the
        // largest D on the grid; 10⁻⁵ of slack keeps x = x_max in range.
        if d > self.d[self.peak] * (1.0 + 1e-5) {
            return Err(InvertError::OutOfRange);
        }
        let d = d.min(self.d[self.peak]);
        let rising = self.root(d, 0, self.peak)?;
        let last = GRID - 1;
        let falling = if self.peak < last && d >= self.d[last] {
            Some(self.root(d, self.peak, last)?)
        } else {
            None
        };
        let lo = line(rising.0, rising.1);
        match (falling, hint) {
            (None, _) => Ok(lo),
            (Some(_), None) => Err(InvertError::Ambiguous),
            (Some((x, zeta)), Some(c)) => {
                let hi = line(x, zeta);
                let dist = |l: &Line| libm::fabsf(libm::logf(l.c_farad / c));
                Ok(if dist(&hi) < dist(&lo) { hi } else { lo })
            }
        }
    }

    /// Root of D(x) = d on the monotone grid stretch [i0, i1]; returns x and
    /// ζ(x).
    ///
    /// The first guess is inverse cubic interpolation of u = ln x against D
    /// through the four grid points around the root (no model evaluation);
    /// then secant steps on g(u) = D(eᵘ) − d, kept inside the bracketing
    /// grid cell (regula falsi when a secant step would leave it). Typically
    /// two or three model evaluations.
    fn root(&self, d: f32, i0: usize, i1: usize) -> Result<(f32, Complex32), InvertError> {
        let up = self.d[i1] >= self.d[i0];
        // Bracketing cell by bisection over the grid (no model evaluations).
        let (mut a, mut b) = (i0, i1);
        while b - a > 1 {
            let m = (a + b) / 2;
            if (self.d[m] < d) == up {
                a = m;
            } else {
                b = m;
            }
        }
        let k0 = a.saturating_sub(1).max(i0);
        let k0 = (k0 + 3).min(i1).saturating_sub(3).max(i0);
        let k1 = (k0 + 3).min(i1);
        let mut u = 0.0;
        for j in k0..=k1 {
            let mut w = self.u[j];
            for m in k0..=k1 {
                if m != j {
                    w *= (d - self.d[m]) / (self.d[j] - self.d[m]);
                }
            }
            u += w;
        }
        // Bracket in u with g < 0 at `lo` side and g > 0 at `hi` side.
        let (mut ua, mut ga, mut ub, mut gb) = (self.u[a], self.d[a] - d, self.u[b], self.d[b] - d);
        if !(u > ua && u < ub) {
            u = ua - ga * (ub - ua) / (gb - ga);
        }
        let (mut up_, mut gp) = if ga.abs() < gb.abs() { (ua, ga) } else { (ub, gb) };
        let mut best = (libm::expf(u), Complex32::new(0.0, -1.0), f32::INFINITY);
        // Which bracket end the last regula-falsi step kept (Illinois).
        let mut kept = 0i8;
        for _ in 0..12 {
            let x = libm::expf(u);
            let zeta = self.model.zeta(x)?;
            let g = dissipation(zeta) - d;
            if g.abs() < best.2 {
                best = (x, zeta, g.abs());
            }
            // D is known to ~1e-7 relative in f32: nothing finer is real.
            if g.abs() <= 2e-7 * d || (ub - ua) < 1e-7 {
                break;
            }
            if (g > 0.0) == (gb > 0.0) {
                (ub, gb) = (u, g);
                if kept == -1 {
                    ga *= 0.5;
                }
                kept = -1;
            } else {
                (ua, ga) = (u, g);
                if kept == 1 {
                    gb *= 0.5;
                }
                kept = 1;
            }
            let secant = u - g * (u - up_) / (g - gp);
            (up_, gp) = (u, g);
            u = if secant > ua && secant < ub && g != gp {
                secant
            } else {
                ua - ga * (ub - ua) / (gb - ga)
            };
            if (u - up_).abs() < 1e-7 {
                break;
            }
        }
        Ok((best.0, best.1))
    }
}

/// D = Re ζ / (−Im ζ).
#[inline]
fn dissipation(zeta: Complex32) -> f32 {
    zeta.re / -zeta.im
}
