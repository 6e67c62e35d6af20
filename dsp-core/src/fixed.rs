//! Small fixed-point helpers shared by the line models.

use crate::tables::{EXP2_BITS, EXP2_NEG_Q31};

/// Split a positive normal `f32` into a mantissa in [2³⁰, 2³¹) and a right
/// shift: x = m·2^(−sh). Exact (a 24-bit f32 mantissa fits in 31 bits).
#[inline]
#[cfg(any(feature = "ladder", test))]
pub(crate) fn split_f32(x: f32) -> (u32, i32) {
    let b = x.to_bits();
    let e = ((b >> 23) & 0xff) as i32;
    let m = ((b & 0x7f_ffff) | 0x80_0000) << 7;
    (m, 157 - e)
}

/// e^(−t) for t = `t_q25`·2⁻²⁵ ∈ [0, 128), unsigned Q31 (2³¹ = 1.0).
///
/// e^(−t) = 2^(−t·log₂e) = 2^(−k)·2^(−i/64)·e^(−w) with the table
/// [`EXP2_NEG_Q31`] for 2^(−i/64) and a third-order Taylor series for e^(−w),
/// 0 ≤ w < ln2/64, whose truncation error is < w⁴/24 < 6·10⁻¹⁰. Total absolute
/// error < 3·10⁻⁹ (tested).
pub(crate) fn exp_neg_q31(t_q25: u32) -> u32 {
    const LOG2E_Q30: u32 = 1_549_082_005; // round(log2(e)·2^30)
    const LN2_Q32: u32 = 2_977_044_472; // round(ln(2)·2^32)
                                        // All products are u32 × u32 → u64 (one UMULL each on Cortex-M4).
    let mul = |a: u32, b: u32| a as u64 * b as u64;
    let u = mul(t_q25, LOG2E_Q30) >> 25; // t·log2(e), Q30, < 2^38
    let k = (u >> 30) as u32;
    if k >= 32 {
        return 0;
    }
    let f = (u & ((1 << 30) - 1)) as u32;
    let idx = (f >> (30 - EXP2_BITS)) as usize;
    let r = f & ((1 << (30 - EXP2_BITS)) - 1); // Q30, < 1/64
    let w = (mul(r, LN2_Q32) >> 31) as u32; // r·ln2, Q31, < 2^25
    let w2 = (mul(w, w) >> 31) as u32;
    let w3 = (mul(w2, w) >> 31) as u32;
    let p = (1u32 << 31) - w + (w2 >> 1) - w3 / 6; // e^(−w), Q31
    ((mul(EXP2_NEG_Q31[idx], p) >> 31) >> k) as u32
}

/// Correctly rounded √x (IEEE 754): the FPU's `vsqrt` where there is one
/// ([`crate::fmath::sqrt`]), `libm`'s software square root elsewhere: the
/// same bits either way.
#[inline]
pub(crate) fn sqrtf(x: f32) -> f32 {
    crate::fmath::sqrt(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_against_f64() {
        let (mut max, mut ss, mut n) = (0f64, 0f64, 0u32);
        let mut t = 0u64;
        while t < 128u64 << 25 {
            let got = exp_neg_q31(t as u32) as f64 / 2f64.powi(31);
            let want = (-(t as f64) / 2f64.powi(25)).exp();
            let e = got - want;
            max = max.max(e.abs());
            ss += e * e;
            n += 1;
            t += 12_345;
        }
        let rms = (ss / n as f64).sqrt();
        assert!(max < 3e-9, "max {max:e}");
        assert!(rms < 1e-9, "rms {rms:e}");
        assert_eq!(exp_neg_q31(0), 1 << 31);
        assert_eq!(exp_neg_q31(u32::MAX), 0);
    }

    #[test]
    fn split_is_exact() {
        for x in [3.9e-5f32, 0.5, 0.499_999_97, 1.0, 56.6, 63.99] {
            let (m, sh) = split_f32(x);
            assert!((1 << 30..1 << 31).contains(&m));
            assert_eq!(m as f64 * 2f64.powi(-sh), x as f64);
        }
    }
}
