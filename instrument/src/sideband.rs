//! The sideband of the tone a channel avoids, fitted beside the comb
//! ([`dsp_core::sideband`]), and what it still leaks, bounded.
//!
//! A channel that moved off a tone ([`crate::avoid`]) did so because
//! something occupies it: an interferer in its bin, a mains harmonic or
//! an alias on it. An interferer δ of a bin off the tone also leaks into
//! the tones the channel moved to (20 Hz off 500 Hz: 9.9 % of its
//! amplitude into 250 Hz) and into the residual, and the records are
//! UNCERTAIN. Fitted beside the comb, the tone's sideband takes the
//! first-order leak out of both, at the price of some noise on the
//! neighbouring tones. What is left is bounded, not assumed away:
//!
//! * **The leak left** into tone j is at most
//!   `Layout::sideband_leak(k, j, δ)` times the sideband fitted, |p|,
//!   with δ the interferer's distance from the tone, in bins.
//! * **δ from the sideband's turn.** From block to block the sideband
//!   turns by 2π·δ (the block is a whole number of the tone's periods).
//!   Its differences two blocks apart, eᵦ = pᵦ − pᵦ₋₂, remove what does
//!   not turn (a stretching sensor's own tone changing across the block)
//!   and share no noise with the previous one; Σλᵃ·eᵦ·conj eᵦ₋₁ turns by
//!   the mean angle 2π·δ̂. The bound is taken at δ̂ plus three standard
//!   errors of that mean (from the spread of the products' angles and
//!   the window's effective count), at ½ (the most) until the window
//!   holds [`MIN_BLOCKS`] blocks or where the products do not agree.
//!
//! The 1 ms layout never moves off a tone, and fits no sideband.

use crate::array::{Layout, BLOCK_INSTANTS, SCAN, TONES};
use crate::reader::BlockComb;
use crate::tones::Input;
use dsp_core::fmath;
use dsp_core::sideband::Sideband;
use dsp_core::Complex32;

/// The window's time constant, s: 50 blocks of 4 ms.
pub const TAU_S: f32 = 0.2;

/// The least effective count of products before δ̂ is believed.
pub const MIN_BLOCKS: f32 = 8.0;

/// "No tone".
const NONE: u8 = u8::MAX;

/// Every comb tone's sideband in 4 ms blocks (configuration).
#[derive(Clone, Debug)]
pub struct Sidebands {
    tones: [Sideband<BLOCK_INSTANTS, TONES>; TONES],
    layout: Layout,
    /// λ a block.
    forget: f32,
}

impl Sidebands {
    /// The sidebands of `comb`'s tones; None for 1 ms blocks.
    #[inline(never)]
    pub fn new(comb: &BlockComb, layout: Layout) -> Option<Self> {
        let BlockComb::Long(c) = comb else { return None };
        let first = Sideband::new(0, c)?;
        let mut tones: [Sideband<BLOCK_INSTANTS, TONES>; TONES] = core::array::from_fn(|_| first.clone());
        for (k, slot) in tones.iter_mut().enumerate().skip(1) {
            *slot = Sideband::new(k, c)?;
        }
        Some(Self {
            tones,
            forget: 1.0 - layout.block_us() as f32 * 1e-6 / TAU_S,
            layout,
        })
    }

    /// Input column `col`'s sums against tone `k`'s sideband (none for
    /// a tone beyond the comb).
    #[inline(never)]
    pub fn sums(&self, k: usize, rows: &[[i16; SCAN]; BLOCK_INSTANTS], col: usize) -> [i64; 2] {
        self.tones.get(k).map_or([0; 2], |s| s.sums(rows, col))
    }

    /// Tone `k`'s sideband (`sums`) out of `into` where it stands out of
    /// the block's noise, into `track`; then every tone's leak bound,
    /// counts, into `into.leak` (0 where none was taken out: the
    /// residual's bound covers a sideband left in).
    #[inline(never)]
    pub fn take_out(&self, sums: [i64; 2], k: usize, track: &mut Track, into: &mut Input<'_>, clean: f32) {
        let Some(sideband) = self.tones.get(k) else { return };
        let Some((p, gains)) = sideband.cancel(sums, into.tones, &mut into.levels, clean) else {
            track.skip(k);
            return;
        };
        for (g, n) in into.gains.iter_mut().zip(gains) {
            *g *= n;
        }
        let delta = track.update(k, Complex32::new(p[0], p[1]), self.forget);
        let size = fmath::hypot(p[0], p[1]);
        for (j, leak) in into.leak.iter_mut().enumerate() {
            *leak = if j == k {
                0.0
            } else {
                self.layout.sideband_leak(k, j, delta) * size
            };
        }
    }
}

/// One sensor's sideband from block to block: how it turns (state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// The tone the history is of, or [`NONE`].
    tone: u8,
    /// pᵦ₋₁ and pᵦ₋₂, and how many of them are held (0–2).
    last: [Complex32; 2],
    held: u8,
    /// eᵦ₋₁, where `held` was 2 a block ago.
    diff: Option<Complex32>,
    /// Σλᵃ·eᵦ·conj eᵦ₋₁.
    turn: Complex32,
    /// Σλᵃ·|eᵦ|·|eᵦ₋₁|.
    size: f32,
    /// Σλᵃ and Σλ²ᵃ over the products.
    weight: f32,
    weight2: f32,
}

impl Default for Track {
    fn default() -> Self {
        Self::NEW
    }
}

impl Track {
    /// No history.
    pub const NEW: Self = Self {
        tone: NONE,
        last: [Complex32::new(0.0, 0.0); 2],
        held: 0,
        diff: None,
        turn: Complex32::new(0.0, 0.0),
        size: 0.0,
        weight: 0.0,
        weight2: 0.0,
    };

    /// No sideband at all (the channel avoids no tone, or a hum was
    /// taken out): no history.
    pub fn lose(&mut self) {
        *self = Self::NEW;
    }

    /// Tone `k`'s sideband was not taken out of this block (it did not
    /// stand out of the noise): the chain of consecutive blocks a turn
    /// needs starts again, the turns gathered so far stay.
    pub fn skip(&mut self, k: usize) {
        if usize::from(self.tone) == k {
            (self.held, self.diff) = (0, None);
        } else {
            self.lose();
        }
    }

    /// This block's sideband `p` at tone `k`, λ = `forget`: the bound on
    /// |δ| (bins, ≤ ½) the history now gives.
    pub fn update(&mut self, k: usize, p: Complex32, forget: f32) -> f32 {
        let k = k.min(usize::from(NONE) - 1) as u8;
        if k != self.tone {
            *self = Self { tone: k, ..Self::NEW };
        }
        let e = (self.held == 2).then(|| p - self.last[1]);
        if let (Some(e), Some(before)) = (e, self.diff) {
            self.turn = self.turn * forget + e * before.conj();
            self.size = self.size * forget + fmath::hypot(e.re, e.im) * fmath::hypot(before.re, before.im);
            self.weight = self.weight * forget + 1.0;
            self.weight2 = self.weight2 * forget * forget + 1.0;
        }
        self.diff = e;
        self.last = [p, self.last[0]];
        self.held = (self.held + 1).min(2);
        self.delta()
    }

    /// The bound on |δ|, bins: the mean turn's angle over 2π plus three
    /// standard errors, ½ at most (and without enough history).
    pub fn delta(&self) -> f32 {
        const HALF: f32 = 0.5;
        // The effective count of products, halved: neighbours share a
        // difference.
        let count = if self.weight2 > 0.0 {
            self.weight * self.weight / self.weight2
        } else {
            0.0
        };
        let agree = if self.size > 0.0 {
            fmath::hypot(self.turn.re, self.turn.im) / self.size
        } else {
            0.0
        };
        if !(count >= MIN_BLOCKS && agree > 0.0) {
            return HALF;
        }
        let angle = libm::atan2f(self.turn.im, self.turn.re).abs();
        // Circular standard deviation √(−2 ln R) of the products' angles.
        let spread = fmath::sqrt(fmath::max(-2.0 * libm::logf(fmath::min(agree, 1.0)), 0.0));
        let error = 3.0 * spread / fmath::sqrt(0.5 * count);
        let bound = (angle + error) / core::f32::consts::TAU + 0.005;
        if bound.is_nan() {
            HALF
        } else {
            fmath::min(bound, HALF)
        }
    }
}
