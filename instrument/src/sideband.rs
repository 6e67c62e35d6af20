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
//!   Its differences two (and three) blocks apart, eᵦ = pᵦ − pᵦ₋₂,
//!   remove what does not turn (a stretching sensor's own tone changing
//!   across the block) and share no noise with the previous one;
//!   Σλᵃ·eᵦ·conj eᵦ₋₁ turns by the mean angle 2π·δ̂. The bound is taken
//!   at δ̂ plus three standard errors of that mean (from the spread of
//!   the products' angles and the window's effective count), the larger
//!   of the two lags' (two blocks apart loses an interferer half a bin
//!   off, three a third off); ½ (the most) until the window holds
//!   [`MIN_BLOCKS`] blocks or where the products do not agree.
//! * **The sideband's size** is taken as the larger of |p| and its
//!   recent peak (a stretching sensor's own tone changing across the
//!   block adds a part that does not turn, and |p| swings between the
//!   two parts' difference and their sum), plus three of its standard
//!   deviations (the block's noise).
//!
//! The 1 ms layout never moves off a tone, and fits no sideband.

use crate::array::{adc_position, input_of, Layout, BLOCK_INSTANTS, SCAN, SENSORS, TONES};
use crate::reader::BlockComb;
use crate::tones::Input;
use dsp_core::fmath;
use dsp_core::sideband::Sideband;
use dsp_core::Complex32;

/// The window's time constant, s: 50 blocks of 4 ms.
pub const TAU_S: f32 = 0.2;

/// The least effective count of products before δ̂ is believed.
pub const MIN_BLOCKS: f32 = 8.0;

/// The least agreement of the products' angles (their mean resultant
/// length) for a mean angle: below it they are noise.
pub const MIN_AGREEMENT: f32 = 0.5;

/// "No tone".
const NONE: u8 = u8::MAX;

/// The sideband the reader fits: one tone's at a time, the tone the
/// channels avoid (an interferer on one tone reaches every sensor's
/// input; where channels avoid different tones, those off it keep the
/// residual's bound). Built when the channels first avoid a tone (a
/// basis and its fit, 1.4 KiB: one, not the five tones'), in 4 ms
/// blocks only.
#[derive(Clone, Debug)]
pub struct Sidebands {
    current: Option<Sideband<BLOCK_INSTANTS, TONES>>,
    /// The tone of `current`.
    tone: u8,
    layout: Layout,
    /// λ a block.
    forget: f32,
}

impl Sidebands {
    /// None built yet, for blocks of `layout`.
    pub fn new(layout: Layout) -> Self {
        Self {
            current: None,
            tone: NONE,
            forget: 1.0 - layout.block_us() as f32 * 1e-6 / TAU_S,
            layout,
        }
    }

    /// The tone whose sideband is fitted, if any.
    pub fn tone(&self) -> Option<usize> {
        self.current.as_ref().map(|_| usize::from(self.tone))
    }

    /// Follow the tones the channels avoid (`avoided`, one per channel):
    /// the sideband in force stays while a channel avoids its tone; else
    /// the first avoided tone's is built from `comb` (4 ms blocks), or
    /// none; every sensor's history (`tracks`) emptied where the
    /// sideband changes. (Out of line, in flash: the reader calls it only
    /// while a sideband is fitted or a channel avoids a tone.)
    #[inline(never)]
    pub fn follow(
        &mut self,
        comb: &BlockComb,
        avoided: impl Iterator<Item = Option<usize>> + Clone,
        tracks: &mut [Track; SENSORS],
    ) {
        let BlockComb::Long(c) = comb else { return };
        let k = self.tone();
        if k.is_some() && avoided.clone().any(|a| a == k) {
            return;
        }
        let next = avoided.flatten().next();
        if next == k {
            return;
        }
        self.current = None;
        self.tone = NONE;
        tracks.iter_mut().for_each(Track::lose);
        if let Some(k) = next {
            self.current = Sideband::new(k, c);
            self.tone = k.min(usize::from(NONE) - 1) as u8;
        }
    }

    /// Input column `col`'s sums against tone `k`'s sideband; None where
    /// it is not the one fitted.
    #[inline(never)]
    pub fn sums(&self, k: usize, rows: &[[i16; SCAN]; BLOCK_INSTANTS], col: usize) -> Option<[i64; 2]> {
        let s = self.current.as_ref().filter(|_| self.tone() == Some(k))?;
        Some(s.sums(rows, col))
    }

    /// Every sensor's sums against tone `k`'s sideband where its channel
    /// avoids `k` (`avoided`, by sensor), else zero, from each ADC's rows
    /// (`rows(adc)`); nothing where `k` is not the one fitted.
    #[inline(never)]
    pub fn sums_into<'a>(
        &self,
        k: usize,
        avoided: impl Fn(usize) -> Option<usize>,
        rows: impl Fn(usize) -> &'a [[i16; SCAN]],
        out: &mut [[i64; 2]; SENSORS],
    ) {
        for (s, slot) in out.iter_mut().enumerate() {
            *slot = [0; 2];
            if avoided(s) != Some(k) {
                continue;
            }
            let (a, j) = adc_position(input_of(s));
            if let Some(sums) = rows(a).first_chunk().and_then(|r| self.sums(k, r, j)) {
                *slot = sums;
            }
        }
    }

    /// Tone `tone`'s sideband (`sums`: None where the sensor's channel
    /// does not avoid it, or a hum was taken out: the two fits are not
    /// one, and a block with both is left to the residual's bound) out
    /// of `into` where it stands out of the block's noise, into `track`
    /// (emptied where there is none); then every tone's leak bound,
    /// counts, into `into.leak` (None where none was taken out: the
    /// residual's bound covers a sideband left in): the interferer's own
    /// sideband is taken as its recent peak plus three of its standard
    /// deviations ([`Track::update`]).
    #[inline(never)]
    pub fn take_out(
        &self,
        sums: Option<[i64; 2]>,
        tone: u8,
        track: &mut Track,
        into: &mut Input<'_>,
        clean: f32,
    ) {
        let k = usize::from(tone);
        let (Some(sideband), Some(sums)) = (self.current.as_ref().filter(|_| self.tone() == Some(k)), sums)
        else {
            track.lose();
            return;
        };
        let Some((p, gains)) = sideband.cancel(sums, into.tones, &mut into.levels, clean) else {
            track.skip(k);
            return;
        };
        for (g, n) in into.gains.iter_mut().zip(gains) {
            *g *= n;
        }
        let (delta, peak) = track.update(k, Complex32::new(p[0], p[1]), self.forget);
        // The block's noise σ from what it leaves: N instants less the
        // mean, two per tone and two for the sideband.
        let n = into.tones.n as f32;
        let dof = fmath::max(n - (2 * TONES + 3) as f32, 1.0);
        let sigma = into.levels.residual * fmath::sqrt(n / dof);
        let size = peak + 3.0 * sigma * sideband.spread();
        into.leak = Some(core::array::from_fn(|j| {
            if j == k {
                0.0
            } else {
                self.layout.sideband_leak(k, j, delta) * size
            }
        }));
    }
}

/// One sensor's sideband from block to block: how it turns (state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// The tone the history is of, or [`NONE`].
    tone: u8,
    /// pᵦ₋₁, pᵦ₋₂ and pᵦ₋₃ of consecutive blocks, and how many are held.
    last: [Complex32; 3],
    held: u8,
    /// The turns seen through differences two and three blocks apart.
    turns: [Turn; 2],
    /// The largest |p| lately, each block's λ times less: where the
    /// sideband turns against a part that does not, |p| swings between
    /// their difference and their sum, and the interferer's is at most
    /// the sum.
    peak: f32,
}

/// The turn of a sideband's differences `lag` blocks apart,
/// eᵦ = pᵦ − pᵦ₋ₗₐ₉: Σλᵃ·eᵦ·conj eᵦ₋₁ and what it would be were they all
/// aligned, Σλᵃ·|eᵦ|·|eᵦ₋₁| (and Σλᵃ, Σλ²ᵃ: the window's effective
/// count). A difference two blocks apart loses an interferer half a bin
/// off (it turns by a whole turn in two blocks), three apart one a third
/// off: each sees what the other cannot.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Turn {
    last: Option<Complex32>,
    sum: Complex32,
    size: f32,
    weight: f32,
    weight2: f32,
}

impl Turn {
    const NEW: Self = Self {
        last: None,
        sum: Complex32::new(0.0, 0.0),
        size: 0.0,
        weight: 0.0,
        weight2: 0.0,
    };

    /// This block's difference `e` (None: the chain is broken).
    fn add(&mut self, e: Option<Complex32>, forget: f32) {
        if let (Some(e), Some(before)) = (e, self.last) {
            self.sum = self.sum * forget + e * before.conj();
            self.size = self.size * forget + fmath::hypot(e.re, e.im) * fmath::hypot(before.re, before.im);
            self.weight = self.weight * forget + 1.0;
            self.weight2 = self.weight2 * forget * forget + 1.0;
        }
        self.last = e;
    }

    /// The bound on |δ| its products give: their mean angle over 2π plus
    /// three standard errors of it; ½ without enough of them or where
    /// they agree too little for a mean angle to mean anything.
    fn delta(&self) -> f32 {
        const HALF: f32 = 0.5;
        // The effective count of products, halved: neighbours share a
        // difference.
        let count = if self.weight2 > 0.0 {
            self.weight * self.weight / self.weight2
        } else {
            0.0
        };
        let agree = if self.size > 0.0 {
            fmath::hypot(self.sum.re, self.sum.im) / self.size
        } else {
            0.0
        };
        if !(count >= MIN_BLOCKS && agree >= MIN_AGREEMENT) {
            return HALF;
        }
        let angle = libm::atan2f(self.sum.im, self.sum.re).abs();
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

impl Default for Track {
    fn default() -> Self {
        Self::NEW
    }
}

impl Track {
    /// No history.
    pub const NEW: Self = Self {
        tone: NONE,
        last: [Complex32::new(0.0, 0.0); 3],
        held: 0,
        turns: [Turn::NEW; 2],
        peak: 0.0,
    };

    /// No sideband at all (the channel avoids no tone, or a hum was
    /// taken out, or the reader changed the sideband it fits): no
    /// history.
    pub fn lose(&mut self) {
        // `follow` empties all sixteen when the sideband changes, most of
        // them empty already: a test, not a 96-byte store (only `update`
        // gives a history a tone).
        if self.tone != NONE {
            *self = Self::NEW;
        }
    }

    /// Tone `k`'s sideband was not taken out of this block (it did not
    /// stand out of the noise): the chain of consecutive blocks a turn
    /// needs starts again, the turns gathered so far stay.
    pub fn skip(&mut self, k: usize) {
        if usize::from(self.tone) == k {
            self.held = 0;
            self.turns.iter_mut().for_each(|t| t.last = None);
        } else {
            self.lose();
        }
    }

    /// This block's sideband `p` at tone `k`, λ = `forget`: the bound on
    /// |δ| (bins, ≤ ½) the history now gives, and the interferer's
    /// sideband at most (counts, before the block's noise: the larger of
    /// |p| and its recent peak).
    pub fn update(&mut self, k: usize, p: Complex32, forget: f32) -> (f32, f32) {
        let k = k.min(usize::from(NONE) - 1) as u8;
        if k != self.tone {
            *self = Self { tone: k, ..Self::NEW };
        }
        for (lag, turn) in (2..).zip(self.turns.iter_mut()) {
            let e = (usize::from(self.held) >= lag).then(|| p - self.last[lag - 1]);
            turn.add(e, forget);
        }
        self.last = [p, self.last[0], self.last[1]];
        self.held = (self.held + 1).min(3);
        self.peak = fmath::max(fmath::hypot(p.re, p.im), self.peak * forget);
        (self.delta(), self.peak)
    }

    /// The bound on |δ|, bins: the larger of the two lags' (each blind
    /// where the other is not), ½ at most.
    pub fn delta(&self) -> f32 {
        fmath::max(self.turns[0].delta(), self.turns[1].delta())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A sideband turning by 2π·δ a block, of size 1 to 100 times its
    /// noise (σ 1 per component), beside a part that does not turn (a
    /// stretching sensor's own tone changing across the block), in half
    /// the cases growing steadily up to 6 times the noise (a sensor at
    /// 20 mm/s: 4 counts): after the window fills, what the bound takes
    /// the interferer to leak, δ·(1 + 2δ)·(peak + 3σ) at the bound's δ
    /// ([`Layout::sideband_leak`]'s shape), covers what it leaks,
    /// |δ|·(1 + 2|δ|) times its own size,
    /// in all but a few blocks in 10⁴ (three standard errors: 1.3 in 10³
    /// one-sided). Without a part that does not turn, the bound on δ is
    /// tight where the sideband stands well out of its noise (within
    /// 0.04 of a bin at 30σ; the most near a third of a bin, where the
    /// three-block lag is blind and bounds by its noise).
    #[test]
    fn the_turn_bounds_how_far_off_the_tone_the_interferer_is() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let forget = 1.0 - 0.004 / TAU_S;
        let (mut blocks, mut missed, mut loose) = (0u32, 0u32, 0u32);
        for case in 0..400 {
            let delta: f32 = rng.gen_range(-0.5..0.5);
            let size = 10f32.powf(rng.gen_range(0.0..2.0));
            let drifts = rng.gen_bool(0.5);
            let drift = if drifts {
                Complex32::new(rng.gen_range(-0.015..0.015), rng.gen_range(-0.015..0.015))
            } else {
                Complex32::new(0.0, 0.0)
            };
            let phase: f32 = rng.gen_range(0.0..core::f32::consts::TAU);
            let mut track = Track::NEW;
            for b in 0..300 {
                let turn = phase + core::f32::consts::TAU * delta * b as f32;
                let noise = Complex32::new(gauss(&mut rng), gauss(&mut rng));
                let p = Complex32::new(size * turn.cos(), size * turn.sin()) + drift * b as f32 + noise;
                let (bound, peak) = track.update(case % TONES, p, forget);
                assert!((0.0..=0.5).contains(&bound), "{bound}");
                if b < 100 {
                    continue;
                }
                blocks += 1;
                let shape = |d: f32| d * (1.0 + 2.0 * d);
                // |p| and three standard deviations (σ 1 a component).
                missed += u32::from(shape(bound) * (peak + 3.0) < shape(delta.abs()) * size);
                loose += u32::from(!drifts && size >= 30.0 && bound > delta.abs() + 0.04);
            }
        }
        assert!(missed * 2000 <= blocks, "{missed} of {blocks}");
        assert_eq!(loose, 0, "of {blocks}");
        // No history: the most.
        assert_eq!(Track::NEW.delta(), 0.5);
    }

    /// A standard normal deviate (Box–Muller).
    fn gauss(rng: &mut ChaCha8Rng) -> f32 {
        let (u, v): (f32, f32) = (rng.gen_range(1e-7..1.0), rng.gen_range(0.0..1.0));
        (-2.0 * u.ln()).sqrt() * (core::f32::consts::TAU * v).cos()
    }
}
