//! A windowed lock-in for one tone, with a guard bin on either side.
//!
//! [`crate::demod`] sums a block against the bare tone: the least-squares
//! phasor, blind to DC and to every harmonic, but its rectangular window
//! lets any other frequency leak into the tone's bin as sin(πΔ)/(πΔ),
//! Δ the distance in bins (1/T, T the block): 6 % of an interferer five
//! bins away. A channel that cannot tell how much leaked in has to refuse
//! every block with anything in it besides the tone.
//!
//! This lock-in multiplies the reference by Nuttall's four-term window
//! ([`NUTTALL`], continuous first derivative),
//!
//! ```text
//! w(n) = a₀ − a₁·cos(2πn/N) + a₂·cos(4πn/N) − a₃·cos(6πn/N)
//! X    = Σ xₙ·w(n)·e^(−jθₙ),   θₙ = 2π·k·n/N            (Q15 · ADC counts)
//! ```
//!
//! so that energy Δ bins from the tone leaks in by at most −92 dB for
//! |Δ| ≥ 4.5, −109 dB at 5.12 bins (1 kHz with the firmware's 1024 pairs at
//! 200 kSa/s) and less beyond: the **stop band** starts 4.5 bins from the
//! tone ([`STOP_BAND_BINS`]). Whole periods and a cosine-sum window keep the
//! tone's image and every harmonic from 2k on exactly out of X; DC lies k
//! bins away, inside the window's main lobe for k = 3 (and 4), so there
//! the block's mean, taken through the same window (which keeps far
//! energy out of it), is solved for together with the tone and its share
//! taken out of the tone and the guards.
//!
//! **Guard bins.** The same windowed baseband is also summed at bins k + 1
//! and k − 1 (rotated by e^(∓j2πn/N), [`Basis`]). A steady tone leaks
//! into each by exactly λ = −a₁/(2a₀) of X, which is taken out; what is left
//! ([`Reading::guards`]) is what lies near the tone and is not the tone:
//! an interferer, a hum harmonic, an alias, a step or a glitch. An
//! interferer |Δ| ≥ ½ bin from the tone moves X by at most [`GUARD_BOUND`]
//! times the larger guard (3.17, tested); beyond the stop band it reaches
//! neither. One closer than half a bin is, within one block, a second tone
//! at the same frequency: no single-tone measurement can see it.
//!
//! **Noise.** The window's equivalent noise bandwidth is 2.02 bins: white
//! noise of σ counts rms puts 0.063·σ counts on each component of the
//! tone's phasor at N = 1024 ([`Reading::noise_gain`]; √(2/N) = 0.044·σ
//! for the bare tone) and 0.037·σ on each of a guard's
//! ([`Reading::guard_noise_gain`]).
//!
//! **Storage.** The window is symmetric and the tone makes whole periods,
//! so the reference of n and of N − n are complex conjugates: half of it
//! is stored (2 KiB at N = 1024). The rotation to the guards, e^(−j2πn/N),
//! is one [`Basis`] shared by every frequency.
//!
//! Overflow: a block is summed folded (pair m with pair N − m, whose
//! references are conjugate): |xₘ ± x_(N−m)| ≤ 2¹⁶ times a Q15 reference is
//! below 2³¹ (an i32 product), and H ≤ 512 of them sum below 2⁴⁰ in i64.

use crate::tables::{SIN_BITS, SIN_Q31};
use crate::Complex32;

/// Nuttall's four-term window with a continuous first derivative: highest
/// sidelobe −93.3 dB, falling 18 dB per octave; main lobe ±4 bins.
pub const NUTTALL: [f64; 4] = [0.355768, 0.487396, 0.144232, 0.012604];

/// Where the stop band begins, bins from the tone: at and beyond it the
/// window passes less than −92 dB into the tone's phasor (and into its
/// guards from 5.5 bins on).
pub const STOP_BAND_BINS: f32 = 4.5;

/// The most an interferer at least half a bin from the tone moves the
/// tone's phasor, per unit of the larger guard it leaves
/// ([`Reading::guards`]); 3.17 computed over Δ = ½…6 bins, rounded up.
pub const GUARD_BOUND: f32 = 3.2;

/// The guards' share of a steady tone: λ = −a₁/(2a₀).
const LAMBDA: f32 = (-NUTTALL[1] / (2.0 * NUTTALL[0])) as f32;

/// Σw²/N of the window: a₀² + (a₁² + a₂² + a₃²)/2.
const POWER: f64 = NUTTALL[0] * NUTTALL[0]
    + (NUTTALL[1] * NUTTALL[1] + NUTTALL[2] * NUTTALL[2] + NUTTALL[3] * NUTTALL[3]) / 2.0;

/// Σw²·|e^(−jφ) − λ|²/N: the same for a guard with the tone's share
/// taken out, which cancels part of the noise both share:
/// (1 + λ²)·POWER − 2λ·Σw²cos φ/N, where Σw²cos φ/N is the cos φ
/// coefficient of w², −a₀a₁ − (a₁a₂ + a₂a₃)/2.
const GUARD_POWER: f64 = {
    let a = NUTTALL;
    let l = -a[1] / (2.0 * a[0]);
    let w2_cos = -a[0] * a[1] - (a[1] * a[2] + a[2] * a[3]) / 2.0;
    (1.0 + l * l) * POWER - 2.0 * l * w2_cos
};

/// cos and sin of 2π·num/den (den a power of two dividing 2^SIN_BITS), from
/// the Q31 sine table, as f64.
const fn turn(num: usize, den: usize) -> (f64, f64) {
    let steps = 1 << SIN_BITS;
    let i = (num % den) * (steps / den);
    let s = SIN_Q31[i] as f64 / 2147483648.0;
    let c = SIN_Q31[(i + steps / 4) % steps] as f64 / 2147483648.0;
    (c, s)
}

/// round(x) into an i16 (|x| ≤ 32767 by construction).
const fn q15(x: f64) -> i16 {
    if x >= 0.0 {
        (x + 0.5) as i16
    } else {
        (x - 0.5) as i16
    }
}

/// Pack a (cos, sin) pair of Q15 values as the demodulator's words are.
const fn pack(c: i16, s: i16) -> u32 {
    (c as u16 as u32) | ((s as u16 as u32) << 16)
}

/// What every frequency's lock-in of one block length shares, for
/// n = 0..H of blocks of N = 2H pairs (the rest mirror them):
/// the rotation from a tone's bin to its guards, word n holding
/// round(32767·cos φₙ) in bits 0..16 and round(32767·sin φₙ) in bits 16..32,
/// φₙ = 2π·n/N (n > H: the conjugate of N − n); and the window itself,
/// round(65535·w(n)) (n > H: that of N − n), for the mean of a block
/// whose tone lies in DC's main lobe.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Basis<const H: usize> {
    rotation: [u32; H],
    window: [u16; H],
    /// Σw over the block, Q16.
    window_sum: i64,
}

impl<const H: usize> Basis<H> {
    /// The basis for blocks of 2H pairs; H a power of two up to 512
    /// (the Q31 sine table's resolution).
    pub const fn new() -> Self {
        assert!(
            H.is_power_of_two() && H >= 4 && 2 * H <= 1 << SIN_BITS,
            "H: a power of two, 4..=512"
        );
        let mut rotation = [0u32; H];
        let mut window = [0u16; H];
        let mut window_sum = 65535;
        let mut n = 0;
        while n < H {
            let (c, s) = turn(n, 2 * H);
            rotation[n] = pack(q15(32767.0 * c), q15(32767.0 * s));
            let w = window_at(n, 2 * H);
            window[n] = (65535.0 * w + 0.5) as u16;
            window_sum += if n == 0 { 1 } else { 2 } * window[n] as i64;
            n += 1;
        }
        Self {
            rotation,
            window,
            window_sum,
        }
    }
}

/// w(n) of the window over N pairs.
const fn window_at(n: usize, n_total: usize) -> f64 {
    let a = NUTTALL;
    let (c1, _) = turn(n, n_total);
    let (c2, _) = turn(2 * n, n_total);
    let (c3, _) = turn(3 * n, n_total);
    a[0] - a[1] * c1 + a[2] * c2 - a[3] * c3
}

impl<const H: usize> Default for Basis<H> {
    fn default() -> Self {
        Self::new()
    }
}

/// A windowed lock-in at one frequency: its reference for blocks of
/// N = 2H pairs, and what a block of ones gives (to take the mean out).
#[derive(Clone, Debug, PartialEq)]
pub struct Lockin<const H: usize> {
    /// Word n: round(32767·w(n)·cos θₙ), round(32767·w(n)·sin θₙ), packed
    /// as [`Basis`]'s rotation, n = 0..H.
    half: [u32; H],
    /// The word of n = H (w = 1, θ = πk: sin is 0).
    middle: u32,
    basis: &'static Basis<H>,
    /// Periods of the tone per block.
    periods: u32,
    /// Re X of a block of ones (its imaginary part is 0 by symmetry).
    dc: i64,
    /// The guards of a block of ones, [+, −], Q15 · counts.
    guard_dc: [[i64; 2]; 2],
    /// What a tone of amplitude 1 and phase 0 gives the windowed mean
    /// (Σw·cos θ/Σw; a tone of phase ψ gives its real part's share).
    mean_leak: f32,
}

/// The references of the tone and of its guards at one folded pair m
/// (n = m and n = N − m): w·cos θ and w·sin θ (Q15, as stored) and
/// u₁ = w·cos(θ+φ), u₂ = w·sin(θ+φ), u₃ = w·cos(θ−φ), u₄ = w·sin(θ−φ),
/// rounded to Q15 from the Q30 products (`const`, so that a block of ones
/// is summed at compile time exactly as a block is at run time).
#[inline(always)]
const fn refs(r: u32, z: u32) -> [i32; 6] {
    let (rc, rs) = (r as i16 as i32, (r >> 16) as i16 as i32);
    let (zc, zs) = (z as i16 as i32, (z >> 16) as i16 as i32);
    [
        rc,
        rs,
        round15(rc * zc - rs * zs),
        round15(rc * zs + rs * zc),
        round15(rc * zc + rs * zs),
        round15(rc * zs - rs * zc),
    ]
}

/// A Q30 product rounded to Q15 (|x| < 2³¹ − 2¹⁴: two Q15 products).
#[inline(always)]
const fn round15(x: i32) -> i32 {
    (x + (1 << 14)) >> 15
}

/// One channel's sums over a block, folded: with s = xₘ + x_(N−m) and
/// d = xₘ − x_(N−m) (the reference of N − m is the conjugate of m's),
///
/// ```text
/// X  = Σ s·w cos θ − j Σ d·w sin θ
/// G₊ = Σ s·u₁      − j Σ d·u₂          (bin k + 1)
/// G₋ = Σ s·u₃      + j Σ d·u₄          (bin k − 1)
/// ```
///
/// (m = 0 and m = H have no partner: s = d = xₘ.) Each product is below
/// 2¹⁶·2¹⁵, so the i64 sums cannot overflow (H ≤ 512).
#[derive(Clone, Copy, Default)]
struct Sums([i64; 6]);

impl Sums {
    #[inline(always)]
    fn add(&mut self, s: i32, d: i32, u: &[i32; 6]) {
        let a = &mut self.0;
        // Widened before the product: one SMLAL each on a Cortex-M4 (the
        // product fits an i32 all the same, so the sums are those of
        // i32 products).
        a[0] += s as i64 * u[0] as i64;
        a[1] += d as i64 * u[1] as i64;
        a[2] += s as i64 * u[2] as i64;
        a[3] += d as i64 * u[3] as i64;
        a[4] += s as i64 * u[4] as i64;
        a[5] += d as i64 * u[5] as i64;
    }

    /// X, G₊ and G₋ as [re, im] (Q15 · counts, all three).
    const fn phasors(&self) -> [[i64; 2]; 3] {
        let a = &self.0;
        [[a[0], -a[1]], [a[2], -a[3]], [a[4], a[5]]]
    }
}

/// Why a block cannot be demodulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockLength {
    /// Pairs given.
    pub got: usize,
    /// Pairs the lock-in's blocks have.
    pub expected: usize,
}

/// One block through a [`Lockin`]: each channel's tone and guards, in ADC
/// counts (the complex amplitude: |v| is the tone's peak, arg v its phase
/// at the block's start).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reading {
    /// The voltage channel's tone, counts.
    pub v: Complex32,
    /// The current channel's tone, counts.
    pub i: Complex32,
    /// What lies near the tone and is not the tone: each channel's guards
    /// at k + 1 and k − 1, `[voltage, current]`, counts (module docs).
    pub guards: [[Complex32; 2]; 2],
    /// White noise of σ counts rms puts σ·`noise_gain` counts rms on each
    /// component of `v` and `i` (0.063 at N = 1024).
    pub noise_gain: f32,
    /// ... and σ·`guard_noise_gain` on each component of a guard (0.037
    /// at N = 1024: taking the tone's share out cancels part of it).
    pub guard_noise_gain: f32,
    /// Pairs summed.
    pub n: u32,
}

impl Reading {
    /// Amplitude of the voltage tone, counts (peak).
    pub fn v_amplitude(&self) -> f32 {
        crate::fmath::sqrt(self.v.norm_sqr())
    }

    /// Amplitude of the current tone, counts (peak).
    pub fn i_amplitude(&self) -> f32 {
        crate::fmath::sqrt(self.i.norm_sqr())
    }

    /// The larger guard of each channel, `[voltage, current]`, counts.
    pub fn near(&self) -> [f32; 2] {
        self.guards
            .map(|[p, m]| crate::fmath::sqrt(p.norm_sqr().max(m.norm_sqr())))
    }

    /// Impedance Z = k·V/I through `front_end` (Ω), or `None` if no current
    /// was measured.
    pub fn impedance(&self, front_end: &crate::demod::FrontEnd) -> Option<Complex32> {
        impedance(self.v, self.i, front_end)
    }

    /// The tone without its guards.
    pub fn phasors(&self) -> Phasors {
        Phasors {
            v: self.v,
            i: self.i,
            noise_gain: self.noise_gain,
            n: self.n,
        }
    }
}

impl<const H: usize> Lockin<H> {
    /// The lock-in for a tone of `periods` whole periods per block of
    /// N = 2H pairs, guarded through `basis`; computable at compile time
    /// (`static` puts the reference in flash). Panics (at compile time,
    /// in a `static`) unless 3 ≤ periods and periods + 2 ≤ H (both guards
    /// below Nyquist).
    pub const fn new(periods: u32, basis: &'static Basis<H>) -> Self {
        let rotation = &basis.rotation;
        assert!(periods >= 3 && periods as usize + 2 <= H, "periods: 3..=H-2");
        let n_total = 2 * H;
        let mut half = [0u32; H];
        let mut n = 0;
        while n < H {
            half[n] = Self::word(periods as usize, n, n_total);
            n += 1;
        }
        let middle = Self::word(periods as usize, H, n_total);
        let mut s = Self {
            half,
            middle,
            basis,
            periods,
            dc: 0,
            guard_dc: [[0; 2]; 2],
            mean_leak: 0.0,
        };
        // What a block of ones gives, by the same sums as a block: s = 2,
        // d = 0 for a folded pair, s = d = 1 at m = 0 and m = H.
        let mut ones = [0i64; 6];
        let mut m = 0;
        while m <= H {
            let r = if m == H { s.middle } else { s.half[m] };
            let z = if m == H { pack(-32767, 0) } else { rotation[m] };
            let u = refs(r, z);
            let (sum, diff) = if m == 0 || m == H { (1, 1) } else { (2, 0) };
            let mut c = 0;
            while c < 6 {
                ones[c] += (if c % 2 == 0 { sum } else { diff } * u[c]) as i64;
                c += 1;
            }
            m += 1;
        }
        let [x, gp, gm] = Sums(ones).phasors();
        s.dc = x[0];
        s.guard_dc = [gp, gm];
        let mut leak = 0.0;
        let mut n = 0;
        while n < n_total {
            let w = if n == H {
                65535
            } else if n < H {
                basis.window[n]
            } else {
                basis.window[n_total - n]
            };
            leak += w as f64 * turn(periods as usize * n, n_total).0;
            n += 1;
        }
        s.mean_leak = (leak / basis.window_sum as f64) as f32;
        s
    }

    /// The reference word of pair n.
    const fn word(k: usize, n: usize, n_total: usize) -> u32 {
        let w = window_at(n, n_total);
        let (c, s) = turn(k * n, n_total);
        pack(q15(32767.0 * w * c), q15(32767.0 * w * s))
    }

    /// Σw·x/Σw of each channel, counts. Once a block, so a function of
    /// its own (as [`Lockin::tone_of`]): the block's loop is compiled
    /// alone, whatever these become.
    #[inline(never)]
    fn windowed_means(&self, pairs: &[[i16; 2]]) -> [f32; 2] {
        let w = &self.basis.window;
        let (mut v, mut i) = (0i64, 0i64);
        let mut add = |&[x, y]: &[i16; 2], w: u16| {
            v += x as i64 * w as i64;
            i += y as i64 * w as i64;
        };
        // Pairs 0..H, H (w = 1), then H + 1..N mirroring 1..H: plain
        // loops (a chain of iterators costs a branch a pair).
        let (first, rest) = pairs.split_at(H.min(pairs.len()));
        for (p, &w) in first.iter().zip(w) {
            add(p, w);
        }
        if let Some((middle, second)) = rest.split_first() {
            add(middle, 65535);
            for (p, &w) in second.iter().zip(w[1..].iter().rev()) {
                add(p, w);
            }
        }
        let s = self.basis.window_sum as f32;
        [v as f32 / s, i as f32 / s]
    }

    /// Periods of the tone per block.
    pub const fn periods(&self) -> u32 {
        self.periods
    }

    /// Demodulate one block of `[voltage, current]` pairs (2H of them).
    pub fn block(&self, pairs: &[[i16; 2]]) -> Result<Reading, BlockLength> {
        if pairs.len() != 2 * H {
            return Err(BlockLength {
                got: pairs.len(),
                expected: 2 * H,
            });
        }
        let mut sums = [Sums::default(); 2];
        let ends = [
            (0, self.half[0], self.basis.rotation[0]),
            (H, self.middle, pack(-32767, 0)),
        ];
        for (m, r, z) in ends {
            let u = refs(r, z);
            let [v, i] = pairs[m];
            sums[0].add(v as i32, v as i32, &u);
            sums[1].add(i as i32, i as i32, &u);
        }
        let (first, second) = pairs[1..].split_at(H - 1);
        // Pair m (1..H) with pair N − m: the second half backwards.
        for (((&[v, i], &[v2, i2]), &r), &z) in first
            .iter()
            .zip(second[1..].iter().rev())
            .zip(&self.half[1..])
            .zip(&self.basis.rotation[1..])
        {
            let u = refs(r, z);
            let (v, v2, i, i2) = (v as i32, v2 as i32, i as i32, i2 as i32);
            sums[0].add(v + v2, v - v2, &u);
            sums[1].add(i + i2, i - i2, &u);
        }
        let means = self.means(pairs);
        let scale = Self::scale();
        let channel = |c: usize| {
            let [x, gp, gm] = sums[c].phasors();
            let (tone, mean) = self.tone_of(x, means, c);
            let guard = |g: [i64; 2], dc: [i64; 2]| {
                let g = Complex32::new(
                    g[0] as f32 - mean * dc[0] as f32,
                    g[1] as f32 - mean * dc[1] as f32,
                );
                g * scale - tone * LAMBDA
            };
            (tone, [guard(gp, self.guard_dc[0]), guard(gm, self.guard_dc[1])])
        };
        let (v, gv) = channel(0);
        let (i, gi) = channel(1);
        Ok(Reading {
            v,
            i,
            guards: [gv, gi],
            noise_gain: Self::noise_gain(),
            guard_noise_gain: crate::fmath::sqrt((2.0 * GUARD_POWER) as f32 / (2 * H) as f32)
                / NUTTALL[0] as f32,
            n: 2 * H as u32,
        })
    }

    /// The tone alone of one block (2H pairs): the same phasors
    /// [`Lockin::block`] gives, bit for bit, without the guards (a third
    /// of the work). For a second tone in the block, whose errors the
    /// model check of the two sees ([`crate::twotone`]).
    pub fn tone(&self, pairs: &[[i16; 2]]) -> Result<Phasors, BlockLength> {
        if pairs.len() != 2 * H {
            return Err(BlockLength {
                got: pairs.len(),
                expected: 2 * H,
            });
        }
        // [Σ s·w cos θ, Σ d·w sin θ] of each channel, as `Sums` has them.
        let mut sums = [[0i64; 2]; 2];
        for (m, r) in [(0, self.half[0]), (H, self.middle)] {
            let (rc, rs) = (r as i16 as i32, (r >> 16) as i16 as i32);
            let [v, i] = pairs[m];
            let (v, i) = (v as i64, i as i64);
            let (rc, rs) = (rc as i64, rs as i64);
            sums[0][0] += v * rc;
            sums[0][1] += v * rs;
            sums[1][0] += i * rc;
            sums[1][1] += i * rs;
        }
        let (first, second) = pairs[1..].split_at(H - 1);
        for ((&[v, i], &[v2, i2]), &r) in first.iter().zip(second[1..].iter().rev()).zip(&self.half[1..]) {
            let (rc, rs) = (r as i16 as i32, (r >> 16) as i16 as i32);
            let (v, v2, i, i2) = (v as i32, v2 as i32, i as i32, i2 as i32);
            let (rc, rs) = (rc as i64, rs as i64);
            // One SMLAL each (as `Sums::add`).
            sums[0][0] += (v + v2) as i64 * rc;
            sums[0][1] += (v - v2) as i64 * rs;
            sums[1][0] += (i + i2) as i64 * rc;
            sums[1][1] += (i - i2) as i64 * rs;
        }
        let means = self.means(pairs);
        let [v, i] = [0, 1].map(|c| self.tone_of([sums[c][0], -sums[c][1]], means, c).0);
        Ok(Phasors {
            v,
            i,
            noise_gain: Self::noise_gain(),
            n: 2 * H as u32,
        })
    }

    /// Tone and guards in counts from their sums: X·2/(32767·Σw), Σw = a₀·N.
    fn scale() -> f32 {
        2.0 / (32767.0 * NUTTALL[0] as f32 * (2 * H) as f32)
    }

    /// White noise of σ counts rms puts σ times this on each component of
    /// the tone's phasor.
    fn noise_gain() -> f32 {
        crate::fmath::sqrt((2.0 * POWER) as f32 / (2 * H) as f32) / NUTTALL[0] as f32
    }

    /// The block's windowed means, where the tone lies in DC's main lobe.
    ///
    /// The mean's share of X and of the guards: beyond its main lobe (4
    /// bins and more from DC) the window has none; within it (the tone's
    /// 3 periods: a₃/(2a₀) = 1.8 % of DC, and 9.8 % at the lower guard) it
    /// is taken out with the block's mean through the same window, which
    /// sees DC as the tone does and far energy not at all (the bare mean
    /// of an interferer of b bins and a counts is up to a/(πb)).
    fn means(&self, pairs: &[[i16; 2]]) -> Option<[f32; 2]> {
        (self.periods < 5).then(|| self.windowed_means(pairs))
    }

    /// Channel `c`'s tone (counts) from its sum X, and the block's mean
    /// (counts, 0 when not solved for).
    ///
    /// The tone and the mean see each other (real parts only, by the
    /// window's symmetry): Re X·scale = T + a·d and M = d + b·T, solved
    /// for the tone T and the mean d. In f32 (hardware floats on the
    /// Cortex-M4F; f64 was soft-float, 3 KiB of image): for 3 periods the
    /// mean's share of X (≈ 1.8 % of a bias of up to 2¹⁵ counts) can be
    /// 10³ times a weak tone's, so the cancellation costs ten bits of
    /// f32's 24: a 0.5-count tone on a 32 000-count bias reads within
    /// 3·10⁻⁴ counts of the f64 reference (`tests/lockin.rs`: a fifth of
    /// its bound; the samples' own rounding is 0.29 counts rms).
    #[inline(never)]
    fn tone_of(&self, x: [i64; 2], means: Option<[f32; 2]>, c: usize) -> (Complex32, f32) {
        let scale = Self::scale();
        let (re, mean) = match means {
            Some(m) => {
                let (a, b) = (self.dc as f32 * scale, self.mean_leak);
                let t = (x[0] as f32 * scale - a * m[c]) / (1.0 - a * b);
                (t, m[c] - b * t)
            }
            None => (x[0] as f32 * scale, 0.0),
        };
        (Complex32::new(re, x[1] as f32 * scale), mean)
    }
}

/// One tone of a block without its guards ([`Lockin::tone`]), in ADC
/// counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Phasors {
    /// The voltage channel's tone, counts.
    pub v: Complex32,
    /// The current channel's tone, counts.
    pub i: Complex32,
    /// White noise of σ counts rms puts σ·`noise_gain` counts rms on each
    /// component of `v` and `i`.
    pub noise_gain: f32,
    /// Pairs summed.
    pub n: u32,
}

impl Phasors {
    /// Amplitude of the voltage tone, counts (peak).
    pub fn v_amplitude(&self) -> f32 {
        crate::fmath::sqrt(self.v.norm_sqr())
    }

    /// Amplitude of the current tone, counts (peak).
    pub fn i_amplitude(&self) -> f32 {
        crate::fmath::sqrt(self.i.norm_sqr())
    }

    /// Impedance Z = k·V/I through `front_end` (Ω), or `None` if no
    /// current was measured.
    pub fn impedance(&self, front_end: &crate::demod::FrontEnd) -> Option<Complex32> {
        impedance(self.v, self.i, front_end)
    }
}

/// k·V/I, or `None` without a current.
fn impedance(v: Complex32, i: Complex32, front_end: &crate::demod::FrontEnd) -> Option<Complex32> {
    let d = i.norm_sqr();
    if d > 0.0 && d.is_finite() {
        Some(v * i.conj() / d * front_end.gain)
    } else {
        None
    }
}
