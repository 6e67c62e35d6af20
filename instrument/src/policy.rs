//! Adaptive excitation frequency.
//!
//! The rule: remember the peak electrode resistance seen recently, R̂ (a
//! peak detector that decays by `decay_per_s` per second), and use the
//! highest frequency f of the set for which x̂ = 2π·f·R̂·C ≤ `x_limit`,
//! where C is the current line capacitance. x̂ bounds the *model error
//! amplification* of the line inversion, κ = |d ln C / d ln D|: the
//! relative capacitance error per relative error of the measured
//! dissipation factor (noise, or any deviation of the sensor from the
//! uniform-line model). For the continuous line κ = 0.14, 0.45, 0.86, 1.43,
//! 2.4, 4.7, 13.5 at x = 1…7, and infinite at the peak of D (x ≈ 7.71). The
//! default x ≤ 4 keeps κ ≤ 1.5.
//!
//! * Down: at once, the first block in which x̂ at the current frequency
//!   exceeds `x_limit` (resistance peaks come fast).
//! * Up: only when `hold_s` has passed since the last switch, to the
//!   highest frequency whose x̂ stays below `x_limit·(1 − hysteresis)`.
//! * A channel starts at the lowest frequency, where every inversion is
//!   unique whatever the sensor, and climbs after its first good block.
//! * After every switch `settle_blocks` blocks are discarded.
//!
//! Higher frequencies mean shorter periods, more periods per block, and
//! less 50/60 Hz pickup, so the policy sits as high as the bound allows.

use crate::config::{freq_hz, FREQS_HZ, PERIODS};
use core::f32::consts::TAU;
use dsp_core::fmath;

/// Policy parameters, as a device keeps them
/// ([`crate::stored::Stored::policy`], checked by [`Policy::check`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Policy {
    /// Largest x = 2π·f·R̂·C allowed at the remembered peak resistance
    /// (0.5 … 16).
    pub x_limit: f32,
    /// Relative margin below `x_limit` required before switching up
    /// (0 … 0.5).
    pub hysteresis: f32,
    /// Fraction by which the remembered peak decays per second (0 … 10).
    pub decay_per_s: f32,
    /// Minimum time between switches up, s (0 … 60).
    pub hold_s: f32,
    /// Blocks discarded after a switch (0 … 16).
    pub settle_blocks: u8,
    /// The lowest and the highest index of the frequency set the policy
    /// may choose, lowest first (a device's set must keep them within
    /// the set; here, the highest beyond it means its last).
    pub tones: (u8, u8),
}

impl Policy {
    /// Defaults: x ≤ 4, 5 % hysteresis (the decaying peak memory is the
    /// main hysteresis: in time), the peak memory halves in ~1.4 s, 0.5 s
    /// between switches up, one block of settling.
    pub const DEFAULT: Self = Self {
        x_limit: 4.0,
        hysteresis: 0.05,
        decay_per_s: 0.5,
        hold_s: 0.5,
        settle_blocks: 1,
        tones: (0, PERIODS.len() as u8 - 1),
    };
}

/// Policy state of one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolicyState {
    /// Index into the frequency set.
    pub fidx: usize,
    /// Remembered peak resistance R̂, Ω.
    pub r_peak: f32,
    /// Time since the last switch, s.
    pub since_switch_s: f32,
    /// Blocks still to discard.
    pub settling: u8,
}

impl PolicyState {
    /// Start at the lowest frequency with no memory, free to climb.
    pub const fn new() -> Self {
        Self {
            fidx: 0,
            r_peak: 0.0,
            since_switch_s: f32::MAX,
            settling: 1,
        }
    }
}

impl Default for PolicyState {
    fn default() -> Self {
        Self::new()
    }
}

impl Policy {
    /// x at frequency index `i` for resistance `r` and capacitance `c`.
    pub fn x(i: usize, r: f32, c: f32) -> f32 {
        TAU * freq_hz(i) * r * c
    }

    /// Update with a measured line (R Ω, C F) after `dt_s` seconds; returns
    /// true if the frequency changed.
    pub fn update(&self, st: &mut PolicyState, r_ohm: f32, c_farad: f32, dt_s: f32) -> bool {
        self.update_on(&FREQS_HZ, st, r_ohm, c_farad, dt_s)
    }

    /// As [`Policy::update`] on another frequency set (`set_hz`, Hz,
    /// ascending; `st.fidx` indexes it): the array's comb.
    pub fn update_on(
        &self,
        set_hz: &[f32],
        st: &mut PolicyState,
        r_ohm: f32,
        c_farad: f32,
        dt_s: f32,
    ) -> bool {
        let x = |i: usize, r: f32| TAU * set_hz[i] * r * c_farad;
        st.since_switch_s = fmath::min(st.since_switch_s + dt_s, f32::MAX);
        let decayed = st.r_peak * fmath::max(1.0 - self.decay_per_s * dt_s, 0.0);
        st.r_peak = fmath::max(decayed, r_ohm);
        let (lo, hi) = self.limits(set_hz.len());
        let mut target = st.fidx.clamp(lo, hi);
        while target > lo && x(target, st.r_peak) > self.x_limit {
            target -= 1;
        }
        if target == st.fidx && st.since_switch_s >= self.hold_s {
            while target < hi && x(target + 1, st.r_peak) <= self.x_limit * (1.0 - self.hysteresis) {
                target += 1;
            }
        }
        if target != st.fidx {
            st.fidx = target;
            st.since_switch_s = 0.0;
            st.settling = self.settle_blocks;
            true
        } else {
            false
        }
    }

    /// The indices of a set of `len` frequencies the policy may use,
    /// lowest first (`tones` within the set).
    pub fn limits(&self, len: usize) -> (usize, usize) {
        let last = len.saturating_sub(1);
        let hi = usize::from(self.tones.1).min(last);
        (usize::from(self.tones.0).min(hi), hi)
    }

    /// The frequency to use after a fault that left no measurement: the
    /// lowest allowed, which tolerates the most resistance.
    pub fn fallback(&self, st: &mut PolicyState) -> bool {
        let lo = self.limits(PERIODS.len()).0;
        let changed = st.fidx != lo;
        if changed {
            st.fidx = lo;
            st.since_switch_s = 0.0;
            st.settling = self.settle_blocks;
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_policy_stays_within_its_tones() {
        let p = Policy {
            tones: (1, 3),
            hold_s: 0.0,
            ..Policy::DEFAULT
        };
        let mut st = PolicyState::new();
        // A tiny line: every tone is allowed. From the start (index 0) the
        // policy steps into its limits, then climbs to 3, not 4.
        p.update(&mut st, 1e3, 1e-12, 0.01);
        assert_eq!(st.fidx, 1);
        p.update(&mut st, 1e3, 1e-12, 0.01);
        assert_eq!(st.fidx, 3);
        // A huge line: down to 1, not 0.
        p.update(&mut st, 1e9, 1e-9, 0.01);
        assert_eq!(st.fidx, 1);
        st.fidx = 4;
        p.fallback(&mut st);
        assert_eq!(st.fidx, 1);
        // Limits beyond the set end at its last entry.
        let wide = Policy {
            tones: (9, 200),
            ..Policy::DEFAULT
        };
        assert_eq!(wide.limits(PERIODS.len()), (4, 4));
        assert_eq!(Policy::DEFAULT.limits(PERIODS.len()), (0, 4));
    }
}
