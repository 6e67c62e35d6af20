//! Synchronous I/Q demodulation of paired (voltage, current) ADC samples.
//!
//! For sample pair n of a block, `[vₙ, iₙ]`, with the reference phase
//! θₙ = n·ftw (from the excitation's tuning word, 0 at the start of every
//! block), four i64 sums are accumulated:
//!
//! ```text
//! V = Σ vₙ·e^(−jθₙ) = Σ vₙ cos θₙ − j Σ vₙ sin θₙ     (Q15 · ADC counts)
//! I = Σ iₙ·e^(−jθₙ)
//! ```
//!
//! The reference cos θₙ, sin θₙ (Q15, from
//! [`DEMOD_REF`]) is laid out once per frequency
//! in the [`Demodulator`] itself (`N` words, 4·N bytes), so the inner loop is
//! two loads and four 16×16→64 multiply-accumulates per pair (`SMLALxy` on
//! Cortex-M4).
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
//! # What the tone does not explain
//! Alongside, each channel's sum Σx and sum of squares Σx² are kept
//! ([`Moments`]), so that the energy left after removing the block's mean
//! and the fitted tone is known:
//!
//! ```text
//! E_res = Σx² − (Σx)²/N − 2|X|²/(N·32767²),   r = √(E_res/N)   (counts rms)
//! ```
//!
//! With a clean excitation r is the ADC noise (≈ 0.8 counts on the
//! reference front end). Mains hum, a step or a glitch within the block
//! raise it, and they also leak into the tone's bin: over a block shorter
//! than a hum period, hum is mostly a ramp, and a ramp's leakage into the
//! bin of k whole periods is √12/(πk) ≈ 1.1/k times its own rms. So r bounds
//! the error a disturbance can have caused, and a channel can refuse the
//! block ([`Phasors::residual_rms`]).
//!
//! Overflow: each product is below 2¹⁵·2¹⁵ = 2³⁰, so the i64 sums cannot
//! overflow for any block that fits in memory (N < 2³³).

use crate::tables::{DEMOD_REF, REF_BITS};
use crate::Complex32;
use num_complex::Complex;

/// Demodulator configuration: the reference for blocks of `N` sample pairs.
///
/// Word n holds round(32767·cos θₙ) in bits 0..16 and round(32767·sin θₙ)
/// in bits 16..32.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Demodulator<const N: usize> {
    reference: [u32; N],
}

/// Demodulator state: the position in the block and the running sums.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DemodState {
    /// Pairs of the current block summed so far.
    n: usize,
    /// Σv·cos, Σv·sin, Σi·cos, Σi·sin (Q15 · ADC counts).
    sums: [i64; 4],
    /// Σv, Σv², Σi, Σi² (counts, counts²).
    moments: [i64; 4],
}

/// Each channel's sum and sum of squares over a block, for the energy the
/// tone does not explain (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Moments {
    /// Σv, counts.
    pub v_sum: i64,
    /// Σv², counts².
    pub v_sq: i64,
    /// Σi, counts.
    pub i_sum: i64,
    /// Σi², counts².
    pub i_sq: i64,
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
    /// Sums and sums of squares of both channels.
    pub moments: Moments,
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
        let g = if inverting {
            -r_feedback_ohm
        } else {
            r_feedback_ohm
        };
        Self {
            gain: Complex32::new(g, 0.0),
        }
    }
}

impl<const N: usize> Demodulator<N> {
    /// Demodulator for blocks of `N` pairs at an oscillator's frequency.
    pub fn new(osc: &crate::Oscillator) -> Self {
        Self::from_ftw(osc.ftw())
    }

    /// Demodulator for the tuning word `ftw`, computable at compile time:
    /// `static D: Demodulator<1024> = Demodulator::from_ftw(FTW);` puts the
    /// reference in flash instead of RAM.
    pub const fn from_ftw(ftw: u32) -> Self {
        const SHIFT: u32 = 32 - REF_BITS;
        let mut reference = [0u32; N];
        let mut phase = 0u32;
        let mut n = 0;
        while n < N {
            reference[n] = DEMOD_REF[(phase >> SHIFT) as usize];
            phase = phase.wrapping_add(ftw);
            n += 1;
        }
        Self { reference }
    }

    /// The reference words, one per pair of a block (see the type's docs).
    pub fn reference(&self) -> &[u32; N] {
        &self.reference
    }

    /// Accumulate a chunk of `[voltage, current]` sample pairs. Chunks of one
    /// block may arrive in any sizes (DMA halves, say); pairs beyond the
    /// block's `N` are not used. Returns the number of pairs consumed.
    #[inline]
    pub fn update(&self, state: &mut DemodState, pairs: &[[i16; 2]]) -> usize {
        let reference = self.reference.get(state.n..).unwrap_or(&[]);
        let used = pairs.len().min(reference.len());
        state.sums = accumulate(state.sums, &pairs[..used], &reference[..used]);
        state.moments = moments(state.moments, &pairs[..used]);
        state.n += used;
        used
    }

    /// End the block: return its phasors and reset the state.
    pub fn finish(&self, state: &mut DemodState) -> Phasors {
        let [vc, vs, ic, is] = state.sums;
        let [v_sum, v_sq, i_sum, i_sq] = state.moments;
        let p = Phasors {
            v: Complex::new(vc, -vs),
            i: Complex::new(ic, -is),
            n: state.n as u32,
            moments: Moments {
                v_sum,
                v_sq,
                i_sum,
                i_sq,
            },
        };
        *state = DemodState::default();
        p
    }

    /// Demodulate one whole block at once.
    pub fn block(&self, pairs: &[[i16; 2]; N]) -> Phasors {
        Phasors {
            n: N as u32,
            ..self.finish(&mut DemodState {
                n: N,
                sums: accumulate([0; 4], pairs, &self.reference),
                moments: moments([0; 4], pairs),
            })
        }
    }
}

/// The inner loop: per pair, four 16×16 → 64-bit multiply-accumulates.
///
/// Done as two passes over the chunk, one per channel, so that each pass
/// keeps its two 64-bit sums, its pointers and the loaded words in registers
/// (a single pass needs 13 registers where a Cortex-M4 has 12 free). On Arm
/// cores with the DSP extension the passes are [`arm`] inline assembly (two
/// pairs per turn, one `SMLALxy` per product); elsewhere [`portable`]. Both
/// compute the same exact integer sums (no product or sum can overflow), so
/// results are bit-identical; the QEMU benchmark checks that on the target.
fn accumulate(sums: [i64; 4], pairs: &[[i16; 2]], reference: &[u32]) -> [i64; 4] {
    #[cfg(arm_dsp)]
    return arm::accumulate(sums, pairs, reference);
    #[cfg(not(arm_dsp))]
    return portable(sums, pairs, reference);
}

/// Σv, Σv², Σi, Σi² over a chunk, added to `m`. Each square is below 2³⁰,
/// so the i64 sums cannot overflow (N < 2³³). The plain sums run in i32
/// over runs of 2¹⁵ pairs (|Σ| ≤ 2³⁰), and each square is a widening
/// multiply-accumulate (one `SMLAL` on a Cortex-M4).
fn moments(m: [i64; 4], pairs: &[[i16; 2]]) -> [i64; 4] {
    let [mut v1, mut v2, mut i1, mut i2] = m;
    for run in pairs.chunks(1 << 15) {
        let (mut vs, mut is) = (0i32, 0i32);
        for &[v, i] in run {
            let (v, i) = (v as i32, i as i32);
            vs += v;
            is += i;
            v2 += v as i64 * v as i64;
            i2 += i as i64 * i as i64;
        }
        v1 += vs as i64;
        i1 += is as i64;
    }
    [v1, v2, i1, i2]
}

/// Reference implementation of the inner loop (all targets).
pub fn portable(sums: [i64; 4], pairs: &[[i16; 2]], reference: &[u32]) -> [i64; 4] {
    let [mut vc, mut vs, mut ic, mut is] = sums;
    for (&[v, i], &r) in pairs.iter().zip(reference) {
        let (c, s) = (r as i16 as i64, (r as i32 >> 16) as i64);
        vc += v as i64 * c;
        vs += v as i64 * s;
        ic += i as i64 * c;
        is += i as i64 * s;
    }
    [vc, vs, ic, is]
}

/// Cortex-M4 (DSP extension) inner loop in inline assembly.
#[cfg(arm_dsp)]
#[allow(unsafe_code)]
pub mod arm {
    macro_rules! pass {
        ($name:ident, $mc:literal, $ms:literal) => {
            /// One channel over an even, non-empty number of pairs.
            #[inline(always)]
            fn $name(c: i64, s: i64, pairs: &[[i16; 2]], reference: &[u32]) -> (i64, i64) {
                debug_assert!(pairs.len() == reference.len() && pairs.len() % 2 == 0 && !pairs.is_empty());
                let (mut cl, mut ch, mut sl, mut sh) = (c as u32, (c >> 32) as u32, s as u32, (s >> 32) as u32);
                let mut p = pairs.as_ptr();
                let mut q = reference.as_ptr();
                // SAFETY: `p` and `q` walk `pairs` and `reference`, which hold
                // the same, even, non-zero number of 4-byte elements; the loop
                // reads exactly that many of each and stops when `p` reaches
                // the end. Only registers and the two slices are touched.
                unsafe {
                    let end = p.add(pairs.len());
                    core::arch::asm!(
                        "2:",
                        "ldr {w0}, [{p}], #4",
                        "ldr {r0}, [{q}], #4",
                        "ldr {w1}, [{p}], #4",
                        "ldr {r1}, [{q}], #4",
                        concat!($mc, " {cl}, {ch}, {w0}, {r0}"),
                        concat!($ms, " {sl}, {sh}, {w0}, {r0}"),
                        concat!($mc, " {cl}, {ch}, {w1}, {r1}"),
                        concat!($ms, " {sl}, {sh}, {w1}, {r1}"),
                        "cmp {p}, {end}",
                        "bne 2b",
                        p = inout(reg) p,
                        q = inout(reg) q,
                        end = in(reg) end,
                        cl = inout(reg) cl,
                        ch = inout(reg) ch,
                        sl = inout(reg) sl,
                        sh = inout(reg) sh,
                        w0 = out(reg) _,
                        r0 = out(reg) _,
                        w1 = out(reg) _,
                        r1 = out(reg) _,
                        options(nostack, readonly),
                    );
                }
                let _ = (p, q);
                (((ch as u64) << 32 | cl as u64) as i64, ((sh as u64) << 32 | sl as u64) as i64)
            }
        };
    }
    pass!(voltage, "smlalbb", "smlalbt");
    pass!(current, "smlaltb", "smlaltt");

    /// Same result as [`portable`](super::portable), bit for bit.
    #[inline(never)]
    pub fn accumulate(sums: [i64; 4], pairs: &[[i16; 2]], reference: &[u32]) -> [i64; 4] {
        let n = pairs.len().min(reference.len());
        let even = n & !1;
        let [mut vc, mut vs, mut ic, mut is] = sums;
        if even > 0 {
            (vc, vs) = voltage(vc, vs, &pairs[..even], &reference[..even]);
            (ic, is) = current(ic, is, &pairs[..even], &reference[..even]);
        }
        super::portable([vc, vs, ic, is], &pairs[even..n], &reference[even..n])
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

    /// What the tone does not explain, per channel: the rms of the block
    /// after removing its mean and the fitted tone, `[voltage, current]`,
    /// counts (see the module docs). 0 for an empty block.
    pub fn residual_rms(&self) -> [f32; 2] {
        let m = &self.moments;
        [
            residual(m.v_sum, m.v_sq, self.v, self.n),
            residual(m.i_sum, m.i_sq, self.i, self.n),
        ]
    }

    /// V/I as a complex ratio, or `None` if the current phasor is zero.
    pub fn ratio(&self) -> Option<Complex32> {
        ratio_of(self.v, self.i)
    }

    /// Impedance Z = k·V/I through `front_end` (Ω), or `None` if no current
    /// was measured (open sensor).
    pub fn impedance(&self, front_end: &FrontEnd) -> Option<Complex32> {
        self.ratio().map(|r| r * front_end.gain)
    }
}

/// V/I of two i64 phasors as a complex `f32`, or `None` if I is zero.
/// Each sum converted to f32 ([`crate::fmath::i64_to_f32`], 1.5 ulp) and
/// all four scaled by one power of two, exactly, so that the largest is
/// below 2⁴⁰ (V/I is unchanged by a common factor; |I|² cannot
/// overflow). [`Phasors::ratio`] and [`crate::comb::Tones::ratio`] both
/// use it.
pub(crate) fn ratio_of(v: Complex<i64>, i: Complex<i64>) -> Option<Complex32> {
    let m = v.re.unsigned_abs() | v.im.unsigned_abs() | i.re.unsigned_abs() | i.im.unsigned_abs();
    let bits = 64 - m.leading_zeros() as i32;
    let scale = crate::fmath::pow2(if bits > 40 { 40 - bits } else { 0 });
    let f = |x: i64| crate::fmath::i64_to_f32(x) * scale;
    let (v, i) = (Complex32::new(f(v.re), f(v.im)), Complex32::new(f(i.re), f(i.im)));
    let d = i.norm_sqr();
    if d > 0.0 && d.is_finite() {
        Some(v * i.conj() / d)
    } else {
        None
    }
}

fn amplitude(x: Complex<i64>, n: u32) -> f32 {
    if n == 0 {
        return 0.0;
    }
    let (re, im) = (x.re as f64, x.im as f64);
    // |X|² in f64 (exact to 2⁻⁵³), its root in f32 (correctly rounded on
    // every target, [`crate::fmath::sqrt`]).
    crate::fmath::sqrt((re * re + im * im) as f32) * (2.0 / (32767.0 * n as f32))
}

/// What none of several tones explains: the rms of one block after
/// removing its mean and every tone in `tones`, `[voltage, current]`,
/// counts; each tone demodulated from the same block (the same sums and
/// squares, the same N) and a whole number of periods in it, so that the
/// tones are orthogonal and their energies add:
///
/// ```text
/// E_res = Σx² − (Σx)²/N − Σ_k 2|X_k|²/(N·32767²)
/// ```
///
/// 0 for no tone or an empty block. With one tone, [`Phasors::residual_rms`].
pub fn residual_rms_tones(tones: &[Phasors]) -> [f32; 2] {
    let Some(first) = tones.first() else {
        return [0.0; 2];
    };
    let m = &first.moments;
    [
        residual_of(m.v_sum, m.v_sq, tones.iter().map(|t| t.v), first.n),
        residual_of(m.i_sum, m.i_sq, tones.iter().map(|t| t.i), first.n),
    ]
}

/// √(E_res/N) of one channel (f64: exact for the sums' sizes, and IEEE
/// basic operations only, so the same bits on every target).
fn residual(sum: i64, sq: i64, x: Complex<i64>, n: u32) -> f32 {
    residual_of(sum, sq, core::iter::once(x), n)
}

/// √(E_res/N) of one channel after every tone of `xs`.
fn residual_of(sum: i64, sq: i64, xs: impl Iterator<Item = Complex<i64>>, n: u32) -> f32 {
    if n == 0 {
        return 0.0;
    }
    let n = n as f64;
    let s = sum as f64;
    const REF: f64 = 32767.0;
    let mut e = sq as f64 - s * s / n;
    for x in xs {
        let (re, im) = (x.re as f64, x.im as f64);
        e -= 2.0 * (re * re + im * im) / (n * REF * REF);
    }
    crate::fmath::sqrt((e.max(0.0) / n) as f32)
}
