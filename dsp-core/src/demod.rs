//! Synchronous I/Q demodulation of paired (voltage, current) ADC samples.
//!
//! For each sample pair `[v, i]` the reference phase θₙ (from the same
//! tuning word as the excitation, starting at 0 at the start of the block)
//! selects cos θₙ and sin θₙ (Q15, [`DEMOD_REF`](crate::tables::DEMOD_REF))
//! and four i64 sums are accumulated:
//!
//! ```text
//! V = Σ vₙ·e^(−jθₙ) = Σ vₙ cos θₙ − j Σ vₙ sin θₙ     (Q15 · ADC counts)
//! I = Σ iₙ·e^(−jθₙ)
//! ```
//!
//! Over whole periods (see [`Oscillator::coherent`](crate::Oscillator::coherent))
//! this is the least-squares fit of a sinusoid at the known frequency, which
//! is also the maximum-likelihood estimate in white Gaussian noise: its
//! amplitude and phase variances meet the Cramér–Rao bound, and DC and every
//! harmonic of the excitation sum to exactly zero. The amplitude of the
//! voltage is A_v = 2|V|/(32767·N) ADC counts and its phase is arg V.
//!
//! The impedance is Z = k·V/I, where k is the front end's complex
//! transimpedance ([`FrontEnd`]).
//!
//! Overflow: each product is at most 2¹⁵·2¹⁵ = 2³⁰, so the i64 sums cannot
//! overflow for blocks shorter than 2³³ samples; blocks are limited to
//! 2³² − 1 pairs by the `u32` counter.

use crate::tables::{DEMOD_REF, REF_BITS};
use crate::Complex32;
use num_complex::Complex;

/// Demodulator configuration: the reference tuning word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Demodulator {
    ftw: u32,
}

/// Demodulator state: the reference phase and the running sums.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DemodState {
    phase: u32,
    /// Σv·cos, Σv·sin, Σi·cos, Σi·sin (Q15 · ADC counts).
    sums: [i64; 4],
    n: u32,
}

/// The demodulated phasors of one block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Phasors {
    /// Voltage phasor V = Σ v·e^(−jθ), Q15 · ADC counts.
    pub v: Complex<i64>,
    /// Current phasor I = Σ i·e^(−jθ), Q15 · ADC counts.
    pub i: Complex<i64>,
    /// Number of sample pairs summed.
    pub n: u32,
}

/// The analog front end between the sensor and the two ADC channels.
///
/// `gain` is the complex factor k (Ω) in Z = k·V/I: the transimpedance of
/// the current amplifier times the ratio of the ADC channel gains, with the
/// sign of an inverting stage and any phase error of the front end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontEnd {
    /// Complex transimpedance k, Ω.
    pub gain: Complex32,
}

impl FrontEnd {
    /// A transimpedance stage of `r_feedback_ohm` with equal ADC channel
    /// gains; `inverting` for the usual inverting op-amp stage.
    pub fn transimpedance(r_feedback_ohm: f32, inverting: bool) -> Self {
        let g = if inverting { -r_feedback_ohm } else { r_feedback_ohm };
        Self {
            gain: Complex32::new(g, 0.0),
        }
    }
}

impl Demodulator {
    /// Demodulator locked to an oscillator's tuning word.
    pub const fn new(osc: &crate::Oscillator) -> Self {
        Self { ftw: osc.ftw() }
    }

    /// Accumulate a chunk of `[voltage, current]` sample pairs. Chunks of one
    /// block may arrive in any sizes (DMA halves, say); the reference phase
    /// continues across them.
    #[inline]
    pub fn update(&self, state: &mut DemodState, pairs: &[[i16; 2]]) {
        const SHIFT: u32 = 32 - REF_BITS;
        let mut phase = state.phase;
        let [mut vc, mut vs, mut ic, mut is] = state.sums;
        for &[v, i] in pairs {
            let r = DEMOD_REF[(phase >> SHIFT) as usize];
            phase = phase.wrapping_add(self.ftw);
            let (c, s) = (r as i16 as i32, (r >> 16) as i16 as i32);
            let (v, i) = (v as i32, i as i32);
            vc += (v * c) as i64;
            vs += (v * s) as i64;
            ic += (i * c) as i64;
            is += (i * s) as i64;
        }
        state.phase = phase;
        state.sums = [vc, vs, ic, is];
        state.n = state.n.wrapping_add(pairs.len() as u32);
    }

    /// End the block: return its phasors and reset the state (phase to 0).
    pub fn finish(&self, state: &mut DemodState) -> Phasors {
        let [vc, vs, ic, is] = state.sums;
        let p = Phasors {
            v: Complex::new(vc, -vs),
            i: Complex::new(ic, -is),
            n: state.n,
        };
        *state = DemodState::default();
        p
    }

    /// Demodulate one whole block at once.
    pub fn block(&self, pairs: &[[i16; 2]]) -> Phasors {
        let mut st = DemodState::default();
        self.update(&mut st, pairs);
        self.finish(&mut st)
    }
}

impl Phasors {
    /// Amplitude of the voltage channel, ADC counts (peak).
    pub fn v_amplitude(&self) -> f32 {
        amplitude(self.v, self.n)
    }

    /// Amplitude of the current channel, ADC counts (peak).
    pub fn i_amplitude(&self) -> f32 {
        amplitude(self.i, self.n)
    }

    /// V/I as a complex ratio, or `None` if the current phasor is zero.
    pub fn ratio(&self) -> Option<Complex32> {
        // Scale both to f32 by the same power of two so that f32 keeps the
        // top bits of the larger sum; V/I is unchanged by a common factor.
        let m = [self.v.re, self.v.im, self.i.re, self.i.im]
            .iter()
            .fold(0u64, |a, x| a | x.unsigned_abs());
        let sh = (64 - m.leading_zeros()).saturating_sub(40);
        let f = |x: i64| (x >> sh) as f32;
        let (v, i) = (
            Complex32::new(f(self.v.re), f(self.v.im)),
            Complex32::new(f(self.i.re), f(self.i.im)),
        );
        let d = i.norm_sqr();
        if d > 0.0 && d.is_finite() {
            Some(v * i.conj() / d)
        } else {
            None
        }
    }

    /// Impedance Z = k·V/I through `front_end` (Ω), or `None` if no current
    /// was measured (open sensor).
    pub fn impedance(&self, front_end: &FrontEnd) -> Option<Complex32> {
        self.ratio().map(|r| r * front_end.gain)
    }
}

fn amplitude(x: Complex<i64>, n: u32) -> f32 {
    if n == 0 {
        return 0.0;
    }
    let (re, im) = (x.re as f64, x.im as f64);
    (libm::sqrt(re * re + im * im) * 2.0 / (32767.0 * n as f64)) as f32
}
