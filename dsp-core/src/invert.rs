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
//!   [`Inverter::new`] computes once, guessed by inverse cubic
//!   interpolation, and refined by Newton steps in ln x with ζ's slope
//!   (one model evaluation where the guess is close, away from the ends of
//!   a branch; the continuous line's slope costs nothing more, a ladder's
//!   a second evaluation). Which lines fit is known from the grid before
//!   any is solved: a reading more than one fits is refused at once.
//!
//! # Several lines, one reading
//! D(x) is not monotone. For the continuous line it rises to a peak of
//! 1.057 at x ≈ 7.71 and falls back towards 1 as x → ∞; a ladder's D falls
//! after its first peak (x ≈ 8.3 for 30 elements) to a minimum and then
//! rises without bound. So one impedance can fit two or three lines over
//! the model's whole range (x up to [`crate::tline::X_MAX`]), whatever
//! `x_max` says: a line beyond `x_max` is still a line a sensor can be.
//! The inverter keeps a grid of D over the whole range, split into its
//! monotone branches, and solves every branch that reaches the measured D:
//!
//! * [`Inverter::invert`] answers only where one line fits over the whole
//!   range, allowing [`D_MARGIN`] for the uncertainty of a reading's D:
//!   x ≤ [`Inverter::x_unique`] (4.58 for the continuous line, whose D dips
//!   to 0.9976 at x ≈ 25; 4.89 without the margin); elsewhere
//!   [`InvertError::Ambiguous`].
//! * [`Inverter::invert_near`] takes the line whose C is closest (in ratio)
//!   to a prior (a calibration value or the previous block's result), and
//!   only if every other line is at least [`SEPARATION`] further from it;
//!   else [`InvertError::Ambiguous`]. If the line it takes lies beyond
//!   `x_max`, [`InvertError::OutOfRange`]: a line far beyond the range
//!   (an electrode resistance step, a cracked electrode) is never reported
//!   as the rising-branch line of the same D.
//!
//! Close to the peak the problem is ill-conditioned (dD/dx = 0): keep the
//! excitation frequency such that x stays below ~5 for noisy data.
//!
//! # Tab leads
//! A sensor whose electrodes carry part of their resistance in tab leads
//! outside the capacitor ([`Inverter::with_leads`]) is the line plus a
//! series resistance proportional to the line's: Z = Z_line(R, C) + ℓ·R,
//! so ζ(x) = ζ_line(x) + ℓ·x, and everything above holds with that ζ. R
//! is then the line's resistance alone. ℓ = β/(2(1 − β)) for a fraction
//! β of each electrode's end-to-end resistance in its two leads.

use crate::fmath::{self, max, min, positive_finite};
use crate::tables::INVERT_GRID_U;
use crate::tline::{LineModel, ModelError};
use crate::Complex32;
use core::f32::consts::TAU;

/// Below this x the inversion uses the small-x asymptote.
pub const X_ASYMPTOTE: f32 = 0.01;
/// Default upper end of the inversion range (x = ωRC).
pub const X_MAX_DEFAULT: f32 = 10.0;
/// Number of grid points from [`X_ASYMPTOTE`] to [`crate::tline::X_MAX`]
/// (log-spaced, ≈ 0.23 apart in ln x): ln x at each is
/// [`INVERT_GRID_U`], one table every inverter shares.
const GRID: usize = 56;
const _: () = assert!(GRID == INVERT_GRID_U.len() && GRID <= 64);
/// Largest number of monotone branches of D(x) kept (rising, falling,
/// rising again for a ladder; the continuous line has two).
const BRANCHES: usize = 4;
/// How much closer (in |ln(C/C_prior)|) the chosen line must be to the
/// prior than any other line fitting the same reading (2 %): more than a
/// sensor's C moves in one block plus the noise of a reading.
pub const SEPARATION: f32 = 0.02;
/// Relative uncertainty of a measured D the inverter allows for when it
/// decides how many lines fit (2 %: noise, and what a disturbance below the
/// channel's residual check can do to the phase).
pub const D_MARGIN: f32 = 0.02;
/// A branch of D(x) beyond the first peak and trough over which D changes
/// by less than this (relative) does not tell lines apart.
const FLAT: f32 = 0.01;

/// Why an impedance could not be inverted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InvertError {
    /// Re Z < 0, Im Z ≥ 0 or not finite: not an R-C line (shorted sensor,
    /// wiring fault, or no signal).
    NotCapacitive,
    /// Frequency not finite and positive.
    BadFrequency,
    /// The expected capacitance (or range) given is not finite and
    /// positive.
    BadPrior,
    /// The line that fits lies beyond `x_max` (or no line of the model
    /// fits D): ωRC is beyond the inversion range (lower the excitation
    /// frequency).
    OutOfRange,
    /// D fits more than one line (see the module docs) and no prior tells
    /// them apart.
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
            InvertError::BadPrior => f.write_str("the expected capacitance is not finite and positive"),
            InvertError::OutOfRange => f.write_str("ωRC is beyond the inversion range: lower the frequency"),
            InvertError::Ambiguous => f.write_str(
                "more than one line fits this reading and no expected capacitance tells them apart",
            ),
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
    /// Total electrode resistance R (top + bottom) of the line, Ω (without
    /// tab leads: [`Inverter::with_leads`]).
    pub r_ohm: f32,
    /// Line capacitance C, F.
    pub c_farad: f32,
    /// x = ωRC at the measurement frequency (dimensionless).
    pub x: f32,
    /// Error amplification κ = |d ln C / d ln D| at this line: a relative
    /// error ε of the measured D moves C by κ·ε (0.14 at x = 1, 1.4 at 4,
    /// 13 at 7, ∞ at the peak of D). A reading is only as good as κ
    /// times its phase noise allows.
    pub kappa: f32,
}

/// Inverter configuration: the model and its precomputed D(x) grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inverter {
    model: LineModel,
    x_max: f32,
    /// Grid points moved onto an extremum of D ([`Inverter::refine`]):
    /// point `moved_at[j]` is at ln x `moved_u[j]` (`u8::MAX`: none).
    /// Every other point is the shared grid's ([`INVERT_GRID_U`]): 224
    /// bytes less per inverter, one per sensor.
    moved_at: [u8; BRANCHES],
    /// ln x of the moved points.
    moved_u: [f32; BRANCHES],
    /// D at the grid points.
    d: [f32; GRID],
    /// Grid indices of the ends of the monotone branches: `ends[0] = 0`,
    /// then every local extremum of D (refined onto the true extremum),
    /// then `GRID − 1`.
    ends: [usize; BRANCHES + 1],
    /// Number of branches (1 when D rises all the way).
    branches: usize,
    /// Branches `resolved..branches` are flat (see [`FLAT`]).
    resolved: usize,
    /// Smallest |ζ| over the flat branches (less 0.1 %).
    tail_zeta: f32,
    /// The band of D the flat branches reach ([`Inverter::tail`]),
    /// computed once.
    tail_band: Option<(f32, f32)>,
    /// Series resistance of the read end's tab leads per line resistance,
    /// ℓ (dimensionless, 0 ≤ ℓ ≤ [`LEAD_MAX`]).
    lead: f32,
}

/// Largest lead ratio ℓ an inverter takes (β = 0.99 of each electrode's
/// resistance in its leads, the catalogue's limit).
pub const LEAD_MAX: f32 = 50.0;

/// ζ of `model` with leads ℓ: ζ_line(x) + ℓ·x.
fn zeta_with(model: LineModel, lead: f32, x: f32) -> Result<Complex32, ModelError> {
    model.zeta(x).map(|z| Complex32::new(z.re + lead * x, z.im))
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

    /// Inverter for `model` reporting lines with x ≤ `x_max` (clamped to
    /// 1..=100, and to where D stops telling lines apart: the continuous
    /// line's trough at x ≈ 25); lines beyond are still solved for, to tell
    /// them apart.
    pub fn with_x_max(model: LineModel, x_max: f32) -> Result<Self, ModelError> {
        Self::with_leads(model, x_max, 0.0)
    }

    /// As [`with_x_max`](Self::with_x_max), for a sensor whose read end
    /// has tab leads of ℓ = `lead_ratio` times the line's resistance in
    /// series (see the module's "Tab leads"); [`ModelError::OutOfRange`]
    /// unless 0 ≤ ℓ ≤ [`LEAD_MAX`].
    pub fn with_leads(model: LineModel, x_max: f32, lead_ratio: f32) -> Result<Self, ModelError> {
        if !(0.0..=LEAD_MAX).contains(&lead_ratio) {
            return Err(ModelError::OutOfRange);
        }
        let lead = lead_ratio;
        let x_max = x_max.clamp(1.0, 100.0);
        let (u0, u1) = (libm::logf(X_ASYMPTOTE), libm::logf(crate::tline::X_MAX));
        let mut s = Self {
            model,
            x_max,
            moved_at: [u8::MAX; BRANCHES],
            moved_u: [0.0; BRANCHES],
            d: [0.0; GRID],
            ends: [GRID - 1; BRANCHES + 1],
            branches: 1,
            resolved: 1,
            tail_zeta: f32::INFINITY,
            tail_band: None,
            lead,
        };
        for (k, &u) in INVERT_GRID_U.iter().enumerate() {
            // exp(ln x) as it was when x was the grid point: the top point
            // rounds to a hair above X_MAX in f32.
            let x = libm::expf(u0 + (u1 - u0) * k as f32 / (GRID - 1) as f32).min(crate::tline::X_MAX);
            debug_assert_eq!(libm::logf(x).to_bits(), u.to_bits());
            s.d[k] = dissipation(zeta_with(model, lead, x)?);
        }
        // Branch ends: where D turns by more than EXTREMUM_TOL (f32 noise
        // on the continuous line's flat D → 1 is no turn).
        const EXTREMUM_TOL: f32 = 1e-4;
        s.ends[0] = 0;
        let mut rising = s.d[1] >= s.d[0];
        let mut ext = 0;
        for k in 1..GRID {
            if (s.d[k] >= s.d[ext]) == rising {
                ext = k;
            } else if libm::fabsf(s.d[k] - s.d[ext]) > EXTREMUM_TOL * s.d[ext] {
                if s.branches == BRANCHES {
                    break;
                }
                if ext > 0 {
                    s.refine(ext, rising)?;
                }
                s.ends[s.branches] = ext;
                s.branches += 1;
                rising = !rising;
                ext = k;
            }
        }
        s.ends[s.branches] = GRID - 1;
        // Past the first two branches, a branch over which D changes by
        // less than FLAT (the continuous line's tail, where D = 1 ± 0.25 %
        // oscillates ever faster) does not resolve x: readings it reaches
        // are refused, and x_max stops at its start.
        s.resolved = s.branches;
        for b in 2..s.branches {
            let (d0, d1) = (s.d[s.ends[b]], s.d[s.ends[b + 1]]);
            if libm::fabsf(d1 - d0) < FLAT * d0 {
                s.resolved = b;
                break;
            }
        }
        s.x_max = s.x_max.min(libm::expf(s.u(s.ends[s.resolved])));
        for k in s.ends[s.resolved]..GRID {
            if s.resolved < s.branches {
                let z = zeta_with(model, lead, libm::expf(s.u(k)).min(crate::tline::X_MAX))?;
                s.tail_zeta = s.tail_zeta.min(crate::fmath::hypot(z.re, z.im) * 0.999);
            }
        }
        if s.resolved < s.branches {
            let d = &s.d[s.ends[s.resolved]..];
            let lo = d.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = d.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            s.tail_band = Some((lo * (1.0 - 1e-4), hi * (1.0 + 1e-4)));
        }
        Ok(s)
    }

    /// Move grid point `k` onto the extremum of D between its neighbours
    /// (golden-section search in ln x), so that every D up to a peak (or
    /// down to a trough) lies inside the grid.
    fn refine(&mut self, k: usize, max: bool) -> Result<(), ModelError> {
        const R: f32 = 0.618_034;
        let sign = if max { 1.0 } else { -1.0 };
        let f = |u: f32| self.zeta(libm::expf(u)).map(|z| sign * dissipation(z));
        let (mut a, mut b) = (self.u(k - 1), self.u(k + 1));
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
        if du > sign * self.d[k] {
            self.set_u(k, u);
            self.d[k] = sign * du;
        }
        Ok(())
    }

    /// ln x at grid point `k`: the shared grid's, or where it was moved.
    /// Out of line: inlined at its nine uses it took a kilobyte more of
    /// flash.
    #[inline(never)]
    fn u(&self, k: usize) -> f32 {
        match self.moved_at.iter().position(|&at| usize::from(at) == k) {
            Some(j) => self.moved_u[j],
            None => INVERT_GRID_U.get(k).copied().unwrap_or(f32::NAN),
        }
    }

    /// Move grid point `k` to ln x = `u`: at most [`BRANCHES`] points
    /// move, the branches' inner ends.
    fn set_u(&mut self, k: usize, u: f32) {
        let free = self
            .moved_at
            .iter()
            .position(|&at| usize::from(at) == k || at == u8::MAX);
        match free {
            Some(j) if k < GRID => {
                self.moved_at[j] = k as u8;
                self.moved_u[j] = u;
            }
            // No room (the construction moves no more; debug builds say
            // so): the point stays where it was.
            _ => debug_assert!(false, "grid point {k}: no room to move it"),
        }
    }

    /// The model this inverter fits.
    pub fn model(&self) -> LineModel {
        self.model
    }

    /// The lead ratio ℓ (0: no leads).
    pub fn lead_ratio(&self) -> f32 {
        self.lead
    }

    /// ζ(x) of the model with its leads.
    fn zeta(&self, x: f32) -> Result<Complex32, ModelError> {
        zeta_with(self.model, self.lead, x)
    }

    /// ζ(x) = ωC·Z of the model with its leads at any x = ωRC up to
    /// [`crate::tline::X_MAX`]: below [`crate::tline::X_MIN`] the small-x
    /// asymptote −j + (a + ℓ)·x (there within 10⁻¹⁰ of the line).
    /// Not inlined: the fits call it from several places, and a copy in
    /// each would cost the single-channel board's flash.
    #[inline(never)]
    pub fn zeta_at(&self, x: f32) -> Result<Complex32, InvertError> {
        if x > 0.0 && x < crate::tline::X_MIN {
            let a = self.model.low_freq_resistance_fraction() + self.lead;
            return Ok(Complex32::new(a * x, -1.0));
        }
        Ok(self.zeta(x)?)
    }

    /// ζ(x) as [`zeta_at`](Self::zeta_at) and its slope dζ/d ln x, what
    /// a fit's Jacobian needs. The continuous line's slope is exact from ζ
    /// itself: with ζ₀ = −j·γ·coth γ, γ² = j·x,
    ///
    /// ```text
    /// dζ₀/d ln x = (ζ₀ − j·ζ₀² + x)/2
    /// ```
    ///
    /// (one product, no second evaluation; f32 rounding of ζ₀ leaves it
    /// within 10⁻⁷ absolute), the leads add ℓ·x to both, and below
    /// [`crate::tline::X_MIN`] the asymptote's slope is its real part. A
    /// ladder's slope is a forward difference, (ζ(x·e^h) − ζ(x))/h with
    /// h = 10⁻³ (its O(h) error slows a fit's convergence, not where it
    /// converges).
    #[inline(never)]
    pub fn zeta_slope_at(&self, x: f32) -> Result<(Complex32, Complex32), InvertError> {
        self.zeta_slope_inline(x)
    }

    /// [`zeta_slope_at`](Self::zeta_slope_at), the continuous line inside
    /// the model's range inline (a root's every step), the rest out of
    /// line. (A fit calls it out of line: inlined there, its larger body
    /// made the compiler clear and copy the fit's state in bulk.)
    #[inline(always)]
    fn zeta_slope_inline(&self, x: f32) -> Result<(Complex32, Complex32), InvertError> {
        if matches!(self.model, LineModel::Continuous)
            && (crate::tline::X_MIN..=crate::tline::X_MAX).contains(&x)
        {
            let z0 = crate::tline::continuous_zeta(x);
            let lead = self.lead * x;
            return Ok((Complex32::new(z0.re + lead, z0.im), self.continuous_slope(z0, x)));
        }
        self.zeta_slope_beyond(x)
    }

    /// [`zeta_slope_at`](Self::zeta_slope_at) for a ladder, or outside the
    /// continuous line's range (below [`crate::tline::X_MIN`] its
    /// asymptote, beyond an error).
    #[inline(never)]
    fn zeta_slope_beyond(&self, x: f32) -> Result<(Complex32, Complex32), InvertError> {
        if x > 0.0 && x < crate::tline::X_MIN {
            let a = self.model.low_freq_resistance_fraction() + self.lead;
            return Ok((Complex32::new(a * x, -1.0), Complex32::new(a * x, 0.0)));
        }
        match self.model {
            // The continuous line inside its range is `zeta_slope_inline`'s:
            // here it is outside it.
            LineModel::Continuous => Err(ModelError::OutOfRange.into()),
            LineModel::Ladder(_) => {
                const H: f32 = 1e-3;
                let z = self.zeta(x)?;
                let up = self.zeta(x * 1.001_000_5)?;
                Ok((z, (up - z) / H))
            }
        }
    }

    /// d²ζ/d(ln x)² at `x`, from ζ and its slope there as
    /// [`zeta_slope_at`](Self::zeta_slope_at) gives them, where it is
    /// exact: the continuous line's, differentiating its slope once more,
    ///
    /// ```text
    /// d²ζ₀/d(ln x)² = (ζ₀' − 2j·ζ₀·ζ₀' + x)/2
    /// ```
    ///
    /// with the leads' ℓ·x added (and below [`crate::tline::X_MIN`] the
    /// asymptote's, its slope). `None` for a ladder, whose slope is a
    /// forward difference. What a fit needs to bound the second-order
    /// term of a step it takes without evaluating the model again.
    /// Within 10⁻⁶·|ζ| + 4·10⁻⁶·x of the exact (f32's rounding of
    /// ζ₀·ζ₀', terms of size x that cancel; tested against f64).
    pub fn curvature(&self, x: f32, zeta: Complex32, slope: Complex32) -> Option<Complex32> {
        if let LineModel::Ladder(_) = self.model {
            return None;
        }
        if x < crate::tline::X_MIN {
            return Some(slope);
        }
        let lead = self.lead * x;
        let (z0, s0) = (
            Complex32::new(zeta.re - lead, zeta.im),
            Complex32::new(slope.re - lead, slope.im),
        );
        let w = z0 * s0;
        // −2j·w = 2·Im w − 2j·Re w.
        Some(Complex32::new(
            0.5 * (s0.re + 2.0 * w.im + x) + lead,
            0.5 * (s0.im - 2.0 * w.re),
        ))
    }

    /// The continuous line's dζ/d ln x with its leads at `x`, from the
    /// line's own ζ₀ (without leads): (ζ₀ − j·ζ₀² + x)/2 + ℓ·x.
    fn continuous_slope(&self, z0: Complex32, x: f32) -> Complex32 {
        let lead = self.lead * x;
        let sq = z0 * z0;
        // −j·ζ₀² = Im ζ₀² − j·Re ζ₀².
        Complex32::new(0.5 * (z0.re + sq.im + x) + lead, 0.5 * (z0.im - sq.re))
    }

    /// Upper end of the reported range (x = ωRC).
    pub fn x_max(&self) -> f32 {
        self.x_max
    }

    /// The first peak of D(x): (x, D) at the largest dissipation factor of
    /// the rising branch (the top of the model's range when D rises all the
    /// way). Near it the inversion is ill-conditioned: dD/dx = 0.
    pub fn peak(&self) -> (f32, f32) {
        let k = self.ends[1];
        (libm::expf(self.u(k)), self.d[k])
    }

    /// Largest x up to which one impedance fits only one line over the
    /// model's whole range: where the rising branch meets the lowest D
    /// reached beyond the first peak, less [`D_MARGIN`] (4.58 for the
    /// continuous line), or
    /// `x_max` if D rises all the way. Without a prior,
    /// [`invert`](Self::invert) answers only below this; frequency policies
    /// keep x below it.
    pub fn x_unique(&self) -> f32 {
        if self.branches == 1 {
            return self.x_max;
        }
        let floor = self.d[self.ends[1]..]
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min)
            * (1.0 - D_MARGIN);
        match self.root(floor, 0, self.ends[1]) {
            Ok(r) => r.x.min(self.x_max),
            Err(_) => libm::expf(self.u(0)),
        }
    }

    /// The band of D reached by lines beyond the resolved branches (the
    /// continuous line's tail past its trough at x ≈ 25: D = 0.9976 to
    /// 1.0001), widened by 10⁻⁴ for rounding; `None` if every branch
    /// resolves x. A line far beyond any range fits readings in it: they
    /// are [`InvertError::Ambiguous`] unless a prior is clearly below the
    /// smallest C of those lines (≈ 2.2 times the rising branch's C for
    /// the continuous line).
    pub fn tail(&self) -> Option<(f32, f32)> {
        self.tail_band
    }

    /// The line that explains `z` (Ω) at `f_hz` where only one line does;
    /// [`InvertError::Ambiguous`] where more than one fits.
    pub fn invert(&self, z: Complex32, f_hz: f32) -> Result<Line, InvertError> {
        self.solve(z, f_hz, Select::Unique)
    }

    /// As [`invert`](Self::invert), but where several lines fit, the one
    /// whose capacitance is closest (in ratio) to `c_hint_farad`, if it is
    /// closer by [`SEPARATION`] than every other.
    pub fn invert_near(&self, z: Complex32, f_hz: f32, c_hint_farad: f32) -> Result<Line, InvertError> {
        self.solve(z, f_hz, Select::Near(c_hint_farad))
    }

    /// As [`invert`](Self::invert), but where several lines fit, the only
    /// one whose capacitance lies in `lo_farad..=hi_farad` (the range a
    /// sensor's calibration spans, when nothing better is known);
    /// [`InvertError::Ambiguous`] if more than one does (a line of the
    /// flat tail counts when its smallest C is in range), and
    /// [`InvertError::OutOfRange`] if none does. Where one line fits, that
    /// line, whatever its C.
    pub fn invert_within(
        &self,
        z: Complex32,
        f_hz: f32,
        lo_farad: f32,
        hi_farad: f32,
    ) -> Result<Line, InvertError> {
        self.solve(z, f_hz, Select::Within(lo_farad, hi_farad))
    }

    /// [`Self::solve_unchecked`], with every returned line finite and
    /// positive: an impedance whose ω|Z| is beyond `f32` would give C = 0
    /// and R = ∞, which is no reading.
    fn solve(&self, z: Complex32, f_hz: f32, hint: Select) -> Result<Line, InvertError> {
        let line = self.solve_unchecked(z, f_hz, hint)?;
        if positive_finite(line.c_farad) && positive_finite(line.r_ohm) && positive_finite(line.x) {
            Ok(line)
        } else {
            Err(InvertError::OutOfRange)
        }
    }

    fn solve_unchecked(&self, z: Complex32, f_hz: f32, hint: Select) -> Result<Line, InvertError> {
        check_inputs(z, f_hz, hint)?;
        let w = TAU * f_hz;
        let zabs = crate::fmath::hypot(z.re, z.im);
        let d = z.re / -z.im;
        let line = |r: Root| {
            let c = crate::fmath::hypot(r.zeta.re, r.zeta.im) / (w * zabs);
            Line {
                r_ohm: r.x / (w * c),
                c_farad: c,
                x: r.x,
                kappa: r.kappa,
            }
        };
        // Which lines fit: the small-x asymptote, a branch, the flat tail.
        // A reading's D is uncertain by up to D_MARGIN: a branch whose D
        // comes that close fits too (at its nearest end), so near a peak or
        // trough both sides count, and x_unique is where D is D_MARGIN
        // below the trough. This needs no model evaluation, so a reading
        // that more than one line fits is refused without solving any.
        let margin = D_MARGIN * d;
        let small = d <= self.d[0];
        // A flat branch reaching D: some line far beyond the range fits.
        // Its x cannot be told, but its C is at least the tail's smallest
        // |ζ| over ω|Z| (|ζ| grows with x there).
        let tail_c = match self.tail_band {
            Some((lo, hi)) if d >= lo - margin && d <= hi + margin => Some(self.tail_zeta / (w * zabs)),
            _ => None,
        };
        let mut inside = [false; BRANCHES];
        let mut n = small as usize;
        for (b, slot) in inside.iter_mut().enumerate().take(self.resolved) {
            let (d0, d1) = (self.d[self.ends[b]], self.d[self.ends[b + 1]]);
            *slot = if b == 0 {
                // The rising branch owns D above the asymptote's, up to its
                // peak and D_MARGIN beyond.
                d > d0 && d <= d1 + margin
            } else {
                d >= min(d0, d1) - margin && d <= max(d0, d1) + margin
            };
            n += *slot as usize;
        }
        if n == 0 {
            return Err(if tail_c.is_some() {
                InvertError::Ambiguous
            } else {
                InvertError::OutOfRange
            });
        }
        if matches!(hint, Select::Unique) && (n > 1 || tail_c.is_some()) {
            return Err(InvertError::Ambiguous);
        }
        let mut found = [None::<Line>; BRANCHES];
        let mut k = 0;
        if small {
            // Small x: ζ = −j + a·x, scaled so that it meets the grid at x_lo.
            let x = d * (X_ASYMPTOTE / self.d[0]);
            let a = self.model.low_freq_resistance_fraction() + self.lead;
            found[0] = Some(line(Root {
                x,
                zeta: Complex32::new(a * x, -1.0),
                kappa: 0.0,
            }));
            k = 1;
        }
        for b in (0..self.resolved).filter(|&b| inside[b]) {
            let (i0, i1) = (self.ends[b], self.ends[b + 1]);
            let (d0, d1) = (self.d[i0], self.d[i1]);
            // fmath's clamp, not f32's (its order check would link core's
            // float formatting into the firmware, ≈ 35 KiB): d and the
            // grid are finite.
            let d = fmath::clamp(d, min(d0, d1), max(d0, d1));
            found[k] = Some(line(self.root(d, i0, i1)?));
            k += 1;
        }
        let chosen = choose(hint, &found[..k], n == 1 && tail_c.is_none(), tail_c)?;
        self.finish(chosen)
    }

    /// The chosen line within the range: 10⁻⁴ of slack, for a line at
    /// x_max may come back a hair above it. A ladder's forward
    /// difference resolves Im ζ' only above [`KAPPA_SLOPE_X`] (below,
    /// κ < 10⁻² is its f32 rounding), and D's slope to 10⁻² only where
    /// κ < [`KAPPA_SLOPE_MAX`] (near a peak of D the slope vanishes):
    /// elsewhere κ from central differences, as [`Self::kappa`] gives it.
    #[inline(always)]
    fn finish(&self, chosen: Line) -> Result<Line, InvertError> {
        if chosen.x > self.x_max * (1.0 + 1e-4) {
            return Err(InvertError::OutOfRange);
        }
        if matches!(self.model, LineModel::Ladder(_))
            && !(chosen.x >= KAPPA_SLOPE_X && chosen.kappa < KAPPA_SLOPE_MAX)
        {
            return Ok(Line {
                kappa: self.kappa(chosen.x)?,
                ..chosen
            });
        }
        Ok(chosen)
    }

    /// κ = |d ln|ζ|/d ln x| / |d ln D/d ln x| at `x` (C ∝ |ζ(x)| at a
    /// fixed |Z|): how much a reading's error in D moves C, from ζ and its
    /// exact slope ([`zeta_slope_at`](Self::zeta_slope_at)) for the
    /// continuous line, d ln|ζ| = Re(ζ'·ζ̄)/|ζ|² and
    /// d ln D = Re ζ'/Re ζ − Im ζ'/Im ζ (one evaluation); a ladder's by
    /// central differences over ±0.5 % in x. (A [`Line`]'s κ is the same
    /// quantity from the slope the solve ended on: a ladder's forward
    /// difference above [`KAPPA_SLOPE_X`], within 10⁻² of this.)
    /// Below the small-x asymptote C does not depend on D: 0.
    pub fn kappa(&self, x: f32) -> Result<f32, InvertError> {
        if x <= X_ASYMPTOTE {
            return Ok(0.0);
        }
        let x = x.clamp(crate::tline::X_MIN, crate::tline::X_MAX);
        if let LineModel::Ladder(_) = self.model {
            // Central differences over ±0.5 %: a forward difference's
            // rounding would swamp Im ζ' at small x.
            const H: f32 = 0.005;
            let at = |x: f32| -> Result<(f32, f32), InvertError> {
                let z = self.zeta(x.clamp(crate::tline::X_MIN, crate::tline::X_MAX))?;
                Ok((z.norm_sqr(), dissipation(z)))
            };
            let ((m0, d0), (m1, d1)) = (at(x * (1.0 - H))?, at(x * (1.0 + H))?);
            // ln|ζ₁| − ln|ζ₀| = ½·ln(|ζ₁|²/|ζ₀|²): two logarithms, not four.
            let k = libm::fabsf(0.5 * libm::logf(m1 / m0) / libm::logf(d1 / d0));
            return Ok(if k.is_nan() { f32::INFINITY } else { k });
        }
        let (z, s) = self.zeta_slope_at(x)?;
        Ok(kappa_of(z, s))
    }

    /// Root of D(x) = d on the monotone grid stretch [i0, i1]: x, ζ(x)
    /// and κ there.
    ///
    /// The first guess is inverse cubic interpolation of u = ln x against D
    /// through the four grid points around the root (no model evaluation);
    /// then Newton steps in u with ζ's slope
    /// ([`zeta_slope_at`](Self::zeta_slope_at)), kept inside the
    /// bracketing grid cell (regula falsi when a step would leave it).
    /// The last step, once below [`NEWTON_LAST`], is taken along the
    /// slope without evaluating the model again: what it leaves is of the
    /// order of the step squared (below 10⁻⁷ in x and ζ). One evaluation
    /// when the guess is within [`NEWTON_LAST`], which it is away from the
    /// ends of a branch.
    fn root(&self, d: f32, i0: usize, i1: usize) -> Result<Root, InvertError> {
        let (a, b, mut u) = self.start(d, i0, i1);
        // The bracket in u, g = D − d of opposite signs at its ends.
        let (mut ua, mut ga, mut ub, mut gb) = (self.u(a), self.d[a] - d, self.u(b), self.d[b] - d);
        let falsi = |ua: f32, ga: f32, ub: f32, gb: f32| ua - ga * (ub - ua) / (gb - ga);
        // (NaN fails both comparisons.)
        if !(u > ua && u < ub) {
            u = falsi(ua, ga, ub, gb);
        }
        let mut best = Root {
            x: libm::expf(u),
            zeta: Complex32::new(0.0, -1.0),
            kappa: f32::INFINITY,
        };
        let mut best_g = f32::INFINITY;
        for _ in 0..12 {
            // exp(ln X_MAX) may round a hair above X_MAX.
            let x = min(libm::expf(u), crate::tline::X_MAX);
            let (zeta, s) = self.zeta_slope_inline(x)?;
            let g = dissipation(zeta) - d;
            // dD/du = (Re ζ·Im ζ' − Re ζ'·Im ζ)/(Im ζ)².
            let dg = (zeta.re * s.im - s.re * zeta.im) / (zeta.im * zeta.im);
            let step = -g / dg;
            if libm::fabsf(step) <= NEWTON_LAST {
                return Ok(self.last_step(x, zeta, s, step));
            }
            if g.abs() < best_g {
                best_g = g.abs();
                best = Root {
                    x,
                    zeta,
                    kappa: kappa_of(zeta, s),
                };
            }
            if (g > 0.0) == (gb > 0.0) {
                (ub, gb) = (u, g);
            } else {
                (ua, ga) = (u, g);
            }
            if ub - ua < 1e-7 {
                break;
            }
            let next = u + step;
            u = if next > ua && next < ub {
                next
            } else {
                falsi(ua, ga, ub, gb)
            };
        }
        Ok(best)
    }

    /// Where [`Self::root`] starts on the branch of grid points `i0..=i1`:
    /// the grid cell `a..=b` whose D brackets `d` (by bisection, no model
    /// evaluations) and the guess in ln x, the cubic through the four
    /// grid points around the cell inside the branch (NaN on a branch too
    /// short for one: the caller's falsi).
    #[inline(always)]
    fn start(&self, d: f32, i0: usize, i1: usize) -> (usize, usize, f32) {
        let up = self.d[i1] >= self.d[i0];
        let (mut a, mut b) = (i0, i1);
        while b - a > 1 {
            let m = (a + b) / 2;
            if (self.d[m] < d) == up {
                a = m;
            } else {
                b = m;
            }
        }
        let u = if i1 - i0 >= 3 {
            let k = a.saturating_sub(1).max(i0).min(i1 - 3);
            let u = [self.u(k), self.u(k + 1), self.u(k + 2), self.u(k + 3)];
            cubic_through(d, &self.d[k..k + 4], &u)
        } else {
            f32::NAN
        };
        (a, b, u)
    }

    /// [`Self::root`]'s last Newton step, along the slope: x·e^step and
    /// ζ + ζ'·step, to step², from the line at `x` (`zeta`, its slope
    /// `s`). The continuous line's slope follows from ζ: κ at the root
    /// itself (near the peak of D, κ moves by 10⁻³ over such a step).
    #[inline(always)]
    fn last_step(&self, x: f32, zeta: Complex32, s: Complex32, step: f32) -> Root {
        let x = min(x * (1.0 + step * (1.0 + 0.5 * step)), crate::tline::X_MAX);
        let zeta = zeta + s * step;
        let s = match self.model {
            LineModel::Continuous => {
                self.continuous_slope(Complex32::new(zeta.re - self.lead * x, zeta.im), x)
            }
            LineModel::Ladder(_) => s,
        };
        Root {
            x,
            zeta,
            kappa: kappa_of(zeta, s),
        }
    }
}

/// Below this Newton step (in ln x) [`Inverter::root`] takes the step
/// along ζ's slope instead of evaluating the model again: the step squared
/// (10⁻⁷) is what that leaves, at f32's rounding of D.
const NEWTON_LAST: f32 = 3e-4;

/// Above this x, and where it is below [`KAPPA_SLOPE_MAX`], a ladder's
/// [`Line::kappa`] comes from the forward difference the solve ended on;
/// elsewhere from [`Inverter::kappa`] (two more evaluations).
pub const KAPPA_SLOPE_X: f32 = 0.5;
/// See [`KAPPA_SLOPE_X`].
pub const KAPPA_SLOPE_MAX: f32 = 10.0;

/// u(d) by the Lagrange cubic through the four points (dₖ, uₖ) (the dₖ
/// distinct: one monotone stretch of the grid), in straight-line code.
#[inline]
fn cubic_through(d: f32, ds: &[f32], us: &[f32]) -> f32 {
    let (Some(&[d0, d1, d2, d3]), Some(&[u0, u1, u2, u3])) = (ds.first_chunk::<4>(), us.first_chunk::<4>())
    else {
        return f32::NAN;
    };
    let (e0, e1, e2, e3) = (d - d0, d - d1, d - d2, d - d3);
    let (d01, d02, d03, d12, d13, d23) = (d0 - d1, d0 - d2, d0 - d3, d1 - d2, d1 - d3, d2 - d3);
    u0 * (e1 * e2 * e3) / (d01 * d02 * d03) - u1 * (e0 * e2 * e3) / (d01 * d12 * d13)
        + u2 * (e0 * e1 * e3) / (d02 * d12 * d23)
        - u3 * (e0 * e1 * e2) / (d03 * d13 * d23)
}

/// A frequency and an impedance an inversion can take: f finite and
/// positive, Z finite and capacitive (Re ≥ 0, Im < 0), and a prior of
/// positive finite capacitances in order.
#[inline(always)]
fn check_inputs(z: Complex32, f_hz: f32, hint: Select) -> Result<(), InvertError> {
    if !positive_finite(f_hz) {
        return Err(InvertError::BadFrequency);
    }
    if !(z.re.is_finite() && z.im.is_finite() && z.re >= 0.0 && z.im < 0.0) {
        return Err(InvertError::NotCapacitive);
    }
    let good = positive_finite;
    match hint {
        Select::Near(c) if !good(c) => Err(InvertError::BadPrior),
        Select::Within(lo, hi) if !(good(lo) && good(hi) && lo <= hi) => Err(InvertError::BadPrior),
        _ => Ok(()),
    }
}

/// The line `hint` picks of `lines` (at least one), where `one` says a
/// single line fits and `tail_c` is the least C of the tail's lines, if
/// they fit too.
#[inline(always)]
fn choose(hint: Select, lines: &[Option<Line>], one: bool, tail_c: Option<f32>) -> Result<Line, InvertError> {
    let mut rest = lines.iter().flatten();
    let Some(&first) = rest.next() else {
        return Err(InvertError::OutOfRange);
    };
    match hint {
        _ if one => Ok(first),
        Select::Within(lo, hi) => {
            let inside = |c: f32| c >= lo && c <= hi;
            let mut picked = inside(first.c_farad).then_some(first);
            for l in rest.filter(|l| inside(l.c_farad)) {
                if picked.is_some() {
                    return Err(InvertError::Ambiguous);
                }
                picked = Some(*l);
            }
            if tail_c.is_some_and(|ct| ct <= hi) {
                return Err(InvertError::Ambiguous);
            }
            picked.ok_or(InvertError::OutOfRange)
        }
        Select::Unique => Err(InvertError::Ambiguous),
        Select::Near(c) => {
            let dist = |l: &Line| libm::fabsf(libm::logf(l.c_farad / c));
            let (mut best, mut d_best, mut d_next) = (first, dist(&first), f32::INFINITY);
            for l in rest {
                let dl = dist(l);
                if dl < d_best {
                    (best, d_next, d_best) = (*l, d_best, dl);
                } else {
                    // (A NaN dl leaves d_next, as min would.)
                    d_next = min(d_next, dl);
                }
            }
            // The tail's lines: the closest of them to the prior.
            if let Some(ct) = tail_c {
                d_next = min(d_next, max(libm::logf(ct / c), 0.0));
            }
            // NaN distances (a non-finite C) never pass.
            let gap = d_next - d_best;
            if gap.is_nan() || gap < SEPARATION {
                return Err(InvertError::Ambiguous);
            }
            Ok(best)
        }
    }
}

/// A root of D(x) = d.
#[derive(Clone, Copy)]
struct Root {
    x: f32,
    zeta: Complex32,
    kappa: f32,
}

/// κ from ζ and its slope dζ/d ln x ([`Inverter::kappa`]); ∞ where D's
/// slope vanishes or the quotient is not a number.
fn kappa_of(z: Complex32, s: Complex32) -> f32 {
    let d_mag = (s.re * z.re + s.im * z.im) / z.norm_sqr();
    let d_dis = s.re / z.re - s.im / z.im;
    let k = libm::fabsf(d_mag / d_dis);
    if k.is_nan() {
        f32::INFINITY
    } else {
        k
    }
}

/// How to pick among the lines that fit one reading.
#[derive(Clone, Copy)]
enum Select {
    /// Only where one line fits.
    Unique,
    /// The one closest to a prior C (F), by [`SEPARATION`].
    Near(f32),
    /// The only one with C in a range (F).
    Within(f32, f32),
}

/// D = Re ζ / (−Im ζ).
#[inline]
fn dissipation(zeta: Complex32) -> f32 {
    zeta.re / -zeta.im
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared grid is, bit for bit, the grid each inverter computed
    /// for itself before: X_ASYMPTOTE to X_MAX, log-spaced, through
    /// libm's expf and logf.
    #[test]
    fn the_shared_grid_is_the_computed_one() {
        let (u0, u1) = (libm::logf(X_ASYMPTOTE), libm::logf(crate::tline::X_MAX));
        for (k, &u) in INVERT_GRID_U.iter().enumerate() {
            let x = libm::expf(u0 + (u1 - u0) * k as f32 / (GRID - 1) as f32).min(crate::tline::X_MAX);
            assert_eq!(libm::logf(x).to_bits(), u.to_bits(), "point {k}");
        }
    }

    /// Moved points read back where they were moved; the others stay the
    /// grid's.
    #[test]
    fn moved_points_read_back() {
        for model in [LineModel::Continuous, LineModel::Ladder(30)] {
            let inv = Inverter::new(model);
            let mut n = 0;
            for (k, &grid) in INVERT_GRID_U.iter().enumerate() {
                let ends = &inv.ends[1..inv.branches];
                if ends.contains(&k) {
                    n += 1;
                    assert_ne!(inv.u(k), grid, "{model:?} end {k} refined");
                } else {
                    assert_eq!(inv.u(k).to_bits(), grid.to_bits());
                }
            }
            assert_eq!(
                n,
                inv.moved_at.iter().filter(|&&a| a != u8::MAX).count(),
                "{model:?}"
            );
            assert!(n >= 1, "{model:?}: the first peak is refined");
        }
    }
}
