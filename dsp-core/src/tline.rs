//! Fixed-point R-C transmission-line model of a DE sensor read from one end.
//!
//! The sensor is a line of total electrode resistance R (top plus bottom
//! electrode, both in series as the current flows in through one tab and out
//! through the other) and total capacitance C, open at the far end (the
//! paper's Figure 5). Everything depends on R, C and ω only through the
//! dimensionless x = ωRC, so the kernels compute the normalized impedance
//!
//! ```text
//! ζ(x) = ωC·Z        (Z = ζ/(ωC), and ζ → −j for a pure capacitor)
//! ```
//!
//! * [`LineModel::Ladder`]`(n)`: n elements, each a series resistor R/n then
//!   a shunt capacitor C/n; n = 1 is the lumped series R-C.
//! * [`LineModel::Continuous`]: the uniform line, Z = √(R/(jωC))·coth √(jωRC).
//!
//! Declared range: n = 1..=64 and x ∈ [[`X_MIN`], [`X_MAX`]], which covers
//! R = 1 kΩ..10 MΩ, C = 10 pF..1 nF, f = 100 Hz..50 kHz. Over that range
//! the result is within 1·10⁻⁴ relative (|ζ − ζ_ref|/|ζ_ref|, max) of an f64
//! reference (tests in `tests/tline_accuracy.rs` state the measured bounds).
//!
//! # Ladder kernel (no division per element)
//! From the open end, with voltage v and current i (i in units of V/R), each
//! element applies `i += j(x/n)·v` (shunt) then `v += i/n` (series), starting
//! from v = 1, i = 0; then Z/R = v/i. Substituting q = i/√x makes both
//! steps multiplications by the same β = √x/n:
//!
//! ```text
//! q ← q + jβ·p,   p ← p + β·q,   ζ = √x · p/q
//! ```
//!
//! p and q are complex `i32` mantissas sharing one (discarded) block exponent:
//! a common scale cancels in p/q. β = m·2⁻ˢʰ with m ∈ [2³⁰, 2³¹).
//! * β < ½ (`sh ≥ 32`): each product is `smmulr(m', ·)`, m' = m·2⁻⁽ˢʰ⁻³²⁾
//!   rounded, so |β·a| ≤ |a|/2 + ½. Before an element all components are
//!   ≤ 2³⁰; after it |q| ≤ 1.5·2³⁰ + 1 and |p| ≤ 1.75·2³⁰ + 2 < 2³¹, and one
//!   right shift restores ≤ 2³⁰: no overflow is possible.
//! * β ≥ ½ (few elements at large x): products are taken in i64 and the
//!   block is renormalized to < 2³⁰ before each half step, so a product
//!   is below 2⁶¹ and a half step grows a component to below
//!   2³⁰·(1 + β) < 2³⁷ (β < 64). 30 bits matter: there Im ζ is a few
//!   10⁻³ of |ζ| and is what a meter reads as Cs.
//!
//! # Continuous kernel
//! For x ≤ 1 the series ζ = −j + x/3 − jx²/45 − 2x³/945 + … (to x⁸,
//! truncation < 10⁻⁸) in Q31/Q30 Horner form. For x > 1, with
//! a = √(x/2), E = e^(−2a) (fixed-point, table of 2^(−i/64) and a Taylor step) and the
//! table sine:
//!
//! ```text
//! ζ = a(1 − j)·coth(a + ja),
//! coth(a + ja) = ((1 − E²) − j·2E·sin 2a) / ((1 − E)² + 4E·sin²a)
//! ```
//!
//! where every term is bounded (0 < E < 0.25), so nothing overflows or
//! cancels. All products are of values below 2³¹ in magnitude: one
//! `SMULL`/`UMULL` each on Cortex-M4.

use crate::cossin::cossin;
#[cfg(feature = "ladder")]
use crate::fixed::split_f32;
use crate::fixed::{exp_neg_q31, sqrtf};
use crate::Complex32;
use core::f32::consts::TAU;

/// Smallest supported x = ωRC (2π·100 Hz·1 kΩ·10 pF ≈ 6.28·10⁻⁶, rounded down).
pub const X_MIN: f32 = 6.0e-6;
/// Largest supported x = ωRC (2π·50 kHz·10 MΩ·1 nF ≈ 3142, rounded up).
pub const X_MAX: f32 = 3200.0;
/// Supported electrode resistance R, Ω (inclusive).
pub const R_RANGE_OHM: (f32, f32) = (1e3, 10e6);
/// Supported line capacitance C, F (inclusive).
pub const C_RANGE_FARAD: (f32, f32) = (10e-12, 1e-9);
/// Supported excitation frequency, Hz (inclusive).
pub const F_RANGE_HZ: (f32, f32) = (100.0, 50e3);
/// Largest number of ladder elements.
pub const N_MAX: u8 = 64;

/// Which line model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineModel {
    /// An n-element R-C ladder, n = 1..=[`N_MAX`] (n = 1: lumped series R-C).
    Ladder(u8),
    /// The continuous uniform R-C line (the limit n → ∞).
    Continuous,
}

/// Why the model cannot be evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelError {
    /// Ladder with n = 0 or n > [`N_MAX`].
    BadElements,
    /// x = ωRC outside [[`X_MIN`], [`X_MAX`]], or an input not finite and positive.
    OutOfRange,
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ModelError::BadElements => write!(f, "a ladder needs 1 to {N_MAX} elements"),
            ModelError::OutOfRange => write!(
                f,
                "ωRC outside [{X_MIN:e}, {X_MAX}] or an input not finite and positive"
            ),
        }
    }
}

impl core::error::Error for ModelError {}

impl LineModel {
    /// Normalized impedance ζ = ωC·Z at x = ωRC (dimensionless).
    pub fn zeta(&self, x: f32) -> Result<Complex32, ModelError> {
        if !(X_MIN..=X_MAX).contains(&x) {
            return Err(ModelError::OutOfRange);
        }
        match *self {
            #[cfg(feature = "ladder")]
            LineModel::Ladder(n) if (1..=N_MAX).contains(&n) => Ok(ladder_zeta(n as u32, x)),
            // (Without the `ladder` feature, every ladder: an image that
            // reads only continuous lines keeps no ladder kernel.)
            LineModel::Ladder(_) => Err(ModelError::BadElements),
            LineModel::Continuous => Ok(continuous_zeta(x)),
        }
    }

    /// Input impedance (Ω) of a line with total electrode resistance
    /// `r_ohm` (Ω) and capacitance `c_farad` (F) at `f_hz` (Hz), each within
    /// its declared range ([`R_RANGE_OHM`], [`C_RANGE_FARAD`], [`F_RANGE_HZ`]).
    pub fn impedance(&self, r_ohm: f32, c_farad: f32, f_hz: f32) -> Result<Complex32, ModelError> {
        let within = |v: f32, (lo, hi): (f32, f32)| v >= lo && v <= hi;
        if !(within(r_ohm, R_RANGE_OHM) && within(c_farad, C_RANGE_FARAD) && within(f_hz, F_RANGE_HZ)) {
            return Err(ModelError::OutOfRange);
        }
        let w = TAU * f_hz;
        let x = (w * r_ohm * c_farad).clamp(X_MIN, X_MAX);
        let z = self.zeta(x)?;
        Ok(z / (w * c_farad))
    }

    /// Rs/R in the low-frequency limit: the fraction of the electrode
    /// resistance a series meter sees, (n+1)(2n+1)/(6n²) for a ladder and
    /// 1/3 for the continuous line.
    pub fn low_freq_resistance_fraction(&self) -> f32 {
        match *self {
            LineModel::Ladder(n) => {
                let n = n.max(1) as f32;
                (n + 1.0) * (2.0 * n + 1.0) / (6.0 * n * n)
            }
            LineModel::Continuous => 1.0 / 3.0,
        }
    }
}

/// Below this x the ladder is its series (see [`crate::tables::LADDER_SERIES`]):
/// the mantissa kernel's absolute error (≈ n·2⁻³⁰ of |ζ|) would swamp
/// Re ζ ≈ q1·x, the part a meter reports as Rs. The series' first omitted
/// term is O(x⁵): below 10⁻⁸ of |ζ| here.
pub const LADDER_SERIES_X: f32 = 0.02;

/// ζ of an n-element ladder; `n` in 1..=64, `x` in the declared range.
#[cfg(feature = "ladder")]
fn ladder_zeta(n: u32, x: f32) -> Complex32 {
    if x < LADDER_SERIES_X {
        let [q1, q2, q3, q4] = crate::tables::LADDER_SERIES[(n - 1) as usize];
        let x2 = x * x;
        return Complex32::new(x * (q1 - q3 * x2), -1.0 + x2 * (q2 - q4 * x2));
    }
    let sx = sqrtf(x);
    let (m, sh) = split_f32(sx / n as f32);
    let (p, q) = if sh >= 32 {
        ladder_small_beta(n, m, (sh - 32) as u32)
    } else {
        ladder_large_beta(n, m, sh as u32)
    };
    let p = Complex32::new(p[0] as f32, p[1] as f32);
    let q = Complex32::new(q[0] as f32, q[1] as f32);
    p * q.conj() * (sx / q.norm_sqr())
}

/// β = m·2^-(32+s) < ½ kernel; returns (p, q) as [re, im].
#[inline(never)]
#[cfg(feature = "ladder")]
fn ladder_small_beta(n: u32, m: u32, s: u32) -> ([i32; 2], [i32; 2]) {
    // m' = round(m / 2^s) ≤ 2^31 − 1 (m < 2^31): β = m'·2^-32.
    let mb = ((m as u64 + ((1u64 << s) >> 1)) >> s).min(i32::MAX as u64) as i32;
    // Knowing mb ≥ 0, LLVM would pick an unsigned multiply and sign fix-ups;
    // hiding that (once, outside the loop) lets it use one SMMULR.
    let mb = core::hint::black_box(mb);
    // round(β·a): one SMMULR on Cortex-M4.
    let mul = |a: i32| ((mb as i64 * a as i64 + 0x8000_0000) >> 32) as i32;
    let (mut pr, mut pi, mut qr, mut qi) = (1i32 << 29, 0i32, 0i32, 0i32);
    for _ in 0..n {
        qr -= mul(pi);
        qi += mul(pr);
        pr += mul(qr);
        pi += mul(qi);
        let big = (pr ^ (pr >> 31)) | (pi ^ (pi >> 31)) | (qr ^ (qr >> 31)) | (qi ^ (qi >> 31));
        if big >= 1 << 30 {
            pr >>= 1;
            pi >>= 1;
            qr >>= 1;
            qi >>= 1;
        }
    }
    ([pr, pi], [qr, qi])
}

/// β = m·2^-sh ≥ ½ kernel (sh in 25..=31); returns (p, q) as [re, im].
#[inline(never)]
#[cfg(feature = "ladder")]
fn ladder_large_beta(n: u32, m: u32, sh: u32) -> ([i32; 2], [i32; 2]) {
    // Components stay below 2^L before each half step: a product m·a is
    // below 2^(31+L) and a half step grows a component to below
    // 2^L·(1 + β) < 2^(L+7) (β < 64), both well inside i64. The final
    // renormalization leaves them below 2^30 for the i32 result.
    const L: u32 = 30;
    let m = m as i64;
    let mul = |a: i64| (m * a) >> sh;
    // Shift all four right so that every |component| < 2^L.
    let norm = |v: &mut [i64; 4]| {
        let big = v.iter().fold(0u64, |a, x| a | x.unsigned_abs());
        let bits = 64 - big.leading_zeros();
        if bits > L {
            v.iter_mut().for_each(|x| *x >>= bits - L);
        }
    };
    let mut v = [1i64 << (L - 1), 0, 0, 0]; // pr, pi, qr, qi
    for _ in 0..n {
        v[2] -= mul(v[1]);
        v[3] += mul(v[0]);
        norm(&mut v);
        v[0] += mul(v[2]);
        v[1] += mul(v[3]);
        norm(&mut v);
    }
    norm(&mut v);
    ([v[0] as i32, v[1] as i32], [v[2] as i32, v[3] as i32])
}

/// Q31 constant.
const fn q31(x: f64) -> i32 {
    (x * 2147483648.0 + if x < 0.0 { -0.5 } else { 0.5 }) as i32
}

/// ζ of the continuous line; `x` in the declared range.
pub(crate) fn continuous_zeta(x: f32) -> Complex32 {
    if x <= 1.0 {
        // u = x² in Q31 (x ≤ 1; the cast saturates x = 1 to 1 − 2⁻³¹).
        // u only scales the small corrections (≤ 2.3 % of the result), so
        // its f32 rounding (6·10⁻⁸) is harmless.
        let u = (x * x * 2147483648.0) as i32;
        // Horner in Q31 in v = u/2, one SMMUL (the product's high word)
        // and an add per term: the coefficient of uᵏ is stored times 2ᵏ.
        let h = |c: &[i32]| {
            c.iter()
                .rev()
                .fold(0i32, |acc, &k| k + ((acc as i64 * u as i64) >> 32) as i32)
        };
        // Re ζ / x = 1/3 − 2u/945 + 2u²/93555 − 4u³/18243225
        let re = h(&[
            q31(1.0 / 3.0),
            q31(-2.0 / 945.0 * 2.0),
            q31(2.0 / 93555.0 * 4.0),
            q31(-4.0 / 18243225.0 * 8.0),
        ]);
        // −Im ζ − 1 = u/45 − u²/4725 + 1382u³/638512875 − 3617u⁴/162820783125
        let im = h(&[
            0,
            q31(1.0 / 45.0 * 2.0),
            q31(-1.0 / 4725.0 * 4.0),
            q31(1382.0 / 638512875.0 * 8.0),
            q31(-3617.0 / 162820783125.0 * 16.0),
        ]);
        let s = 1.0 / 2147483648.0;
        return Complex32::new(x * (re as f32 * s), -1.0 - im as f32 * s);
    }
    let a = sqrtf(0.5 * x);
    // a < 40: Q25 fits in u32 (exact for a ≥ 2^-1: f32 has 24 mantissa bits).
    let a_q25 = (a * 33554432.0) as u32;
    let e = exp_neg_q31(a_q25.saturating_mul(2)) as i64; // E = e^(−2a), Q31
                                                         // Phase of a: a/(2π)·2^32 = a_q25 · (2^7/(2π)); K = round(2^7/(2π)·2^26).
    const K_Q26: u32 = 1_367_130_551;
    let ph = ((a_q25 as u64 * K_Q26 as u64) >> 26) as u32 as i32;
    let (ca, sa) = cossin(ph);
    let (ca, sa) = (ca as i64, sa as i64);
    let one = 1i64 << 31;
    let e2 = (e * e) >> 31;
    let ome = one - e;
    let nr = one - e2; // 1 − E², Q31
    let s2a = (sa * ca) >> 30; // sin 2a = 2·sin a·cos a, Q31
    let ni = -((e * s2a) >> 30); // −2E·sin 2a, Q31
    let sa2 = (sa * sa) >> 31;
    let d = ((ome * ome) >> 31) + ((e * sa2) >> 29); // (1−E)² + 4E·sin²a, Q31
                                                     // To f32 through 32 bits (one `vcvt` each, not a 64-bit library
                                                     // conversion): d < 5·2^31 as Q33 and 1 − E² ± 2E·sin 2a (between
                                                     // 0.45 and 1.5, E < 0.25 for x > 1) as Q30, their dropped bits
                                                     // below 2^-28 of each, under f32's rounding; f takes the scales.
    let f = 0.5 * a / (d >> 2) as u32 as f32;
    let q30 = |v: i64| (v >> 1) as i32 as f32;
    Complex32::new(f * q30(nr + ni), f * q30(ni - nr))
}
