//! Tracking the line over successive blocks: the branch choice and the
//! plausibility checks a running sensor needs around [`Inverter`].
//!
//! * Unlocked (at the start, or after [`Tracker::RELOCK_AFTER`] rejections
//!   in a row) the tracker accepts the inversion as it is where it is
//!   unique; where several lines fit, it takes the one whose C lies in the
//!   band a sensor can have ([`Tracker::with_band`]: the calibration's
//!   range around the prior), and none if more than one does (the prior
//!   alone would pick a line close to the rest value over the true one of
//!   a stretched sensor); then it locks.
//! * Locked, the previous block's C picks the branch (see
//!   [`invert`](crate::invert)), and a result that moves C by more than
//!   [`Tracker::MAX_JUMP`] is rejected: a real sensor changes C by well
//!   under 1 % per block, so such a jump is a branch error or a fault.
//! * Where D lies within [`Tracker::ILL_CONDITIONED`] of the peak of D(x),
//!   D hardly depends on x: the tracker holds the previous C (and says so)
//!   rather than amplify the noise.

use crate::invert::{InvertError, Inverter, Line};
use crate::tline::{LineModel, ModelError};
use crate::Complex32;
use core::f32::consts::TAU;

/// Tracker configuration: the inverter and its grid (≈280 bytes), shared by
/// every channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker {
    inverter: Inverter,
    /// Unlocked, a line's C must lie in prior·band (ratios).
    band: (f32, f32),
}

/// Tracker state of one channel (16 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackState {
    prior: f32,
    hint: f32,
    locked: bool,
    rejected: u32,
}

impl TrackState {
    /// A channel whose sensor rests at `prior_farad` (its calibration).
    pub const fn new(prior_farad: f32) -> Self {
        Self {
            prior: prior_farad,
            hint: prior_farad,
            locked: false,
            rejected: 0,
        }
    }

    /// The currently tracked capacitance, F.
    pub fn capacitance(&self) -> f32 {
        self.hint
    }

    /// True once a value is tracked.
    pub fn locked(&self) -> bool {
        self.locked
    }

    /// Forget the tracked value and start again, unlocked, from the prior.
    pub fn reset(&mut self) {
        *self = Self::new(self.prior);
    }
}

/// One tracked result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    /// The line.
    pub line: Line,
    /// True if C was held from the previous block (ill-conditioned D).
    pub held: bool,
}

impl Tracker {
    /// Largest accepted relative change of C between blocks.
    pub const MAX_JUMP: f32 = 0.15;
    /// Rejections in a row after which the prior replaces the tracked C.
    pub const RELOCK_AFTER: u32 = 5;
    /// Relative distance from the peak of D within which C is held.
    pub const ILL_CONDITIONED: f32 = 1e-3;
    /// Default upper end of x = ωRC: the falling branch of D beyond its peak
    /// (x ≈ 7.71) is still usable up to here with a tracked prior.
    pub const X_MAX: f32 = 16.0;

    /// A tracker for `model` over x ≤ `x_max`.
    pub fn new(model: LineModel, x_max: f32) -> Result<Self, ModelError> {
        Self::with_leads(model, x_max, 0.0)
    }

    /// A tracker for `model` with tab leads of `lead_ratio` times the
    /// line's resistance at the read end ([`Inverter::with_leads`]).
    pub fn with_leads(model: LineModel, x_max: f32, lead_ratio: f32) -> Result<Self, ModelError> {
        Ok(Self {
            inverter: Inverter::with_leads(model, x_max, lead_ratio)?,
            band: Self::BAND,
        })
    }

    /// Default band of C (ratios to the prior) an unlocked tracker accepts
    /// where several lines fit: 0.9 to 1.5 (a DE sensor's C grows with
    /// stretch, by ≈ 30 % at the paper's 30 mm).
    pub const BAND: (f32, f32) = (0.9, 1.5);

    /// The same tracker, accepting (when unlocked and several lines fit)
    /// only lines with C in `lo_ratio..=hi_ratio` times the prior: the
    /// range the sensor's calibration spans, with a margin.
    pub fn with_band(mut self, lo_ratio: f32, hi_ratio: f32) -> Self {
        self.band = (lo_ratio, hi_ratio);
        self
    }

    /// The band of C (ratios to the prior) an unlocked tracker accepts.
    pub fn band(&self) -> (f32, f32) {
        self.band
    }

    /// The inverter in use.
    pub fn inverter(&self) -> &Inverter {
        &self.inverter
    }

    /// The line behind impedance `z` (Ω) at `f_hz`. Errors are those of
    /// [`Inverter`], plus [`InvertError::Jump`] for a rejected jump.
    pub fn update(&self, st: &mut TrackState, z: Complex32, f_hz: f32) -> Result<Tracked, InvertError> {
        if !(f_hz.is_finite() && f_hz > 0.0) {
            return Err(InvertError::BadFrequency);
        }
        let (x_peak, d_peak) = self.inverter.peak();
        if st.locked && z.im < 0.0 && z.re >= 0.0 && st.rejected == 0 {
            let d = z.re / -z.im;
            if (d - d_peak).abs() <= d_peak * Self::ILL_CONDITIONED {
                let c = st.hint;
                let line = Line {
                    r_ohm: x_peak / (TAU * f_hz * c),
                    c_farad: c,
                    x: x_peak,
                    kappa: f32::INFINITY,
                };
                return Ok(Tracked { line, held: true });
            }
        }
        let r = if st.locked {
            self.inverter.invert_near(z, f_hz, st.hint).and_then(|line| {
                if (line.c_farad / st.hint - 1.0).abs() <= Self::MAX_JUMP {
                    Ok(line)
                } else {
                    Err(InvertError::Jump)
                }
            })
        } else {
            let (lo, hi) = self.band;
            self.inverter.invert_within(z, f_hz, st.prior * lo, st.prior * hi)
        };
        match r {
            Ok(line) => {
                st.hint = line.c_farad;
                st.locked = true;
                st.rejected = 0;
                Ok(Tracked { line, held: false })
            }
            Err(e) => {
                st.rejected += 1;
                if st.rejected >= Self::RELOCK_AFTER {
                    st.reset();
                }
                Err(e)
            }
        }
    }
}
