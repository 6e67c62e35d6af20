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
//! The reference is laid out to repeat wherever every tone's periods
//! share a factor with N, or to repeat negated over the halves of an
//! even block (a tone of odd periods: instant n + N/2 is instant n
//! negated), and to mirror (instant L − n of a period L is instant n
//! conjugated, or for a tone of odd periods over halves its conjugate
//! negated), to the bit; so an input's repeats are summed (and, over
//! halves, differenced) and each instant is paired with its mirror
//! before any product ([`folded`]): half the products of the plain
//! sums, a quarter over halves or repeats, and the same exact
//! integers.
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
    /// How many times the comb repeats in a block (every tone's periods
    /// a multiple of it, N too): a divisor of their greatest common
    /// one, at most [`REPEAT_MAX`]; or 2 where it does not repeat and N
    /// is even: the halves, each tone of odd periods negated in the
    /// second ([`repeat_of`]).
    repeat: usize,
    /// Instant n of tone k: [cos θₖ,ₙ, sin θₖ,ₙ], Q31 (saturated: ±1 is
    /// ±i32::MAX). With L = N/`repeat`, instant n + L holds instant n's
    /// words (negated for a tone of odd periods) and instant L − n their
    /// conjugate (negated likewise), exactly, as the fold ([`folded`])
    /// needs.
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
        let repeat = repeat_of(N, &periods);
        let l = N / repeat;
        let mut reference = [[[0i32; 2]; N]; K];
        for (row, &p) in reference.iter_mut().zip(&periods) {
            // The sign a repeat takes: −1 for odd periods over halves
            // (θ_{n+L} = θₙ + π).
            let sign = if p as usize % repeat == 0 { 1 } else { -1 };
            for n in 0..N {
                // The comb repeats every L = N/repeat instants (signed),
                // and instant L − j is instant j conjugated (θ_{L−j} =
                // −θⱼ, or π − θⱼ over halves: signed too): laid out to
                // the bit, as the fold needs.
                let (q, j) = (n / l, n % l);
                row[n] = if n <= l / 2 {
                    // The exact phase as a fraction of a turn, 2³² per turn.
                    let m = (p as u64 * n as u64) % N as u64;
                    let phase = (((m << 32) + N as u64 / 2) / N as u64) as u32 as i32;
                    let (c, s) = cossin(phase);
                    // Symmetric Q31: −1 as −i32::MAX, so that it negates.
                    [c.max(-i32::MAX), s.max(-i32::MAX)]
                } else {
                    let [c, s] = if j <= l / 2 {
                        row[j]
                    } else {
                        let [c, s] = row[l - j];
                        [sign * c, -sign * s]
                    };
                    let t = if q % 2 == 1 { sign } else { 1 };
                    [t * c, t * s]
                };
            }
        }
        Ok(Self {
            periods,
            repeat,
            reference,
        })
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
    /// place, not copied on their way). The sums are taken over the
    /// block folded on its repeats and mirror ([`folded`]; on Arm cores
    /// with the DSP extension the `arm` module's assembly): the same
    /// exact integers as [`portable`] and [`portable_moments`], bit for
    /// bit.
    pub fn column_into<const S: usize>(&self, rows: &[[i16; S]; N], col: usize, out: &mut Tones<K>) {
        if col >= S {
            *out = Tones::EMPTY;
            return;
        }
        #[cfg(arm_dsp)]
        arm::column_into(self, rows, col, out);
        #[cfg(not(arm_dsp))]
        folded(self, rows, col, out);
    }
}

/// The most repeats of the comb a block is folded over: each folded
/// sample is the sum of `repeat` samples and then of two, which i32
/// holds with room to spare (|u| ≤ 2·8·2¹⁵ = 2²⁰).
pub const REPEAT_MAX: usize = 8;

/// How many times a comb of `periods` repeats in `n` instants: the
/// largest divisor of n and of every count that is at most
/// [`REPEAT_MAX`]; where that is 1 and n is even, 2: the halves, a tone
/// of odd periods negated in the second (the 4 ms block's 1, 2, 4, 8,
/// 16 periods in 100 instants; the 1 ms block's 1, 2, 3, 4, 6 in 25
/// neither repeat nor halve).
fn repeat_of(n: usize, periods: &[u32]) -> usize {
    match (1..=REPEAT_MAX)
        .rev()
        .find(|&g| n % g == 0 && periods.iter().all(|&p| p as usize % g == 0))
    {
        Some(1) | None if n % 2 == 0 => 2,
        Some(g) => g,
        None => 1,
    }
}

/// Instants a fold keeps of a period of `l`: 0 to l/2, each with its
/// mirror l − j.
const fn kept(l: usize) -> usize {
    l / 2 + 1
}

/// The comb's sums for input `col` (< S) with the block folded: the
/// comb repeats every L = N/g instants (g = the comb's repeat), and in a
/// period instant L − j is instant j conjugated, exactly ([`Comb::new`]
/// lays the reference out so), so with yⱼ = Σ_q x_{j+qL} (the g repeats
/// summed)
///
/// ```text
/// Σₙ xₙ cos θₙ = Σ_{j ≤ L/2} uⱼ cos θⱼ,   Σₙ xₙ sin θₙ = Σ_{j ≤ L/2} wⱼ sin θⱼ,
/// uⱼ = yⱼ + y_{L−j},  wⱼ = yⱼ − y_{L−j}   (uⱼ = wⱼ = yⱼ where j = L − j mod L: j = 0, L/2)
/// ```
///
/// Over halves (g = 2 where a tone makes odd periods) such a tone is
/// negated in the second half and its mirror conjugated and negated, so
/// it takes dⱼ = xⱼ − x_{j+L} instead, uⱼ = dⱼ − d_{L−j}, wⱼ = dⱼ + d_{L−j}
/// (dⱼ alone at j = 0 and L/2).
///
/// 1/(2g) of the plain sums' products. Σx = Σuⱼ of the y; Σx² of the
/// samples themselves. Every partial sum is a sum of some of the plain
/// sums' terms, so no more can overflow than there (module docs): the
/// same exact integers as [`portable`] and [`portable_moments`].
pub fn folded<const N: usize, const S: usize, const K: usize>(
    comb: &Comb<N, K>,
    rows: &[[i16; S]; N],
    col: usize,
    out: &mut Tones<K>,
) {
    if col >= S {
        *out = Tones::EMPTY;
        return;
    }
    let l = N / comb.repeat;
    let y = |j: usize| -> i32 { rows[j..].iter().step_by(l).map(|r| r[col] as i32).sum() };
    // The halves' difference (used only where a tone negates over them).
    let d = |j: usize| -> i32 { rows[j][col] as i32 - rows[(j + l) % N][col] as i32 };
    let mut uw = [[0i32; 2]; N];
    let mut odd = [[0i32; 2]; N];
    let mut sum = 0i64;
    for (j, (e, o)) in uw.iter_mut().zip(odd.iter_mut()).enumerate().take(kept(l)) {
        let (a, p) = (y(j), d(j));
        (*e, *o) = if j == 0 || 2 * j == l {
            ([a, a], [p, p])
        } else {
            let (b, q) = (y(l - j), d(l - j));
            ([a + b, a - b], [p - q, p + q])
        };
        sum += e[0] as i64;
    }
    for ((x, reference), &p) in out.x.iter_mut().zip(&comb.reference).zip(&comb.periods) {
        let folded = if p as usize % comb.repeat == 0 { &uw } else { &odd };
        let (mut c, mut s) = (0i64, 0i64);
        for (&[u, w], &[rc, rs]) in folded.iter().zip(reference).take(kept(l)) {
            c += u as i64 * rc as i64;
            s += w as i64 * rs as i64;
        }
        *x = Complex::new(c, -s);
    }
    out.n = N as u32;
    out.sum = sum;
    out.sq = portable_moments(rows, col)[1];
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
/// reference, every instant in turn: the definition the folded sums
/// ([`folded`], and the Cortex-M4's `arm` assembly) are checked
/// against, bit for bit.
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

/// Cortex-M4 (DSP extension) folded comb ([`folded`]) in inline
/// assembly. The fold, four pairs of kept instants a turn: where the
/// comb does not repeat, 8 instructions a pair (two post-indexed `LDRSH`,
/// forward and back, two `SMLAL` for Σx², the sum and difference, Σx,
/// one `STRD`); over halves (the 4 ms block), 19 for a pair's four
/// samples (their sums and differences, two `STRD`). Then each tone at
/// 4 instructions a kept instant (two `LDRD`, two `SMLAL`), several a
/// turn. A 25-instant input takes 13 products a tone's cosine where the
/// plain sums took 25, a 100-instant one 26 where they took 100.
#[cfg(arm_dsp)]
#[allow(unsafe_code)]
pub mod arm {
    use super::{kept, Comb, Tones};
    use core::mem::MaybeUninit;
    use num_complex::Complex;

    /// Pairs of kept instants a turn of the fold.
    const FOLD_TURN: usize = 4;

    /// Kept instants a turn of a tone's loop: the one of 4 to 7 that
    /// costs fewest instructions (four per instant, two per turn, the
    /// last turn padded with zeros): 7 for the 13 of a 25-instant
    /// block, and for the 26 of a 100-instant one over halves.
    const fn tone_turn(m: usize) -> usize {
        let (mut best, mut cost, mut u) = (4, usize::MAX, 4);
        while u <= 7 {
            let c = m.div_ceil(u) * (4 * u + 2);
            if c < cost {
                (best, cost) = (u, c);
            }
            u += 1;
        }
        best
    }

    /// One pair of the fold of a comb that does not repeat: x_j forward,
    /// x_{N−j} back, their squares, [u, w] stored, Σx.
    macro_rules! fold_step {
        () => {
            "ldrsh {a}, [{pa}], {stride}\n\
             ldrsh {b}, [{pb}], #-{stride}\n\
             smlal {ql}, {qh}, {a}, {a}\n\
             smlal {ql}, {qh}, {b}, {b}\n\
             add {u}, {a}, {b}\n\
             sub {b}, {a}, {b}\n\
             add {sum}, {u}\n\
             strd {u}, {b}, [{po}], #8"
        };
    }

    /// One pair of the fold over halves (L = N/2): x_j and x_{j+L}
    /// forward, x_{L−j} and x_{N−j} back (each second sample `off` bytes
    /// on), the four squares; y = x_j + x_{j+L} and d = x_j − x_{j+L}
    /// each way (d first, y = d + 2·x_{j+L}); [u, w] of the y stored and
    /// of the d `odd` bytes on ([`super::folded`]), Σx.
    macro_rules! fold2_step {
        () => {
            "ldrsh {a}, [{pa}, #{off}]\n\
             ldrsh {u}, [{pa}], {stride}\n\
             smlal {ql}, {qh}, {a}, {a}\n\
             smlal {ql}, {qh}, {u}, {u}\n\
             sub {u}, {u}, {a}\n\
             add {a}, {u}, {a}, lsl #1\n\
             ldrsh {b}, [{pb}, #{off}]\n\
             ldrsh {v}, [{pb}], #-{stride}\n\
             smlal {ql}, {qh}, {b}, {b}\n\
             smlal {ql}, {qh}, {v}, {v}\n\
             sub {v}, {v}, {b}\n\
             add {b}, {v}, {b}, lsl #1\n\
             sub {a}, {a}, {b}\n\
             add {b}, {a}, {b}, lsl #1\n\
             add {sum}, {b}\n\
             sub {u}, {u}, {v}\n\
             add {v}, {u}, {v}, lsl #1\n\
             strd {u}, {v}, [{po}, #{odd}]\n\
             strd {b}, {a}, [{po}], #8"
        };
    }

    /// One kept instant of a tone: [u, w], its reference pair, two
    /// products.
    macro_rules! tone_step {
        ($_:tt) => {
            "ldrd {u}, {w}, [{p}], #8\n\
             ldrd {c}, {s}, [{q}], #8\n\
             smlal {cl}, {ch}, {u}, {c}\n\
             smlal {sl}, {sh}, {w}, {s}"
        };
    }

    /// [`folded`](super::folded) in assembly, the same sums bit for bit
    /// (the QEMU benchmark checks it against [`portable`](super::portable)
    /// on the target); blocks it was not laid out for (rows of over 127
    /// inputs, periods of fewer than 14 or blocks of more than 2¹⁶
    /// instants, halves of more than 127 instants, combs repeating more
    /// than twice) take the plain sums.
    #[inline(always)]
    pub fn column_into<const N: usize, const S: usize, const K: usize>(
        comb: &Comb<N, K>,
        rows: &[[i16; S]; N],
        col: usize,
        out: &mut Tones<K>,
    ) {
        // Each repeat its own code, every count below known as it is
        // compiled.
        match comb.repeat {
            1 => repeating::<N, S, K, 1>(comb, rows, col, out),
            2 => repeating::<N, S, K, 2>(comb, rows, col, out),
            _ => plain(comb, rows, col, out),
        }
    }

    /// The plain sums ([`portable`](super::portable),
    /// [`portable_moments`](super::portable_moments)) for the shapes the
    /// assembly was not laid out for: the same integers, in the least
    /// code (a board image carries one per block length).
    #[inline(never)]
    fn plain<const N: usize, const S: usize, const K: usize>(
        comb: &Comb<N, K>,
        rows: &[[i16; S]; N],
        col: usize,
        out: &mut Tones<K>,
    ) {
        for (x, reference) in out.x.iter_mut().zip(&comb.reference) {
            let [c, s] = super::portable(rows, col, reference);
            *x = Complex::new(c, -s);
        }
        [out.sum, out.sq] = super::portable_moments(rows, col);
        out.n = N as u32;
    }

    /// [`column_into`] for a comb that repeats `R` times (1 or 2).
    #[inline(always)]
    fn repeating<const N: usize, const S: usize, const K: usize, const R: usize>(
        comb: &Comb<N, K>,
        rows: &[[i16; S]; N],
        col: usize,
        out: &mut Tones<K>,
    ) {
        let l = N / R;
        let m = kept(l);
        let turn = tone_turn(m);
        let padded = m.div_ceil(turn) * turn;
        // Pairs: kept instants 1..=pairs with l−1 down to l−pairs.
        let pairs = (l - 1) / 2;
        let whole = pairs - pairs % FOLD_TURN;
        // Over halves the odd periods' entries lie l on (the `odd`
        // offset of a STRD, at most 1020 bytes), and each second sample
        // l rows on (the `off` of an LDRSH, at most 4095).
        let shape = R == 1 || (N == 2 * l && l * 8 <= 1020 && l * S * 2 <= 4095);
        if col >= S
            || S * 2 > 255
            || l < 14
            || N > 1 << 16
            || padded > l
            || whole == 0
            || comb.repeat != R
            || !shape
        {
            return plain(comb, rows, col, out);
        }
        let mut uw = MaybeUninit::<[[i32; 2]; N]>::uninit();
        let base = uw.as_mut_ptr().cast::<[i32; 2]>();
        // SAFETY: col < S, S·2 ≤ 255, whole a non-zero multiple of
        // FOLD_TURN below l/2, and R·l = N with l·8 ≤ 1020 where R = 2
        // (checked above); `base` is `uw`'s, N entries.
        let (sum, ql, qh) = unsafe { fold_turns::<N, S, R>(rows, col, l, whole, base) };
        let mut sum = sum as i64;
        let mut sq = ((qh as u64) << 32 | ql as u64) as i64;
        // The rest in Rust: the pairs the turns left, instant 0, and l/2
        // where l is even; each y_j (and over halves d_j) with its
        // repeat's sample and squares.
        let mut yd = |j: usize| {
            let (mut a, mut d) = (0i32, 0i32);
            for q in 0..R {
                let x = rows[j + q * l][col] as i32;
                sq += (x * x) as i64;
                a += x;
                d = if q == 0 { x } else { d - x };
            }
            (a, d)
        };
        let mut put = |j: usize, (a, d): (i32, i32), b: Option<(i32, i32)>| {
            let (e, o) = match b {
                Some((b, q)) => ([a + b, a - b], [d - q, d + q]),
                None => ([a, a], [d, d]),
            };
            sum += e[0] as i64;
            // SAFETY: j < m ≤ padded ≤ l, inside `uw` (N entries) at j
            // and, over halves, at l + j < 2·l = N.
            unsafe {
                base.add(j).write(e);
                if R == 2 {
                    base.add(l + j).write(o);
                }
            }
        };
        for j in whole + 1..=pairs {
            let (a, b) = (yd(j), yd(l - j));
            put(j, a, Some(b));
        }
        put(0, yd(0), None);
        if l % 2 == 0 {
            put(l / 2, yd(l / 2), None);
        }
        // Zeros to fill the last turn (adding nothing to any sum).
        for j in m..padded {
            // SAFETY: j < padded ≤ l, and l + j < N over halves.
            unsafe {
                base.add(j).write([0, 0]);
                if R == 2 {
                    base.add(l + j).write([0, 0]);
                }
            }
        }
        for ((x, reference), &p) in out.x.iter_mut().zip(&comb.reference).zip(&comb.periods) {
            // A tone that negates over halves reads the d's entries.
            let at = if R == 2 && p % 2 == 1 { l } else { 0 };
            // SAFETY: entries at..at + padded of `uw` are written above;
            // padded ≤ l, a non-zero multiple of turn (4 to 7).
            *x = unsafe { tone_sums(base.add(at), padded, turn, reference) };
        }
        out.n = N as u32;
        out.sum = sum;
        out.sq = sq;
    }

    /// [`repeating`]'s fold in assembly: entries 1..=`whole` of the
    /// block at `base`, each pair of kept instants (j, l − j) of input
    /// `col` as [y_j + y_(l−j), y_j − y_(l−j)], y_j the sum of the `R`
    /// repeats' samples, and over halves (R = 2) entries l + 1..=l +
    /// `whole` as [d_j − d_(l−j), d_j + d_(l−j)], d_j their difference;
    /// the sum of the y and the squares' sum (low and high words),
    /// FOLD_TURN pairs a turn.
    ///
    /// # Safety
    /// `col` < S, S·2 ≤ 255, `whole` a non-zero multiple of FOLD_TURN
    /// with `whole` < l/2, R·l = N with l·8 ≤ 1020 where R = 2, and
    /// `base` valid for writes of N entries.
    #[inline(always)]
    unsafe fn fold_turns<const N: usize, const S: usize, const R: usize>(
        rows: &[[i16; S]; N],
        col: usize,
        l: usize,
        whole: usize,
        base: *mut [i32; 2],
    ) -> (i32, u32, u32) {
        let (mut sum, mut ql, mut qh) = (0i32, 0u32, 0u32);
        // SAFETY: `pa` walks input `col` (< S) of rows 1..=whole forward
        // and `pb` of rows l−1 down to l−whole back, S·2 bytes a step (an
        // immediate of at most 255), and over halves each also reads
        // the row l on (`off` bytes, at most 4095: rows up to N − 1);
        // `po` writes entries 1..=whole at `base` (N entries, whole <
        // l/2), and over halves l + 1..=l + whole (`odd` bytes on, at
        // most 1020; l + whole < N), 8 bytes a step; the loop takes FOLD_TURN pairs a turn (`whole` a
        // non-zero multiple) and stops when `po` reaches `end`. Only
        // registers, the rows' memory (read) and `base`'s (written) are
        // touched.
        unsafe {
            let pa = rows.as_ptr().cast::<i16>().add(S + col);
            let pb = rows.as_ptr().cast::<i16>().add((l - 1) * S + col);
            let po = base.add(1);
            let end = po.add(whole);
            // The loop, its turn four of `$step` (and any operand the
            // step alone takes).
            macro_rules! fold_loop {
                ($step:ident; $($extra:tt)*) => {
                    core::arch::asm!(
                        "2:",
                        $step!(),
                        $step!(),
                        $step!(),
                        $step!(),
                        "cmp {po}, {end}",
                        "bne 2b",
                        stride = const S * 2,
                        $($extra)*
                        pa = inout(reg) pa => _,
                        pb = inout(reg) pb => _,
                        po = inout(reg) po => _,
                        end = in(reg) end,
                        sum = inout(reg) sum,
                        ql = inout(reg) ql,
                        qh = inout(reg) qh,
                        a = out(reg) _,
                        b = out(reg) _,
                        u = out(reg) _,
                        options(nostack),
                    )
                };
            }
            if R == 1 {
                fold_loop!(fold_step;);
            } else {
                // (R = 2: l = N/2, checked by the caller.)
                fold_loop!(fold2_step; off = const N / 2 * S * 2, odd = const N / 2 * 8, v = out(reg) _,);
            }
        }
        (sum, ql, qh)
    }

    /// [`repeating`]'s sums for one tone in assembly: Σ over entries
    /// 0..`padded` at `base` of the folded pair against `reference`,
    /// `turn` entries a turn; the tone's cosine and (negated) sine sums.
    ///
    /// # Safety
    /// Entries 0..`padded` at `base` written, `padded` ≤ N a non-zero
    /// multiple of `turn` (4 to 7).
    #[inline(always)]
    unsafe fn tone_sums<const N: usize>(
        base: *mut [i32; 2],
        padded: usize,
        turn: usize,
        reference: &[[i32; 2]; N],
    ) -> Complex<i64> {
        let (mut cl, mut ch, mut sl, mut sh) = (0u32, 0u32, 0u32, 0u32);
        // SAFETY: `p` reads entries 0..padded at `base`, all written
        // (the caller's contract), `q` the first `padded` (≤ N) reference words, 8
        // bytes a step each; the loop takes `turn` a turn (`padded` a
        // non-zero multiple of it) and stops when `p` reaches `end`.
        // Only registers and the two arrays' memory (read) are
        // touched.
        unsafe {
            let end = base.add(padded);
            macro_rules! tone_loop {
                ($($step:tt)*) => {
                    core::arch::asm!(
                        "2:",
                        $(tone_step!($step),)*
                        "cmp {p}, {end}",
                        "bne 2b",
                        p = inout(reg) base => _,
                        q = inout(reg) reference.as_ptr() => _,
                        end = in(reg) end,
                        cl = inout(reg) cl,
                        ch = inout(reg) ch,
                        sl = inout(reg) sl,
                        sh = inout(reg) sh,
                        u = out(reg) _,
                        w = out(reg) _,
                        c = out(reg) _,
                        s = out(reg) _,
                        options(nostack, readonly),
                    )
                };
            }
            // One step per token.
            match turn {
                7 => tone_loop!(1 2 3 4 5 6 7),
                6 => tone_loop!(1 2 3 4 5 6),
                5 => tone_loop!(1 2 3 4 5),
                _ => tone_loop!(1 2 3 4),
            }
        }
        let c = ((ch as u64) << 32 | cl as u64) as i64;
        let s = ((sh as u64) << 32 | sl as u64) as i64;
        Complex::new(c, -s)
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
    /// N·E_res = N·Σx² − (Σx)² − T, T = Σₖ 2|Xₖ|²/2⁶² (the tones'
    /// energy), is formed in i128, only its square root in f32: the same
    /// bits on every target, and no cancellation however large the tones;
    /// r = √(N·E_res)/N. T is [`tones_energy`]'s: within one unit of the
    /// exact sum, where the rounding of ADC codes alone leaves about
    /// N²/12 units in N·E_res (52 in the array's shortest block).
    pub fn residual_rms(&self) -> f32 {
        if self.n == 0 {
            return 0.0;
        }
        root_over(self.residual_scaled(), 0, self.n)
    }

    /// What no tone of the comb explains, as energy: N·E_res, E_res the
    /// Σ of the residual's squares, counts², exactly (the i128 of
    /// [`Tones::residual_rms`]; 0 for an empty block).
    pub fn residual_n_energy(&self) -> i128 {
        if self.n == 0 {
            return 0;
        }
        self.residual_scaled()
    }

    /// N·E_res in i128, not below 0 (`n` > 0). Inlined: the rms is on
    /// the boards' per-block path, in their fast RAM.
    #[inline(always)]
    fn residual_scaled(&self) -> i128 {
        let n = self.n as i128;
        let sum = self.sum.unsigned_abs() as u128;
        let mut e = n * self.sq as i128 - (sum * sum) as i128;
        e -= tones_energy(&self.x) as i128;
        e.max(0)
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
            largest: largest(&amplitude),
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

/// T = Σₖ 2|Xₖ|²/2⁶² = Σ (re² + im²)/2⁶¹ over the comb's sums (Q31 ·
/// counts), within one unit: exactly rounded ([`tones_energy_exact`],
/// u128 squares) unless every component is below 2⁵⁶ in size and there
/// are at most 32 of them, which holds for every block of fewer than 2¹⁰
/// instants even at full scale (|X| ≤ 2³¹·N·2¹⁵): then each
/// component X = h·2³² + l (h signed, |h| < 2²⁴; l unsigned) squares
/// as 8h² + 2h·(l/2)/2²⁸ + (l/2¹⁶)²/2²⁹ units, three multiply-accumulates
/// into i64 (Σh² < 2⁵³, Σh·(l/2) < 2⁶⁰, Σ(l/2¹⁶)² < 2³⁷: no overflow),
/// where the u128 squares take about eighteen instructions a component.
/// The bits dropped (l's lowest in h·l, l's low half in l²) are under
/// 1/16 + 2⁻¹² unit a component, the final rounding ½: below one unit
/// for 2 × 5 components, two for 32 (tested against the exact sum).
/// Inlined: on the boards' per-block path, in their fast RAM.
#[inline(always)]
pub fn tones_energy<const K: usize>(x: &[Complex<i64>; K]) -> u128 {
    const LIMIT: i32 = 1 << 24;
    let small = 2 * K <= 32
        && x.iter().all(|c| {
            let (h0, h1) = ((c.re >> 32) as i32, (c.im >> 32) as i32);
            (-LIMIT..LIMIT).contains(&h0) && (-LIMIT..LIMIT).contains(&h1)
        });
    if !small {
        return tones_energy_exact(x);
    }
    let (mut hh, mut hl, mut ll) = (0i64, 0i64, 0u64);
    for c in x {
        for v in [c.re, c.im] {
            let (h, l) = ((v >> 32) as i32, v as u32);
            hh += i64::from(h) * i64::from(h);
            hl += i64::from(h) * i64::from(l >> 1);
            let lh = u64::from(l >> 16);
            ll += lh * lh;
        }
    }
    // 8·Σh² + round((Σh·(l/2) + Σ(l/2¹⁶)²/4) / 2²⁷); the sum of the
    // last two is at least −2⁶⁰, so the floor shift rounds it.
    let frac = (hl + (ll >> 2) as i64 + (1 << 26)) >> 27;
    (8 * hh + frac).max(0) as u128
}

/// [`tones_energy`] exactly rounded: Σ (re² + im²)/2⁶¹ to the nearest
/// integer, the squares as u64 × u64 → u128 (i128 × i128 takes the full
/// 128-bit multiply).
pub fn tones_energy_exact<const K: usize>(x: &[Complex<i64>; K]) -> u128 {
    let square = |v: i64| {
        let a = v.unsigned_abs() as u128;
        a * a
    };
    let mut tones = 0u128;
    for c in x {
        tones += square(c.re) + square(c.im);
    }
    (tones + (1 << 60)) >> 61
}

/// √(e·2⁻²ᵈ)/n for e ≥ 0 (`down` = d): e to f32 through an even shift
/// that keeps 30 bits (e < 2¹²⁶), one square root, and the shift's half
/// less d put back as a power of two (exact, as ldexpf, a library call).
/// The residual's rms from N·E (d = 0), or from N·E in Q62 (d = 31).
#[inline(always)]
pub fn root_over(e: i128, down: i32, n: u32) -> f32 {
    let bits = 128 - e.leading_zeros();
    let sh = (bits.saturating_sub(30) + 1) & !1;
    let scaled = (e >> sh) as i32 as f32;
    crate::fmath::sqrt(scaled) * crate::fmath::pow2((sh / 2) as i32 - down) / n as f32
}

/// The largest of some amplitudes (0 for none; a NaN amplitude is passed
/// over, as by `fmath::max`, whose NaN test of the running value it
/// spares; from 0, never NaN).
#[inline(always)]
pub(crate) fn largest(amplitude: &[f32]) -> f32 {
    amplitude.iter().fold(0.0, |m, &a| if a > m { a } else { m })
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
