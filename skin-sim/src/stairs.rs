//! A calibration run's stretching: the skin relaxed, then held at each
//! stretch of a calibration table in turn (0, 3, …, 30 mm), moved between
//! them at a moderate rate, as a user does on a stage. [`holds`] gives
//! each hold's span for the host's `live calibrate`, which fits each
//! sensor from the records taken within them.
//!
//! The start of each hold is left out ([`SETTLE_S`]): the move has just
//! raised the electrodes' resistance (breakdown, τ ≈ 0.12 s) and the
//! tone policy has stepped down; what follows still drifts with the
//! electrodes' recovery (τ ≈ 1.4 s), which the fit allows for by giving
//! each part of a hold its own resistance.

use crate::profile::Profile;

/// Stretches held, 0 to 30 mm every [`STEP_MM`].
pub const LEVELS: usize = 11;
/// Stretch between holds, mm.
pub const STEP_MM: f64 = 3.0;
/// Rate of the moves between holds, mm/s.
pub const RATE_MM_S: f64 = 10.0;
/// The first hold (relaxed), s: long enough for the tone policy to climb
/// from its lowest tone.
pub const FIRST_HOLD_S: f64 = 1.2;
/// Each later hold, s.
pub const HOLD_S: f64 = 0.8;
/// The start of each hold left out, s.
pub const SETTLE_S: f64 = 0.25;

/// When hold `k` begins, s.
const fn hold_start(k: usize) -> f64 {
    if k == 0 {
        0.0
    } else {
        FIRST_HOLD_S + k as f64 * (STEP_MM / RATE_MM_S) + (k - 1) as f64 * HOLD_S
    }
}

/// When hold `k` ends, s.
const fn hold_end(k: usize) -> f64 {
    if k == 0 {
        FIRST_HOLD_S
    } else {
        hold_start(k) + HOLD_S
    }
}

/// The profile's (time s, stretch mm) corners: each hold's start and end.
const fn corners() -> [(f64, f64); 2 * LEVELS] {
    let mut p = [(0.0, 0.0); 2 * LEVELS];
    let mut k = 0;
    while k < LEVELS {
        let s = k as f64 * STEP_MM;
        p[2 * k] = (hold_start(k), s);
        p[2 * k + 1] = (hold_end(k), s);
        k += 1;
    }
    p
}

/// The corners of [`PROFILE`].
pub const CORNERS: [(f64, f64); 2 * LEVELS] = corners();

/// The stretching: piecewise linear through [`CORNERS`], held at the last
/// stretch after the last hold.
pub const PROFILE: Profile<'static> = Profile::Table(&CORNERS);

/// Simulated time to the end of the last hold, s.
pub const DURATION_S: f64 = hold_end(LEVELS - 1);

/// One hold as the host reads it: the stretch, and the span of the
/// records taken at it (s since the run's start).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Stretch held, mm.
    pub stretch_mm: f64,
    /// Start of the span used, s (the hold's start plus [`SETTLE_S`]).
    pub from_s: f64,
    /// End of the span used, s.
    pub to_s: f64,
}

/// Every hold, in order.
pub fn holds() -> [Hold; LEVELS] {
    core::array::from_fn(|k| Hold {
        stretch_mm: k as f64 * STEP_MM,
        from_s: hold_start(k) + SETTLE_S,
        to_s: hold_end(k),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_hold_is_still_and_at_its_stretch() {
        let h = holds();
        assert_eq!(h[0].stretch_mm, 0.0);
        assert_eq!(h[LEVELS - 1].stretch_mm, 30.0);
        for (k, hold) in h.iter().enumerate() {
            assert!(hold.to_s - hold.from_s >= 0.5, "{hold:?}");
            let mut t = hold.from_s;
            while t <= hold.to_s {
                assert_eq!(PROFILE.at(t), (hold.stretch_mm, 0.0), "hold {k} at {t} s");
                t += 0.01;
            }
            if k > 0 {
                // The move before it, at the stated rate.
                let mid = hold.from_s - SETTLE_S - 0.5 * STEP_MM / RATE_MM_S;
                let (s, v) = PROFILE.at(mid);
                assert!((v - RATE_MM_S).abs() < 1e-9 && (s - (hold.stretch_mm - 1.5)).abs() < 1e-9);
            }
        }
        assert_eq!(PROFILE.at(DURATION_S + 5.0), (30.0, 0.0));
    }
}
