//! Sine and cosine of an `i32` phase.
//!
//! Phase convention (as in quartiq's idsp): one full turn is 2³², an `i32`
//! phase `p` stands for the angle θ = 2π·p/2³², so `i32::MIN` is −π and
//! wrapping addition is modulo 2π.
//!
//! Method: the table [`SIN_Q31`] holds sin at 1024 points per turn (read
//! from its first quarter turn, [`SIN_QUARTER_Q31`]: 1 KiB in an image,
//! not 4); the phase is rounded to the nearest entry θ₀ and the remainder
//! δ (|δ| ≤ π/1024) is applied by a second-order Taylor step,
//!
//! ```text
//! sin(θ₀+δ) ≈ s₀ + δ·(c₀ − δ·s₀/2),   cos(θ₀+δ) ≈ c₀ − δ·(s₀ + δ·c₀/2)
//! ```
//!
//! whose truncation error is below δ³/6 ≈ 4.9·10⁻⁹ of full scale; with the
//! Q31 table rounding the total error is < 1·10⁻⁸ (tested against f64).
//!
//! Overflow: the intermediates c₀ − δ·s₀/2 and s₀ + δ·c₀/2 are narrowed to
//! i32. Their excursion grows with |δ|, so checking every table entry at
//! both extreme remainders covers all phases; the test
//! `intermediates_fit_i32` does exactly that.

#[cfg(doc)]
use crate::tables::SIN_Q31;
use crate::tables::{SIN_BITS, SIN_QUARTER_Q31};

/// π in Q29 (round(π·2²⁹)), to turn a phase remainder into radians.
const PI_Q29: i64 = 1_686_629_713;

/// Cosine and sine of `phase` (θ = 2π·phase/2³²), both Q31:
/// `cos θ ≈ c/2³¹`, `sin θ ≈ s/2³¹`, saturated to the `i32` range
/// (so +1 reads as `i32::MAX` and −1 as `i32::MIN`).
///
/// ```
/// let (c, s) = dsp_core::cossin::cossin(1 << 30); // +90°
/// assert!(c.abs() < 32 && s > i32::MAX - 32);
/// ```
#[inline]
pub fn cossin(phase: i32) -> (i32, i32) {
    const SHIFT: u32 = 32 - SIN_BITS;
    const MASK: usize = (1 << SIN_BITS) - 1;
    let p = phase as u32;
    // Nearest table index and the signed remainder, |rem| ≤ 2^(SHIFT-1).
    let idx = (p.wrapping_add(1 << (SHIFT - 1)) >> SHIFT) as usize & MASK;
    let rem = p.wrapping_sub((idx as u32) << SHIFT) as i32;
    // δ in radians, Q31: rem·2π/2³² ·2³¹ = rem·π; |δ| < 2^23, so i32.
    let d = ((rem as i64 * PI_Q29) >> 29) as i32;
    let (c0, s0) = at_point(idx);
    // All products are i32 × i32 (one SMULL each on Cortex-M4).
    let mul = |a: i32, b: i32, sh: u32| (a as i64 * b as i64) >> sh;
    let t = (c0 as i64 - mul(d, s0, 32)) as i32; // fits: see `intermediates_fit_i32`
    let u = (s0 as i64 + mul(d, c0, 32)) as i32;
    let s = s0 as i64 + mul(d, t, 31);
    let c = c0 as i64 - mul(d, u, 31);
    (sat32(c), sat32(s))
}

/// Sine of `phase`, Q31 (see [`cossin`]).
#[inline]
pub fn sin(phase: i32) -> i32 {
    cossin(phase).1
}

/// Sine (Q31) at the table point nearest `phase`: exactly
/// [`cossin`]`(phase).1` where `phase` is a whole multiple of 2³²/1024
/// (the phases of an oscillator with whole periods in 1024 samples or a
/// divisor of that), within π/1024 of the angle elsewhere: for a DAC
/// that plays such tones, a lookup and no interpolation.
///
/// ```
/// use dsp_core::cossin::{cossin, sin_nearest};
/// let p = 3 << 22; // 3/1024 of a turn
/// assert_eq!(sin_nearest(p), cossin(p).1);
/// ```
#[inline]
pub fn sin_nearest(phase: i32) -> i32 {
    const SHIFT: u32 = 32 - SIN_BITS;
    let idx = (phase as u32).wrapping_add(1 << (SHIFT - 1)) >> SHIFT;
    at_point(idx as usize).1
}

/// cos and sin at table point `idx` (of 2^SIN_BITS per turn, taken
/// modulo a turn), [`SIN_Q31`]'s values read from its first quarter:
/// with a = sin r and b = cos r (= sin of the quarter's other end) at
/// r = idx mod 256, each quadrant is a turn of (b, a) by a quarter.
#[inline]
fn at_point(idx: usize) -> (i32, i32) {
    const QUARTER: usize = 1 << (SIN_BITS - 2);
    let r = idx % QUARTER;
    let (a, b) = (SIN_QUARTER_Q31[r], SIN_QUARTER_Q31[QUARTER - r]);
    match (idx / QUARTER) % 4 {
        0 => (b, a),
        1 => (neg(a), b),
        2 => (neg(b), neg(a)),
        _ => (a, neg(b)),
    }
}

/// −x, with −1 (i32::MAX in the table) as the exact i32::MIN.
#[inline]
fn neg(x: i32) -> i32 {
    (-x) - (x == i32::MAX) as i32
}

#[inline]
fn sat32(x: i64) -> i32 {
    x.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tables::SIN_Q31;

    /// Sweep every 4099th phase over the full turn (1 M points) against f64.
    #[test]
    fn cossin_error_full_turn() {
        let (mut max, mut ss, mut n) = (0f64, 0f64, 0u64);
        let mut p: i64 = i32::MIN as i64;
        while p <= i32::MAX as i64 {
            let th = p as f64 / 2f64.powi(32) * 2.0 * core::f64::consts::PI;
            let (c, s) = cossin(p as i32);
            for e in [
                c as f64 / 2f64.powi(31) - th.cos(),
                s as f64 / 2f64.powi(31) - th.sin(),
            ] {
                max = max.max(e.abs());
                ss += e * e;
                n += 1;
            }
            p += 4099;
        }
        let rms = (ss / n as f64).sqrt();
        assert!(max < 1.0e-8, "max error {max:e}");
        assert!(rms < 3.0e-9, "rms error {rms:e}");
    }

    /// Every point read from the quarter turn is the full table's, cos
    /// and sin, over two turns (the index is taken modulo a turn).
    #[test]
    fn quarter_turn_reads_the_full_table() {
        const N: usize = 1 << SIN_BITS;
        for idx in 0..2 * N {
            let i = idx % N;
            assert_eq!(
                at_point(idx),
                (SIN_Q31[(i + N / 4) % N], SIN_Q31[i]),
                "point {idx}"
            );
        }
    }

    /// At the table's points the quarter-turn read is the full table's,
    /// bit for bit; between them, the nearest point's sine: within
    /// sin(π/1024) ≈ 3.07·10⁻³ of the angle's (checked over the turn
    /// against f64, every 4099th phase).
    #[test]
    fn sin_nearest_is_the_table_at_its_points() {
        for i in 0..1u32 << SIN_BITS {
            let p = (i << (32 - SIN_BITS)) as i32;
            assert_eq!(sin_nearest(p), SIN_Q31[i as usize], "point {i}");
            assert_eq!(sin_nearest(p), cossin(p).1, "point {i}");
        }
        let bound = (core::f64::consts::PI / 1024.0).sin() + 1e-9;
        let (mut max, mut ss, mut n) = (0f64, 0f64, 0u64);
        let mut p: i64 = i32::MIN as i64;
        while p <= i32::MAX as i64 {
            let th = p as f64 / 2f64.powi(32) * 2.0 * core::f64::consts::PI;
            let e = sin_nearest(p as i32) as f64 / 2f64.powi(31) - th.sin();
            max = max.max(e.abs());
            ss += e * e;
            n += 1;
            p += 4099;
        }
        let rms = (ss / n as f64).sqrt();
        assert!(max <= bound, "max error {max:e}");
        assert!(rms < 1.8e-3, "rms error {rms:e}");
    }

    /// Exhaustive proof that the i32 intermediates cannot overflow.
    #[test]
    fn intermediates_fit_i32() {
        const SHIFT: u32 = 32 - SIN_BITS;
        const MASK: usize = (1 << SIN_BITS) - 1;
        for idx in 0..=MASK {
            for rem in [-(1i64 << (SHIFT - 1)), (1 << (SHIFT - 1)) - 1] {
                let d = (rem * PI_Q29) >> 29;
                let s0 = SIN_Q31[idx] as i64;
                let c0 = SIN_Q31[(idx + (1 << (SIN_BITS - 2))) & MASK] as i64;
                let t = c0 - ((d * s0) >> 32);
                let u = s0 + ((d * c0) >> 32);
                assert!(d.abs() < 1 << 23);
                assert!(
                    i32::try_from(t).is_ok() && i32::try_from(u).is_ok(),
                    "idx {idx} rem {rem}"
                );
            }
        }
    }

    #[test]
    fn cossin_edges() {
        assert_eq!(cossin(0), (i32::MAX, 0));
        // −1 is exactly representable in Q31.
        assert_eq!(cossin(i32::MIN), (i32::MIN, 0));
        let (c, s) = cossin(i32::MAX);
        assert!(c < -i32::MAX + 8 && s.abs() < 8);
        let (c, s) = cossin(-(1 << 30));
        assert!(c.abs() < 8 && s == i32::MIN);
    }
}
