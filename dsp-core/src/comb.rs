//! Synchronous demodulation of a comb of tones from one input of a
//! scanned block.
//!
//! A front end that excites every sensor with the same sum of K tones and
//! samples many inputs in turn leaves, per block, rows of `S` samples (one
//! per input of an ADC's scan) at `N` instants. Tone k makes `periods[k]`
//! whole periods in the block, so with θₖ,ₙ = 2π·pₖ·n/N the sums
//!
//! ```text
//! Xₖ = Σₙ xₙ·e^(−jθₖ,ₙ) = Σ xₙ cos θₖ,ₙ − j Σ xₙ sin θₖ,ₙ      (Q31 · ADC counts)
//! ```
//!
//! are each tone's least-squares phasor, and the tones are exactly
//! orthogonal over the block: tone q adds nothing to Xₖ (q ≠ k), nor does
//! DC. The amplitude of tone k is 2|Xₖ|/(2³¹·N) counts, and the ratio of
//! a voltage input's phasor to a current input's ([`Tones::ratio`]) gives
//! the impedance as in [`crate::demod`].
//!
//! The reference is cos θ, sin θ in Q31 from [`crate::cossin`] at the
//! exact phase (pₖ·n mod N)/N of a turn (error below 10⁻⁸): 8·N·K bytes,
//! laid out once. Q31, not the Q15 of [`crate::demod`], because the comb's
//! residual subtracts the energies of K tones that can be 10⁷ times the
//! noise's: a Q15 reference's rounding (10⁻⁵ of each tone's energy) would
//! bury the noise, a Q31 one's (10⁻⁹) does not.
//!
//! What no tone explains (hum, a step, noise), counts rms, with the mean
//! and every tone of the comb removed:
//!
//! ```text
//! E_res = Σx² − (Σx)²/N − Σₖ 2|Xₖ|²/(N·2⁶²),   r = √(E_res/N)
//! ```
//!
//! Overflow: each product is at most 2¹⁵·2³¹ = 2⁴⁶ and a sum holds N of
//! them, so the i64 sums cannot overflow for N < 2¹⁷ ([`Comb::new`]
//! refuses larger blocks).

use crate::cossin::cossin;
use crate::Complex32;
use num_complex::Complex;

/// Why a comb cannot be laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CombError {
    /// A tone has 0 periods, or N/2 or more (at or above Nyquist).
    Periods(u32),
    /// Two tones have the same number of periods.
    Repeated(u32),
    /// The block is longer than 2¹⁷ instants (the sums could overflow).
    TooLong,
}

impl core::fmt::Display for CombError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CombError::Periods(p) => write!(f, "{p} periods per block is not between 1 and N/2 − 1"),
            CombError::Repeated(p) => write!(f, "two tones of {p} periods per block"),
            CombError::TooLong => write!(f, "a block of more than 2^17 instants"),
        }
    }
}

impl core::error::Error for CombError {}

/// The demodulator of a comb of `K` tones over blocks of `N` instants.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Comb<const N: usize, const K: usize> {
    periods: [u32; K],
    /// Instant n of tone k: [cos θₖ,ₙ, sin θₖ,ₙ], Q31 (saturated: +1 is
    /// i32::MAX).
    reference: [[[i32; 2]; N]; K],
}

/// The comb's sums for one input over one block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tones<const K: usize> {
    /// Phasor of each tone, Xₖ = Σ x·e^(−jθₖ), Q31 · ADC counts.
    pub x: [Complex<i64>; K],
    /// Instants summed.
    pub n: u32,
    /// Σx, counts.
    pub sum: i64,
    /// Σx², counts².
    pub sq: i64,
}

impl<const N: usize, const K: usize> Comb<N, K> {
    /// The comb whose tone k makes `periods[k]` whole periods per block;
    /// an error unless every count is in 1..N/2 and none repeats.
    pub fn new(periods: [u32; K]) -> Result<Self, CombError> {
        if N > 1 << 17 {
            return Err(CombError::TooLong);
        }
        for (k, &p) in periods.iter().enumerate() {
            if p == 0 || 2 * p as u64 >= N as u64 {
                return Err(CombError::Periods(p));
            }
            if periods[..k].contains(&p) {
                return Err(CombError::Repeated(p));
            }
        }
        let mut reference = [[[0i32; 2]; N]; K];
        for (row, &p) in reference.iter_mut().zip(&periods) {
            for (n, w) in row.iter_mut().enumerate() {
                // The exact phase as a fraction of a turn, 2³² per turn.
                let m = (p as u64 * n as u64) % N as u64;
                let phase = (((m << 32) + N as u64 / 2) / N as u64) as u32 as i32;
                let (c, s) = cossin(phase);
                *w = [c, s];
            }
        }
        Ok(Self { periods, reference })
    }

    /// Periods per block of each tone.
    pub fn periods(&self) -> &[u32; K] {
        &self.periods
    }

    /// Tone k's reference words (see the type).
    pub fn reference(&self, k: usize) -> Option<&[[i32; 2]; N]> {
        self.reference.get(k)
    }

    /// Demodulate input `col` of a block of rows of `S` inputs (as a
    /// scanning ADC's DMA leaves them): every tone, Σx and Σx². An input
    /// beyond the row gives an empty result (`n` = 0).
    pub fn column<const S: usize>(&self, rows: &[[i16; S]; N], col: usize) -> Tones<K> {
        let mut t = Tones::EMPTY;
        self.column_into(rows, col, &mut t);
        t
    }

    /// [`Comb::column`] into `out` (a block's many results written in
    /// place, not copied on their way).
    pub fn column_into<const S: usize>(&self, rows: &[[i16; S]; N], col: usize, out: &mut Tones<K>) {
        if col >= S {
            *out = Tones::EMPTY;
            return;
        }
        for (x, reference) in out.x.iter_mut().zip(&self.reference) {
            let [c, s] = tone_sums(rows, col, reference);
            *x = Complex::new(c, -s);
        }
        let [sum, sq] = column_moments(rows, col);
        out.n = N as u32;
        out.sum = sum;
        out.sq = sq;
    }
}

/// Σₙ xₙ·cos θₙ and Σₙ xₙ·sin θₙ of input `col` (< S) against one
/// tone's reference: on Arm cores with the DSP extension [`arm`] inline
/// assembly (per instant a post-indexed `LDRSH` of the sample, `LDRD` of
/// the reference and two `SMLAL`, five instants a turn where five divide
/// the block: 4.4 instructions an instant, where the compiler's unrolled
/// loop spilled to 8; inlined, so a column's five tones cost no calls),
/// elsewhere [`portable`]; the same exact integer sums (no product or
/// sum can overflow), bit-identical (the QEMU benchmark checks it on the
/// target).
#[inline]
fn tone_sums<const N: usize, const S: usize>(
    rows: &[[i16; S]; N],
    col: usize,
    reference: &[[i32; 2]; N],
) -> [i64; 2] {
    #[cfg(arm_dsp)]
    return arm::tone_sums(rows, col, reference);
    #[cfg(not(arm_dsp))]
    return portable(rows, col, reference);
}

/// Σx and Σx² of input `col` (< S): [`arm`] assembly where there is
/// the DSP extension, else [`portable_moments`]; bit-identical.
#[inline]
fn column_moments<const N: usize, const S: usize>(rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
    #[cfg(arm_dsp)]
    return arm::moments(rows, col);
    #[cfg(not(arm_dsp))]
    return portable_moments(rows, col);
}

/// Reference implementation of the moments (all targets): each square
/// below 2³⁰, so the i64 sums cannot overflow.
pub fn portable_moments<const N: usize, const S: usize>(rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
    let (mut sum, mut sq) = (0i64, 0i64);
    for row in rows {
        let v = row[col] as i32;
        sum += v as i64;
        sq += (v * v) as i64;
    }
    [sum, sq]
}

/// Σₙ xₙ·cos θₙ and Σₙ xₙ·sin θₙ of input `col` against one tone's
/// reference: the reference implementation of the comb's inner loop (all
/// targets; the Cortex-M4 runs `arm::tone_sums` where it has the DSP
/// extension).
pub fn portable<const N: usize, const S: usize>(
    rows: &[[i16; S]; N],
    col: usize,
    reference: &[[i32; 2]; N],
) -> [i64; 2] {
    let (mut c, mut s) = (0i64, 0i64);
    for (row, &[rc, rs]) in rows.iter().zip(reference.iter()) {
        let v = row[col] as i64;
        c += v * rc as i64;
        s += v * rs as i64;
    }
    [c, s]
}

/// Cortex-M4 (DSP extension) inner loop of the comb in inline assembly.
#[cfg(arm_dsp)]
#[allow(unsafe_code)]
pub mod arm {
    /// Instants a loop turn takes: five where they divide the block (the
    /// array's 25 and 100: 4.4 instructions an instant, where two a
    /// turn take 5 and leave 25's last instant to Rust), else two.
    const fn unroll(n: usize) -> usize {
        if n % 5 == 0 {
            5
        } else {
            2
        }
    }

    /// One instant of [`tone_sums`]: the sample, its reference pair, two
    /// products.
    macro_rules! tone_step {
        () => {
            "ldrsh {x}, [{p}], {stride}\n\
             ldrd {a}, {b}, [{q}], #8\n\
             smlal {cl}, {ch}, {x}, {a}\n\
             smlal {sl}, {sh}, {x}, {b}"
        };
    }

    /// One instant of [`moments`]: the sample, its sum and square.
    macro_rules! moment_step {
        () => {
            "ldrsh {x}, [{p}], {stride}\n\
             add {sum}, {x}\n\
             smlal {ql}, {qh}, {x}, {x}"
        };
    }

    /// Same result as [`portable`](super::portable), bit for bit.
    #[inline(always)]
    pub fn tone_sums<const N: usize, const S: usize>(
        rows: &[[i16; S]; N],
        col: usize,
        reference: &[[i32; 2]; N],
    ) -> [i64; 2] {
        let whole = N - N % unroll(N);
        if col >= S || whole == 0 || S * 2 > 255 {
            return super::portable(rows, col, reference);
        }
        let (mut cl, mut ch, mut sl, mut sh) = (0u32, 0u32, 0u32, 0u32);
        let mut p = rows.as_ptr().cast::<i16>().wrapping_add(col);
        let mut q = reference.as_ptr();
        // SAFETY: `p` walks input `col` (< S) of the first `whole` rows,
        // S·2 bytes a step (an immediate of at most 255), and `q` the
        // first `whole` reference words, 8 bytes a step; the loop reads
        // exactly that many of each (`unroll(N)` a turn, `whole` a
        // non-zero multiple of it) and stops when `q` reaches `end`.
        // Only registers and the two arrays' memory are touched.
        unsafe {
            let end = q.add(whole);
            macro_rules! tone_loop {
                ($($step:expr),*) => {
                    core::arch::asm!(
                        "2:",
                        $($step,)*
                        "cmp {q}, {end}",
                        "bne 2b",
                        stride = const S * 2,
                        p = inout(reg) p,
                        q = inout(reg) q,
                        end = in(reg) end,
                        cl = inout(reg) cl,
                        ch = inout(reg) ch,
                        sl = inout(reg) sl,
                        sh = inout(reg) sh,
                        x = out(reg) _,
                        a = out(reg) _,
                        b = out(reg) _,
                        options(nostack, readonly),
                    )
                };
            }
            if unroll(N) == 5 {
                tone_loop!(
                    tone_step!(),
                    tone_step!(),
                    tone_step!(),
                    tone_step!(),
                    tone_step!()
                );
            } else {
                tone_loop!(tone_step!(), tone_step!());
            }
        }
        let _ = (p, q);
        let mut c = ((ch as u64) << 32 | cl as u64) as i64;
        let mut s = ((sh as u64) << 32 | sl as u64) as i64;
        // An odd last instant.
        if let (Some(row), Some(&[rc, rs])) = (rows.get(whole), reference.get(whole)) {
            let v = row[col] as i64;
            c += v * rc as i64;
            s += v * rs as i64;
        }
        [c, s]
    }

    /// Same result as [`portable_moments`](super::portable_moments), bit
    /// for bit: Σx in 32 bits (|Σx| ≤ 2³¹ over at most 2¹⁶ instants),
    /// Σx² by `SMLAL` (3 instructions an instant, and the turn's two).
    #[inline(always)]
    pub fn moments<const N: usize, const S: usize>(rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
        let whole = N - N % unroll(N);
        if col >= S || whole == 0 || N > 1 << 16 || S * 2 > 255 {
            return super::portable_moments(rows, col);
        }
        let (mut sum, mut ql, mut qh) = (0i32, 0u32, 0u32);
        let mut p = rows.as_ptr().cast::<i16>().wrapping_add(col);
        // SAFETY: `p` walks input `col` (< S) of the first `whole` rows,
        // S·2 bytes a step (an immediate of at most 255), `unroll(N)` a
        // turn, and stops at `end`, one step past the last of them. Only
        // registers and the rows' memory are touched.
        unsafe {
            let end = p.add(whole * S);
            macro_rules! moment_loop {
                ($($step:expr),*) => {
                    core::arch::asm!(
                        "2:",
                        $($step,)*
                        "cmp {p}, {end}",
                        "bne 2b",
                        stride = const S * 2,
                        p = inout(reg) p,
                        end = in(reg) end,
                        sum = inout(reg) sum,
                        ql = inout(reg) ql,
                        qh = inout(reg) qh,
                        x = out(reg) _,
                        options(nostack, readonly),
                    )
                };
            }
            if unroll(N) == 5 {
                moment_loop!(
                    moment_step!(),
                    moment_step!(),
                    moment_step!(),
                    moment_step!(),
                    moment_step!()
                );
            } else {
                moment_loop!(moment_step!(), moment_step!());
            }
        }
        let _ = p;
        let (mut sum, mut sq) = (sum as i64, ((qh as u64) << 32 | ql as u64) as i64);
        if let Some(row) = rows.get(whole) {
            let v = row[col] as i64;
            sum += v;
            sq += v * v;
        }
        [sum, sq]
    }
}

impl<const K: usize> Tones<K> {
    /// No instants: every sum 0 (`n` = 0).
    pub const EMPTY: Self = Self {
        x: [Complex::new(0, 0); K],
        n: 0,
        sum: 0,
        sq: 0,
    };

    /// Amplitude of tone `k`, counts (peak); 0 for an empty block or a
    /// tone beyond the comb. The sums to f32
    /// ([`crate::fmath::i64_to_f32`], 1.5 ulp) and their magnitude by
    /// [`crate::fmath::hypot`] (relative error below 3·10⁻⁷).
    pub fn amplitude(&self, k: usize) -> f32 {
        match self.x.get(k) {
            Some(&x) if self.n > 0 => amplitude_of(phasor_of(x), self.n),
            _ => 0.0,
        }
    }

    /// What no tone of the comb explains: the block's rms after its mean
    /// and every tone, counts (module docs). 0 for an empty block.
    ///
    /// N·E_res = N·Σx² − (Σx)² − Σₖ 2|Xₖ|²/2⁶² is formed in i128
    /// (|Xₖ|² < 2¹²⁶ for N < 2¹⁷; the tones' term rounded to an integer),
    /// only its square root in f32: the same bits on every target, and no
    /// cancellation however large the tones; r = √(N·E_res)/N.
    pub fn residual_rms(&self) -> f32 {
        if self.n == 0 {
            return 0.0;
        }
        // Squares as u64 × u64 → u128 (four 32-bit products: i128 × i128
        // takes the full 128-bit multiply).
        let square = |v: i64| {
            let a = v.unsigned_abs() as u128;
            a * a
        };
        let n = self.n as i128;
        let mut e = n * self.sq as i128 - square(self.sum) as i128;
        let mut tones = 0u128;
        for x in &self.x {
            tones += square(x.re) + square(x.im);
        }
        let tones = tones as i128;
        // Σ 2|X|²/2⁶², rounded to the nearest.
        e -= (tones + (1 << 60)) >> 61;
        let e = e.max(0);
        // To f32 through a shift (even) that keeps 30 bits (E·N < 2¹²⁶).
        let bits = 128 - e.leading_zeros();
        let sh = (bits.saturating_sub(30) + 1) & !1;
        let scaled = (e >> sh) as i32 as f32;
        // ×2^(sh/2), sh/2 ≤ 63: exact, as ldexpf (a library call).
        crate::fmath::sqrt(scaled) * crate::fmath::pow2((sh / 2) as i32) / self.n as f32
    }

    /// The amplitudes of every tone, the phasors in f32 and the
    /// residual, once (a channel reads them many times, and every
    /// sensor's ratio reads the excitation's phasors).
    pub fn levels(&self) -> Levels<K> {
        let phasor: [Complex32; K] = self.x.map(phasor_of);
        // As [`Tones::amplitude`], from the same conversions.
        let amplitude: [f32; K] = if self.n > 0 {
            phasor.map(|p| amplitude_of(p, self.n))
        } else {
            [0.0; K]
        };
        Levels {
            // (From 0, never NaN: a NaN amplitude is passed over, as by
            // `fmath::max`, whose NaN test of the running value it
            // spares.)
            largest: amplitude.iter().fold(0.0, |m, &a| if a > m { a } else { m }),
            amplitude,
            phasor,
            residual: self.residual_rms(),
        }
    }

    /// V/I of tone `k` of a voltage input `v` and a current input `i`
    /// (multiply by the front end's transimpedance for Z, as
    /// [`crate::demod::Phasors::impedance`]); `None` for a tone beyond the
    /// comb or no current.
    pub fn ratio(v: &Self, i: &Self, k: usize) -> Option<Complex32> {
        crate::demod::ratio_of(*v.x.get(k)?, *i.x.get(k)?)
    }
}

/// An input's levels over one block ([`Tones::levels`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Levels<const K: usize> {
    /// Each tone's amplitude, counts (peak).
    pub amplitude: [f32; K],
    /// What no tone explains, counts rms.
    pub residual: f32,
    /// The largest tone's amplitude, counts (0 without tones).
    pub largest: f32,
    /// Each tone's phasor Xₖ in f32 ([`crate::fmath::i64_to_f32`] of
    /// the sums, Q31 · counts).
    pub phasor: [Complex32; K],
}

impl<const K: usize> Levels<K> {
    /// V/I of tone `k` from the levels of a voltage input `v` and a
    /// current input `i`: the same bits as [`Tones::ratio`] of their
    /// sums (which scales all four conversions by one power of two, an
    /// exact step that leaves V/I's bits as they are: every product
    /// and |I|² stays below 2¹²⁷ without it), without converting the
    /// sums again; `None` for a tone beyond the comb or no current.
    pub fn ratio(v: &Self, i: &Self, k: usize) -> Option<Complex32> {
        let (v, i) = (*v.phasor.get(k)?, *i.phasor.get(k)?);
        let d = i.norm_sqr();
        if d > 0.0 && d.is_finite() {
            Some(v * i.conj() / d)
        } else {
            None
        }
    }
}

/// A sum Xₖ in f32 ([`crate::fmath::i64_to_f32`], 1.5 ulp).
fn phasor_of(x: Complex<i64>) -> Complex32 {
    Complex32::new(crate::fmath::i64_to_f32(x.re), crate::fmath::i64_to_f32(x.im))
}

/// A tone's amplitude, counts (peak), from its sum in f32 over `n` (> 0)
/// instants: |X|·2/(2³¹·n) ([`crate::fmath::hypot`]).
fn amplitude_of(x: Complex32, n: u32) -> f32 {
    crate::fmath::hypot(x.re, x.im) * (2.0 / (Q31 as f32 * n as f32))
}

/// The reference's full scale, 2³¹.
const Q31: f64 = 2_147_483_648.0;
