//! Mains hum followed across blocks and taken out of a comb's sums.
//!
//! Over a 4 ms block a 50 Hz hum is a fifth of a turn: a slow arc that
//! neither the block's mean nor its tones fit, so it leaks into the
//! lowest tones (38 % of its amplitude into a tone of one period a
//! block) and fills the residual. Fitted inside the block it cannot be
//! told from those tones: a parabola beside them costs the one-period
//! tone eight times its noise. Across blocks it can: the hum keeps its
//! frequency and phase, so one phasor fitted over the last few tens of
//! milliseconds, each block's own hum sums with its mean and tones taken
//! out, separates it, and each block's sums become those of the block
//! less that hum.
//!
//! In a block of N instants at f_s, with b₀ₙ = cos φₙ, b₁ₙ = sin φₙ,
//! φₙ = 2π·f·n/f_s (the block's own instants), a hum is p·b = p₀·b₀ + p₁·b₁
//! and is T·p in the next block (T the rotation by ψ = 2π·f·N/f_s). With
//! P the projection on the mean and the comb's tones and P⊥ = I − P:
//!
//! ```text
//! uⱼ = ⟨P⊥x, bⱼ⟩ = ⟨x, bⱼ⟩ − Σx·dcⱼ/N − (2/N)·Σₖ Re(Xₖ·conj Lₖⱼ)   (counts·instants)
//! Q  = ⟨P⊥bᵢ, P⊥bⱼ⟩                                                (instants)
//! M ← λ·T·M·Tᵀ + Q,   r ← λ·T·r + u,   p = M⁻¹·r                 (per block and input, λ = 1 − T_block/τ)
//! ```
//!
//! (Lₖⱼ = Σₙ bⱼₙ·e^(−jθₖₙ), dcⱼ = Σₙ bⱼₙ: the basis's own comb sums.) The
//! block's sums are then those of x − p·b, exactly: Xₖ − p·Lₖ, Σx − p·dc,
//! and the residual's energy E − 2·pᵀu + pᵀQp; every later step (the
//! amplitudes, the ratio V/I, the residual checks) reads them unchanged.
//!
//! Only a hum the window vouches for is taken out ([`Fit::cancel`]):
//! the window must be half full (τ·ln 2: a block or two cannot tell the
//! hum from the lowest tones), its energy pᵀr must stand out of the noise the window leaves
//! (χ² of 2 degrees of freedom above [`SIGNIFICANT`]), and what the
//! window leaves must itself be clean (its rms within the caller's
//! bound): a sinusoid of another frequency turns in this frame, is not
//! one phasor, and leaves the window unclean; and taken out of the block
//! it must leave less than the block had (a hum that just stopped does
//! not). p's own noise, σ²·M⁻¹M₂M⁻¹
//! (M₂ the same sum with λ²), moves each tone by p·Lₖ: the tone's noise
//! grows by the factor [`Fit::cancel`] returns with it. Each input keeps
//! its own window, which starts again where it no longer explains what it
//! holds and its block is beyond the clean bound: a hum that starts or
//! grows is followed within half a window.
//!
//! u and the residual's energy are formed in i128 from the comb's exact
//! sums (a strong hum's are small differences of large numbers), the rest
//! in f32, the constants in integers once from the Q31 words the sums
//! use: no f64 on a core without it, and the same bits on every target.

use crate::comb::{largest, root_over, Comb, Levels, Tones};
use crate::cossin::cossin;
use crate::fmath;
use crate::Complex32;

/// A hum's χ² (2 degrees of freedom) over the window's noise above which
/// it is taken out: by chance once in 2.7·10⁵ blocks.
pub const SIGNIFICANT: f32 = 25.0;

/// The window's time constant τ, s: two turns of 50 Hz.
pub const TAU_S: f32 = 0.04;

/// The relative rounding f32 leaves in a sum of a few terms, against
/// their sizes: 2⁻²⁰ (eight ulps).
const ROUNDING: f32 = 1.0 / 1_048_576.0;

/// The reference's full scale, 2³¹.
const Q31: f64 = 2_147_483_648.0;

/// A comb's view of mains hum at one frequency: its reference over a
/// block and how it overlaps the comb's mean and tones (configuration,
/// fixed per layout).
#[derive(Clone, Debug, PartialEq)]
pub struct Mains<const N: usize, const K: usize> {
    /// The basis, Q15 (±32767), laid out for the Cortex-M4's dual
    /// products ([`Words`]): its overlaps are computed from these words
    /// exactly, 3·10⁻⁵ of a sinusoid.
    words: Words<N>,
    /// What every block's fit reads.
    fit: Fit<K>,
}

/// A basis of two sequences (b₀ₙ, b₁ₙ: [cos φₙ, sin φₙ] for a hum),
/// Q15, two instants a pair: entry 2m is [b₀ at 2m, b₀ at 2m + 1] and
/// entry 2m + 1 is [b₁ at 2m, b₁ at 2m + 1], so that one 8-byte load
/// gives the Cortex-M4 both packed halfword pairs of instants 2m and
/// 2m + 1; an odd N's last entry is [b₀, b₁] of its last instant. One
/// copy of the words (4 bytes an instant), aligned for that load.
#[derive(Clone, Debug, PartialEq)]
#[repr(C, align(8))]
pub struct Words<const N: usize>([[i16; 2]; N]);

impl<const N: usize> Words<N> {
    /// Laid out from `basis`, instant by instant ([b₀ₙ, b₁ₙ]).
    fn new(basis: &[[i16; 2]; N]) -> Self {
        let mut words = [[0i16; 2]; N];
        for (m, pair) in words.chunks_exact_mut(2).enumerate() {
            let (a, b) = (basis[2 * m], basis[2 * m + 1]);
            pair[0] = [a[0], b[0]];
            pair[1] = [a[1], b[1]];
        }
        if N % 2 == 1 {
            words[N - 1] = basis[N - 1];
        }
        Self(words)
    }

    /// Instant `n`'s [b₀ₙ, b₁ₙ] ([0, 0] past the block).
    pub fn at(&self, n: usize) -> [i16; 2] {
        let pairs = N / 2 * 2;
        match self.0.get(n) {
            Some(&w) if n >= pairs => w,
            Some(_) => {
                let (m, r) = (n / 2 * 2, n % 2);
                [self.0[m][r], self.0[m + 1][r]]
            }
            None => [0, 0],
        }
    }

    /// Every instant's [b₀ₙ, b₁ₙ], in order.
    pub fn iter(&self) -> impl Iterator<Item = [i16; 2]> + '_ {
        (0..N).map(|n| self.at(n))
    }
}

/// The hum's overlap with a comb of K tones, and how it turns from
/// block to block: all [`Fit::cancel`] needs, whatever the block's
/// length (one copy of the code for every layout).
#[derive(Clone, Debug, PartialEq)]
pub struct Fit<const K: usize> {
    /// Instants in a block.
    n: u32,
    /// Lₖⱼ: the comb's sum of basis j at tone k, instants.
    leak: [[Complex32; 2]; K],
    /// 2·Lₖⱼ/N, Q32: [re, im] (u's tone terms in exact integers).
    leak_q32: [[[i64; 2]; 2]; K],
    /// dcⱼ/N, Q32.
    dc_q32: [i64; 2],
    /// dcⱼ = Σₙ bⱼₙ, instants.
    dc: [f32; 2],
    /// Q = ⟨P⊥bᵢ, P⊥bⱼ⟩, instants.
    q: [[f32; 2]; 2],
    /// Q in Q30 (the residual's energy takes the hum's pᵀQp, up to 10⁷
    /// times the noise's, in integers).
    q30: [[i64; 2]; 2],
    /// cos ψ, sin ψ: a block's turn of the hum.
    turn: [f32; 2],
    /// λ per block.
    forget: f32,
}

/// One input's window: r (counts·instants), Σλᵃ·E (the residual
/// energies it holds, counts²·instants), M and M₂ (instants) and Σλᵃ
/// (state).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HumState {
    r: [f32; 2],
    energy: f32,
    m: [[f32; 2]; 2],
    m2: [[f32; 2]; 2],
    weight: f32,
    /// Times the window started again (the hum changed).
    pub restarts: u32,
}

impl HumState {
    /// No block yet.
    pub const EMPTY: Self = Self {
        r: [0.0; 2],
        energy: 0.0,
        m: [[0.0; 2]; 2],
        m2: [[0.0; 2]; 2],
        weight: 0.0,
        restarts: 0,
    };
}

impl<const N: usize, const K: usize> Mains<N, K> {
    /// Hum at `mains_hz` in blocks of N instants at `rate_hz`, beside
    /// `comb`'s tones, followed over [`TAU_S`].
    pub fn new(mains_hz: u32, rate_hz: u32, comb: &Comb<N, K>) -> Self {
        let mut reference = [[0i16; 2]; N];
        for (w, n) in reference.iter_mut().zip(0u64..) {
            let (c, s) = cossin(turns(mains_hz as u64 * n, rate_hz));
            *w = [q15(c), q15(s)];
        }
        let (c, s) = cossin(turns(mains_hz as u64 * N as u64, rate_hz));
        let turn = [c as f32 / Q31 as f32, s as f32 / Q31 as f32];
        let forget = 1.0 - N as f32 / rate_hz as f32 / TAU_S;
        Self::from_words(reference, comb, turn, forget)
    }

    /// A basis of Q15 `reference` words (instant by instant) beside
    /// `comb`'s tones, turning by `turn` (cos ψ, sin ψ) a block and
    /// followed with λ = `forget` a block (0: each block alone).
    pub(crate) fn from_words(
        reference: [[i16; 2]; N],
        comb: &Comb<N, K>,
        turn: [f32; 2],
        forget: f32,
    ) -> Self {
        let q31 = reference.map(|w| w.map(|v| (v as i32) << 16));
        let tones: [&[[i32; 2]]; K] = core::array::from_fn(|k| comb.reference(k).map_or(&[][..], |r| &r[..]));
        Self {
            words: Words::new(&reference),
            fit: Fit::new(&q31, &tones, turn, forget),
        }
    }

    /// What every block's fit reads.
    pub fn fit(&self) -> &Fit<K> {
        &self.fit
    }

    /// The basis's words ([cos φₙ, sin φₙ] for a hum), Q15.
    pub fn words(&self) -> &Words<N> {
        &self.words
    }

    /// Σₙ xₙ·b₀ₙ and Σₙ xₙ·b₁ₙ of input `col` of a block's rows (Q31 ·
    /// counts, from Q15 words: each product below 2³⁰, N of them, no
    /// overflow for N < 2¹⁷). On the Cortex-M4 two instants a dual
    /// product (`arm`), the same integers.
    #[inline(never)]
    pub fn sums<const S: usize>(&self, rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
        if col >= S {
            return [0, 0];
        }
        #[cfg(arm_dsp)]
        let [c, s] = arm::sums(&self.words, rows, col);
        #[cfg(not(arm_dsp))]
        let [c, s] = portable(self.words.iter(), rows, col, 0);
        [c << 16, s << 16]
    }
}

/// Σₙ xₙ·bₙ from instant `from` on, one instant at a time (Q15 · counts):
/// the definition the Cortex-M4's dual products are held to.
pub fn portable<const S: usize>(
    reference: impl IntoIterator<Item = [i16; 2]>,
    rows: &[[i16; S]],
    col: usize,
    from: usize,
) -> [i64; 2] {
    let (mut c, mut s) = (0i64, 0i64);
    for (row, w) in rows.iter().zip(reference).skip(from) {
        let x = row[col] as i64;
        c += x * w[0] as i64;
        s += x * w[1] as i64;
    }
    [c, s]
}

/// The hum's sums on the Cortex-M4 (DSP extension): two instants packed
/// into one word (`PKHBT`) against two packed reference words by two
/// `SMLALD`, four instants a turn.
#[cfg(arm_dsp)]
#[allow(unsafe_code)]
mod arm {
    /// Two instants: their samples packed into one word, two dual
    /// products with the packed cosines and sines.
    macro_rules! pair {
        () => {
            "ldrsh {a}, [{p}], #{stride}\n\
             ldrsh {b}, [{p}], #{stride}\n\
             ldrd {c}, {s}, [{q}], #8\n\
             pkhbt {a}, {a}, {b}, lsl #16\n\
             smlald {cl}, {ch}, {a}, {c}\n\
             smlald {sl}, {sh}, {a}, {s}"
        };
    }

    /// [`super::portable`]'s integers: the first 4·⌊N/4⌋ instants two by
    /// two in assembly, the rest one by one.
    #[inline(always)]
    pub fn sums<const N: usize, const S: usize>(
        words: &super::Words<N>,
        rows: &[[i16; S]; N],
        col: usize,
    ) -> [i64; 2] {
        let quads = N / 4;
        let (mut cl, mut ch, mut sl, mut sh) = (0u32, 0u32, 0u32, 0u32);
        if quads > 0 {
            let mut p = rows[0][col..].as_ptr();
            let mut q = words.0.as_ptr();
            // SAFETY: `p` walks input `col` of the first 4·quads rows (S
            // samples of 2 bytes apart) and `q` the first 4·quads words
            // (two entries of 4 bytes an instant pair, 8-aligned: `Words`),
            // both inside their arrays; the loop reads exactly those and
            // stops when `q` reaches `end`. Only registers and the two
            // arrays are touched.
            unsafe {
                let end = q.add(4 * quads);
                core::arch::asm!(
                    "2:",
                    pair!(),
                    pair!(),
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
                    a = out(reg) _,
                    b = out(reg) _,
                    c = out(reg) _,
                    s = out(reg) _,
                    options(nostack, readonly),
                );
            }
            let _ = (p, q);
        }
        let done = [
            ((ch as u64) << 32 | cl as u64) as i64,
            ((sh as u64) << 32 | sl as u64) as i64,
        ];
        let rest = super::portable(words.iter(), rows, col, 4 * quads);
        [done[0] + rest[0], done[1] + rest[1]]
    }
}

impl<const K: usize> Fit<K> {
    /// The overlaps of a hum `reference` (Q31 words, one an instant) with
    /// the mean and the comb's `tones` (each its Q31 words): exact sums
    /// of the words' products in i128 ([`overlap`]), and from them every
    /// constant in integers but the last conversion (compact code on a
    /// core without f64); a block's `turn` (cos ψ, sin ψ) and λ
    /// (`forget`) as given.
    #[inline(never)]
    fn new(reference: &[[i32; 2]], tones: &[&[[i32; 2]]; K], turn: [f32; 2], forget: f32) -> Self {
        let count = reference.len() as i128;
        // Lₖⱼ, Q62: [re, im].
        let l62: [[[i128; 2]; 2]; K] = core::array::from_fn(|k| {
            core::array::from_fn(|j| {
                [
                    overlap(reference, j, tones[k], 0),
                    -overlap(reference, j, tones[k], 1),
                ]
            })
        });
        // dcⱼ, Q31.
        let dc: [i128; 2] = [0, 1].map(|j| reference.iter().map(|w| w[j] as i128).sum());
        // Q, Q62: ⟨bᵢ, bⱼ⟩ − dcᵢ·dcⱼ/N − (2/N)·Σₖ Re(Lₖᵢ·conj Lₖⱼ) (L to
        // Q31 for the products: 2⁻³² of a tone's overlap, below 10⁻⁸).
        let q30: [[i64; 2]; 2] = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                let tones = cross(&l62, i, j);
                let q62 = overlap(reference, i, reference, j) - round_div(dc[i] * dc[j] + 2 * tones, count);
                round_div(q62, 1 << 32) as i64
            })
        });
        Self {
            n: count as u32,
            leak: l62.map(|l| l.map(|[re, im]| Complex32::new(q62_to_f32(re), q62_to_f32(im)))),
            // 2·L/N in Q32 = 2·L₆₂/(N·2³⁰); dc/N in Q32 = 2·dc₃₁/N.
            leak_q32: l62.map(|l| l.map(|c| c.map(|v| round_div(2 * v, count << 30) as i64))),
            dc_q32: dc.map(|d| round_div(2 * d, count) as i64),
            dc: dc.map(|d| fmath::i64_to_f32(d as i64) / Q31 as f32),
            q: q30.map(|row| row.map(|v| fmath::i64_to_f32(v) / (1u32 << 30) as f32)),
            q30,
            turn,
            forget,
        }
    }

    /// u = ⟨P⊥x, b⟩ (counts·instants) in f32 from the block's levels, and
    /// the size of the terms it is the difference of (what f32's rounding
    /// scales with).
    fn projections_f32(&self, sums: [i64; 2], tones: &Tones<K>, levels: &Levels<K>) -> ([f32; 2], [f32; 2]) {
        let nf = self.n as f32;
        let q31 = Q31 as f32;
        let mean = fmath::i64_to_f32(tones.sum) / nf;
        let mut u = [0.0; 2];
        let mut size = [0.0; 2];
        for j in 0..2 {
            let own = fmath::i64_to_f32(sums[j]) / q31;
            let (mut t, mut t_size) = (mean * self.dc[j], (mean * self.dc[j]).abs());
            for (x, l) in levels.phasor.iter().zip(&self.leak) {
                let v = (x.re * l[j].re + x.im * l[j].im) * (2.0 / (nf * q31));
                t += v;
                t_size +=
                    (x.re * l[j].re).abs() * (2.0 / (nf * q31)) + (x.im * l[j].im).abs() * (2.0 / (nf * q31));
            }
            u[j] = own - t;
            size[j] = own.abs() + t_size;
        }
        (u, size)
    }

    /// u = ⟨P⊥x, b⟩ from the block's exact sums, in Q23 (counts·instants):
    /// formed in i128 (every term below 2⁸⁷: the sums below 2⁵³, the
    /// constants 2³³), so that a strong hum's u, the small difference of
    /// large sums, keeps every bit but the constants' rounding (2⁻³²).
    fn projections(&self, sums: [i64; 2], tones: &Tones<K>) -> [i64; 2] {
        core::array::from_fn(|j| {
            let mut acc = (sums[j] as i128) << 32;
            for (x, l) in tones.x.iter().zip(&self.leak_q32) {
                acc -= x.re as i128 * l[j][0] as i128 + x.im as i128 * l[j][1] as i128;
            }
            acc -= (tones.sum as i128 * self.dc_q32[j] as i128) << 31;
            // Q63 to Q23: |u| < 2⁴⁰.
            (acc >> 40) as i64
        })
    }

    /// N·E' = N·(E − 2·pᵀu + pᵀQp), Q62 (counts²), in i128: `n_energy`
    /// N·E exact, p in Q16 (below 2³¹), u in Q23 (below 2⁴⁴), Q in
    /// Q30 (below 2³⁸): every product below 2¹⁰⁶.
    fn less_hum(&self, n_energy: i128, p: [f32; 2], u: [i64; 2]) -> i128 {
        let p16 = p.map(|v| (v * 65_536.0) as i64 as i128);
        let pu = p16[0] * u[0] as i128 + p16[1] * u[1] as i128;
        let q = self.q30.map(|row| row.map(|v| v as i128));
        let pqp =
            p16[0] * (q[0][0] * p16[0] + q[0][1] * p16[1]) + p16[1] * (q[1][0] * p16[0] + q[1][1] * p16[1]);
        (n_energy << 62) - self.n as i128 * ((pu << 24) - pqp)
    }

    /// T·A·Tᵀ.
    fn rotate(&self, a: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
        let [c, s] = self.turn;
        let t = [[c, s], [-s, c]];
        let tt = [[c, -s], [s, c]];
        mul(&mul(&t, a), &tt)
    }

    /// Take this block's view of the hum (`sums`: [`Mains::sums`] of the
    /// input whose comb gave `tones` and `levels`) into the input's
    /// window `state`, and the hum the window vouches for out of
    /// `levels` (module docs): its phasors, amplitudes, largest and
    /// residual are then the block's less the hum. `clean_counts`: the
    /// rms the window may leave (the front end's residual bound). Returns
    /// the hum taken out, p (counts), and each tone's noise gain; None
    /// where none was (`levels` untouched).
    #[inline(never)]
    pub fn cancel(
        &self,
        state: &mut HumState,
        sums: [i64; 2],
        tones: &Tones<K>,
        levels: &mut Levels<K>,
        clean_counts: f32,
    ) -> Option<([f32; 2], [f32; K])> {
        if tones.n != self.n {
            return None;
        }
        let nf = self.n as f32;
        let (u, size) = self.projections_f32(sums, tones, levels);
        let energy = levels.residual * levels.residual * nf;
        let block_dof = (self.n as usize - 1 - 2 * K) as f32;
        // The window's hum, as it stood, leaves more of this block than
        // the clean bound, surely (f32's rounding taken off): the hum
        // changed (it started, stopped, or grew). The window starts again
        // from this block.
        if let Some((_, p)) = self.held(state) {
            let (left, rounding) = self.less_hum_f32(energy, self.turned(p), u, size);
            if left - rounding > clean_counts * clean_counts * block_dof {
                *state = HumState {
                    restarts: state.restarts.wrapping_add(1),
                    ..HumState::EMPTY
                };
            }
        }
        self.advance(state, u, energy);
        let (a, p) = self.held(state)?;
        let explained = p[0] * state.r[0] + p[1] * state.r[1];
        let noise = (state.energy - explained) / (state.weight * block_dof - 2.0);
        if !(explained > SIGNIFICANT * noise && noise <= clean_counts * clean_counts) {
            return None;
        }
        // E − 2·pᵀu + pᵀQp cancels: in f32, with what f32 can round off
        // of its terms added, where that is under 1 % of the noise's
        // energy (a weak hum); else (a strong one, up to 10⁷ times the
        // noise's energy) in integers from the block's exact sums.
        let (left, rounding) = self.less_hum_f32(energy, p, u, size);
        let residual = if rounding <= 0.01 * noise * nf {
            fmath::sqrt(fmath::max(left, 0.0) / nf + rounding / nf)
        } else {
            let exact = self.projections(sums, tones);
            root_over(
                self.less_hum(tones.residual_n_energy(), p, exact).max(0),
                31,
                self.n,
            )
        };
        // A hum this block does not hold (it stopped, or is not one):
        // taken out, it would leave more than it found. Left in.
        // (NaN is no less: left in.)
        if residual.partial_cmp(&levels.residual) != Some(core::cmp::Ordering::Less) {
            return None;
        }
        levels.residual = residual;
        for ((phasor, amplitude), leak) in levels
            .phasor
            .iter_mut()
            .zip(levels.amplitude.iter_mut())
            .zip(&self.leak)
        {
            let y = *phasor / Q31 as f32 - (leak[0] * p[0] + leak[1] * p[1]);
            *phasor = y * Q31 as f32;
            *amplitude = fmath::hypot(y.re, y.im) * (2.0 / nf);
        }
        levels.largest = largest(&levels.amplitude);
        Some((p, self.gains(&a, &state.m2)))
    }

    /// The most one block's p can be off by, per unit of the block's
    /// noise σ (counts): p = Q⁻¹·u has covariance σ²·Q⁻¹, whose largest
    /// eigenvalue is 1/λ_min(Q); so √(1/λ_min(Q)) (instants^−½). For a
    /// fit of each block alone (λ = 0; [`crate::sideband`]); ∞ where Q
    /// is singular.
    pub fn spread(&self) -> f32 {
        let q = &self.q;
        let (tr, det) = (q[0][0] + q[1][1], q[0][0] * q[1][1] - q[0][1] * q[1][0]);
        let gap = fmath::sqrt(fmath::max(tr * tr - 4.0 * det, 0.0));
        let least = 0.5 * (tr - gap);
        if fmath::positive_finite(least) {
            fmath::sqrt(1.0 / least)
        } else {
            f32::INFINITY
        }
    }

    /// The window moved on by one block: M ← λ·T·M·Tᵀ + Q, M₂ with λ²,
    /// r ← λ·T·r + u, the energies and weights with λ.
    fn advance(&self, state: &mut HumState, u: [f32; 2], energy: f32) {
        let l = self.forget;
        state.m = add(&scale(&self.rotate(&state.m), l), &self.q);
        state.m2 = add(&scale(&self.rotate(&state.m2), l * l), &self.q);
        let r = self.turned(state.r);
        state.r = [l * r[0] + u[0], l * r[1] + u[1]];
        state.energy = l * state.energy + energy;
        state.weight = l * state.weight + 1.0;
    }

    /// The hum the window holds, p = M⁻¹·r, with M⁻¹, where it is half
    /// full at least: a block or two alone cannot tell the hum from the
    /// lowest tones (M is near singular).
    fn held(&self, state: &HumState) -> Option<([[f32; 2]; 2], [f32; 2])> {
        if state.weight * (1.0 - self.forget) < 0.5 {
            return None;
        }
        let a = inverse2(&state.m)?;
        let r = state.r;
        Some((
            a,
            [a[0][0] * r[0] + a[0][1] * r[1], a[1][0] * r[0] + a[1][1] * r[1]],
        ))
    }

    /// T·v: a hum (or r) of one block in the next block's frame.
    fn turned(&self, v: [f32; 2]) -> [f32; 2] {
        let [c, s] = self.turn;
        [c * v[0] + s * v[1], -s * v[0] + c * v[1]]
    }

    /// E − 2·pᵀu + pᵀQp in f32 (`energy` = E, counts²·instants), and
    /// what f32 can round off of its terms (`size`: u's terms' sizes).
    fn less_hum_f32(&self, energy: f32, p: [f32; 2], u: [f32; 2], size: [f32; 2]) -> (f32, f32) {
        let (pu, pqp) = (p[0] * u[0] + p[1] * u[1], quad(&self.q, p));
        let rounding = ROUNDING * (energy + 2.0 * (p[0].abs() * size[0] + p[1].abs() * size[1]) + pqp.abs());
        (energy - 2.0 * pu + pqp, rounding)
    }

    /// Each tone's noise, times its own, with the hum p = M⁻¹·r taken out
    /// (`a` = M⁻¹): Cov p / σ² = M⁻¹·M₂·M⁻¹, and a tone's component moves
    /// by its leak's row times p.
    fn gains(&self, a: &[[f32; 2]; 2], m2: &[[f32; 2]; 2]) -> [f32; K] {
        let cov = mul(&mul(a, m2), a);
        let half = self.n as f32 / 2.0;
        self.leak.map(|leak| {
            let re = quad(&cov, [leak[0].re, leak[1].re]);
            let im = quad(&cov, [leak[0].im, leak[1].im]);
            fmath::sqrt(1.0 + fmath::max(re, im) / half)
        })
    }
}

/// Σₙ a[n][i]·b[n][j] over the shorter of the two, exactly (Q62 when
/// both are Q31 words).
#[inline(never)]
fn overlap(a: &[[i32; 2]], i: usize, b: &[[i32; 2]], j: usize) -> i128 {
    a.iter()
        .zip(b)
        .map(|(a, b)| a[i] as i64 as i128 * b[j] as i64 as i128)
        .sum()
}

/// a/b rounded to nearest (b > 0; out of line: i128 division is long
/// code on a 32-bit core).
#[inline(never)]
fn round_div(a: i128, b: i128) -> i128 {
    if a >= 0 {
        (a + b / 2) / b
    } else {
        -((-a + b / 2) / b)
    }
}

/// Σₖ Re(Lₖᵢ·conj Lₖⱼ), Q62, of overlaps given in Q62 (each taken to
/// Q31 first: below 2³⁷, so each product is i64 by i64).
#[inline(never)]
fn cross(l62: &[[[i128; 2]; 2]], i: usize, j: usize) -> i128 {
    let q31 = |v: i128| (v >> 31) as i64 as i128;
    l62.iter()
        .map(|l| q31(l[i][0]) * q31(l[j][0]) + q31(l[i][1]) * q31(l[j][1]))
        .sum()
}

/// A Q62 number to f32.
#[inline(never)]
fn q62_to_f32(v: i128) -> f32 {
    fmath::i64_to_f32((v >> 31) as i64) / Q31 as f32
}

/// A Q31 word to Q15, rounded (±32767: symmetric, as the comb's).
pub(crate) fn q15(v: i32) -> i16 {
    ((v as i64 + (1 << 15)) >> 16).clamp(-32767, 32767) as i16
}

/// The phase of `num/den` turns as the comb's references take it (2³² a
/// turn, rounded).
fn turns(num: u64, den: u32) -> i32 {
    let m = num % den as u64;
    (((m << 32) + den as u64 / 2) / den as u64) as u32 as i32
}

fn mul(a: &[[f32; 2]; 2], b: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
    core::array::from_fn(|i| core::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j]))
}

fn add(a: &[[f32; 2]; 2], b: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
    core::array::from_fn(|i| core::array::from_fn(|j| a[i][j] + b[i][j]))
}

fn scale(a: &[[f32; 2]; 2], k: f32) -> [[f32; 2]; 2] {
    a.map(|row| row.map(|v| v * k))
}

/// vᵀ·A·v.
fn quad(a: &[[f32; 2]; 2], v: [f32; 2]) -> f32 {
    v[0] * (a[0][0] * v[0] + a[0][1] * v[1]) + v[1] * (a[1][0] * v[0] + a[1][1] * v[1])
}

/// A⁻¹, None where A is singular.
fn inverse2(a: &[[f32; 2]; 2]) -> Option<[[f32; 2]; 2]> {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    fmath::positive_finite(det).then(|| [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]])
}

#[cfg(test)]
pub(crate) mod tests;
