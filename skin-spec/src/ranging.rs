//! Auto-ranging of the transimpedance stage: the feedback resistor
//! ([`design::TIA_RANGES_OHM`]) each channel is read through, chosen from
//! the current its last block drew, as an LCR meter switches ranges.
//!
//! The C a block yields is off by about (noise / current amplitude) times
//! the line's sensitivity (`sigma_ln_c` of [`dsp_core::twotone::Solution`]),
//! so the current should fill the ADC: a sensor of 3 MΩ (the paper's, with
//! its tab leads, after cycling) on 100 kΩ draws ~40 of the ADC's 2048
//! counts; on 1 MΩ, ~400. A range is a pure gain: the firmware divides
//! it out with that range's [`dsp_core::demod::FrontEnd`].
//!
//! The rule, for a block of current amplitude A (counts) at range k:
//!
//! ```text
//! A' = A · max(1, f_next / f)                  (the next block's frequency:
//!                                               a capacitive current grows with f)
//! clipped                → range 0 (a clipped block's amplitude is only a lower bound)
//! A' ≥ DOWN·H             → the largest range j < k with A'·R_j/R_k ≤ TARGET·H (else 0)
//! A'·R_j/R_k ≤ TARGET·H for some j > k → the largest such j
//! ```
//!
//! with H the ADC's half scale: ranges switch only between TARGET (0.6)
//! and DOWN (0.85) of full scale, never back and forth (the steps of
//! about 2.2× make the band wide enough).

use crate::design::{self, RANGES};
use dsp_core::demod::FrontEnd;

/// The auto-ranging rule (configuration; the state is the channel's range
/// index).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ranging {
    /// Feedback resistance of each range, Ω (ascending).
    pub ranges_ohm: [f32; RANGES],
    /// ADC half scale, counts.
    pub half_scale: f32,
    /// Fraction of the half scale a new range aims under.
    pub target: f32,
    /// Fraction of the half scale at which the range steps down.
    pub down: f32,
}

impl Ranging {
    /// The board's ranges and ADC ([`design`]).
    pub const DEFAULT: Self = Self {
        ranges_ohm: {
            let mut r = [0.0f32; RANGES];
            let mut k = 0;
            while k < RANGES {
                r[k] = design::TIA_RANGES_OHM[k] as f32;
                k += 1;
            }
            r
        },
        half_scale: design::ADC_OFFSET_CODE as f32,
        target: 0.6,
        down: 0.85,
    };

    /// A single range (no switching), for a fixed front end.
    pub const fn fixed(r_ohm: f32) -> Self {
        Self {
            ranges_ohm: [r_ohm; RANGES],
            ..Self::DEFAULT
        }
    }

    /// The front end of each range: an inverting transimpedance of R_k
    /// with the voltage channel's gain `v_gain` (Z = k·V/I, k = −R_k/v_gain).
    pub fn front_ends(&self, v_gain: f32) -> [FrontEnd; RANGES] {
        self.ranges_ohm
            .map(|r| FrontEnd::transimpedance(r / v_gain, true))
    }

    /// The range for the next block of a channel whose last block, read
    /// at range `k`, had a current amplitude of `amplitude` counts
    /// (`clipped` if a sample hit a rail), the next block playing at
    /// `growth` times the last one's frequency. An amplitude that is not
    /// a number keeps the range.
    pub fn next(&self, k: usize, amplitude: f32, clipped: bool, growth: f32) -> usize {
        let k = k.min(RANGES - 1);
        let a = amplitude * growth.max(1.0);
        if a.is_nan() || a < 0.0 {
            return k;
        }
        let at = |j: usize| a * self.ranges_ohm[j] / self.ranges_ohm[k];
        let fits = |j: usize| at(j) <= self.target * self.half_scale;
        if clipped {
            return 0;
        }
        if a >= self.down * self.half_scale {
            return (0..k).rev().find(|&j| fits(j)).unwrap_or(0);
        }
        (k + 1..RANGES)
            .rev()
            .find(|&j| fits(j) && self.ranges_ohm[j] > self.ranges_ohm[k])
            .unwrap_or(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_fill_the_adc_and_do_not_chatter() {
        let r = Ranging::DEFAULT;
        let h = r.half_scale;
        // 40 counts on 100 kΩ: 400 on 1 MΩ.
        assert_eq!(r.next(0, 40.0, false, 1.0), 3);
        // 0.3 H on 470 kΩ: 1 MΩ would be 0.64 H, over the target: stay.
        assert_eq!(r.next(2, 0.3 * h, false, 1.0), 2);
        // 0.84 H stays; 0.86 H steps down to the largest range that fits.
        assert_eq!(r.next(3, 0.84 * h, false, 1.0), 3);
        assert_eq!(r.next(3, 0.86 * h, false, 1.0), 2);
        // A clipped block goes to the lowest range, from where the next
        // block finds the right one at once.
        assert_eq!(r.next(3, 0.5 * h, true, 1.0), 0);
        assert_eq!(r.next(3, 10.0 * h, true, 1.0), 0);
        assert_eq!(r.next(0, 10.0 * h, true, 1.0), 0);
        // A frequency rise of 3× is foreseen.
        assert_eq!(r.next(3, 0.4 * h, false, 3.0), 2);
        // NaN keeps the range; out-of-range indices are clamped.
        assert_eq!(r.next(2, f32::NAN, false, 1.0), 2);
        assert_eq!(r.next(9, 0.5 * h, false, 1.0), 3);
        // Whatever the amplitude, a step up lands under the target and a
        // step down under the down threshold: the next block does not
        // undo it.
        for k in 0..RANGES {
            for n in 0..2000 {
                let a = n as f32 * 0.001 * h;
                let j = r.next(k, a, false, 1.0);
                let at = a * r.ranges_ohm[j] / r.ranges_ohm[k];
                if j != k {
                    assert!(at <= r.target * h || j == 0, "{k} {a} -> {j}");
                    assert_eq!(r.next(j, at, false, 1.0), j, "{k} {a} -> {j}: chatter");
                }
            }
        }
        // A fixed front end never switches.
        let f = Ranging::fixed(1e5);
        assert_eq!(f.next(0, 1.0, false, 1.0), 0);
    }
}
