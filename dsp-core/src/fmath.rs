//! f32 functions that the Cortex-M4F computes in one instruction.
//!
//! IEEE-754 requires the square root to be correctly rounded, so the FPU's
//! `vsqrt.f32` and libm's `sqrtf` give the same bits: the host and the
//! target agree, and the target saves ~60 instructions a call.

/// √x, correctly rounded (NaN for x < 0).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(arm_fpu)]
    return arm::sqrt(x);
    #[cfg(not(arm_fpu))]
    return libm::sqrtf(x);
}

/// |a + jb| = √(a² + b²) by [`sqrt`], within 1.5 ulp everywhere: where
/// a² + b² neither overflows nor underflows f32 (|a|, |b| between about
/// 10⁻¹⁸ and 10¹⁹: every impedance in Ω and every normalized ζ) in about
/// ten instructions; beyond, scaled by powers of two first (exact), so
/// that no f64 arithmetic (libm's `hypotf`, a software library on the
/// Cortex-M4) is linked into the firmware.
#[inline]
pub fn hypot(a: f32, b: f32) -> f32 {
    let s = a * a + b * b;
    // Two float comparisons (a NaN fails the first, +∞ the second):
    // `is_finite` is an integer test of the bits besides.
    if (1e-36..=f32::MAX).contains(&s) {
        sqrt(s)
    } else {
        hypot_scaled(a, b)
    }
}

/// [`hypot`] outside the range of its squares: IEEE's special cases (an
/// infinite component gives +∞ even beside a NaN), then the larger
/// component brought to [1, 2) by a power of two, the squares summed
/// there and the power put back (each step exact but the last, which
/// rounds once if the result is subnormal).
#[cold]
#[inline(never)]
fn hypot_scaled(a: f32, b: f32) -> f32 {
    let (a, b) = (a.abs(), b.abs());
    if a == f32::INFINITY || b == f32::INFINITY {
        return f32::INFINITY;
    }
    if a.is_nan() || b.is_nan() {
        return f32::NAN;
    }
    let m = max(a, b);
    if m == 0.0 {
        return 0.0;
    }
    // Subnormals first up by 2³² (exact), so that m has an exponent.
    let (a, b, m, up) = if m < f32::MIN_POSITIVE {
        let k = pow2(32);
        (a * k, b * k, m * k, -32)
    } else {
        (a, b, m, 0)
    };
    // m = 2^e·[1, 2); the scale 2^−e in two halves (pow2's range).
    let e = ((m.to_bits() >> 23) as i32) - 127;
    let (d1, d2) = (-e / 2, -e - (-e / 2));
    let (x, y) = (a * pow2(d1) * pow2(d2), b * pow2(d1) * pow2(d2));
    let t = e + up;
    sqrt(x * x + y * y) * pow2(t / 2) * pow2(t - t / 2)
}

/// `x.is_finite() && x > 0.0` (NaN: false), on the bits: one integer
/// compare, where the compiler's version takes about 17 instructions on
/// the Cortex-M4. Positive finite f32 are the bit patterns 1..=0x7f7f_ffff.
#[inline]
pub fn positive_finite(x: f32) -> bool {
    x.to_bits().wrapping_sub(1) < 0x7f7f_ffff
}

/// x as f32 within 1.5 ulp, through two 32-bit conversions (one
/// instruction each on a Cortex-M4F) where `x as f32` is a library call
/// of about 50: |x| = hi·2³² + lo, both halves unsigned (no
/// cancellation), each converted (½ ulp of the sum at most) and the sum
/// rounded once more, then the sign.
#[inline]
pub fn i64_to_f32(x: i64) -> f32 {
    let a = x.unsigned_abs();
    let f = ((a >> 32) as u32 as f32) * 4_294_967_296.0 + (a as u32) as f32;
    if x < 0 {
        -f
    } else {
        f
    }
}

/// The larger of a and b, NaN passed over, as `f32::max`, in two
/// comparisons: on the Cortex-M4 (no `vmaxnm`) `f32::max` is a library
/// call of about 15 instructions.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if b > a || a.is_nan() {
        b
    } else {
        a
    }
}

/// The smaller of a and b, NaN passed over, as `f32::min` (see [`max`]).
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if b < a || a.is_nan() {
        b
    } else {
        a
    }
}

/// v limited to lo..=hi (lo ≤ hi), a NaN v passed through, as
/// `f32::clamp` without its check of the bounds (whose panic message
/// would link core's float formatting into the firmware).
#[inline]
pub fn clamp(v: f32, lo: f32, hi: f32) -> f32 {
    if v > hi {
        hi
    } else if v < lo {
        lo
    } else {
        v
    }
}

/// 2^e as f32 for e in −126..=127, exact (no library call).
#[inline]
pub fn pow2(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

#[cfg(arm_fpu)]
#[allow(unsafe_code)]
mod arm {
    /// `vsqrt.f32` in s0, declared clobbered (stable Rust does not yet
    /// name the FPU's register class on this target, but takes its
    /// registers as clobbers): three instructions, where saving and
    /// restoring s0 around it took five.
    #[inline(always)]
    pub fn sqrt(x: f32) -> f32 {
        let y: u32;
        // SAFETY: built only for hard-float Cortex-M4/M33 targets
        // (`arm_fpu`), whose FPU has `vsqrt.f32`; s0, the one register
        // written besides `y`, is declared clobbered.
        unsafe {
            core::arch::asm!(
                "vmov s0, {x}",
                "vsqrt.f32 s0, s0",
                "vmov {y}, s0",
                x = in(reg) x.to_bits(),
                y = lateout(reg) y,
                out("s0") _,
                options(pure, nomem, nostack),
            );
        }
        f32::from_bits(y)
    }
}

#[cfg(test)]
mod tests {
    /// max and min as f32's, NaN and infinities included (up to the sign
    /// of a zero, which f32's leave open).
    #[test]
    fn max_and_min_are_f32s() {
        let v = [
            f32::NAN,
            f32::NEG_INFINITY,
            -3.5,
            -0.0,
            0.0,
            1e-40,
            2.0,
            f32::MAX,
            f32::INFINITY,
        ];
        for a in v {
            for b in v {
                let same = |x: f32, y: f32| x == y || (x.is_nan() && y.is_nan());
                assert!(same(super::max(a, b), a.max(b)), "max {a} {b}");
                assert!(same(super::min(a, b), a.min(b)), "min {a} {b}");
                // clamp with ordered, non-NaN bounds: f32's.
                if !a.is_nan() && !b.is_nan() && a <= b {
                    for x in v {
                        assert!(same(super::clamp(x, a, b), x.clamp(a, b)), "clamp {x} {a} {b}");
                    }
                }
            }
        }
    }

    /// i64 → f32 within 1.5 ulp of the exact value (f64 holds the i64
    /// to 2⁻⁵³, far below an f32 ulp), across the range and at the
    /// carries between the halves; powers of two exact.
    #[test]
    fn i64_to_f32_is_within_one_and_a_half_ulp() {
        let mut worst = 0.0f64;
        let mut check = |x: i64| {
            let got = super::i64_to_f32(x) as f64;
            let want = x as f64;
            let a = (want as f32).abs();
            let ulp = (f32::from_bits(a.to_bits() + 1) - a) as f64;
            worst = worst.max((got - want).abs() / ulp);
        };
        for k in 0..63 {
            for d in [-3i64, -1, 0, 1, 3, 0x7fff_ffff, 0xffff_ffff, 0x1_0000_0001] {
                let x = (1i64 << k).wrapping_add(d);
                check(x);
                check(x.wrapping_neg());
            }
        }
        let mut x = 1u64;
        for _ in 0..200_000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            check(x as i64);
            check((x >> (x % 60)) as i64);
        }
        check(i64::MIN);
        check(i64::MAX);
        assert!(worst <= 1.5, "{worst} ulp");
        for e in -126..=127 {
            assert_eq!(super::pow2(e), 2f32.powi(e), "{e}");
        }
    }

    /// Against its definition on every bit pattern's neighbourhood that
    /// matters (0, subnormals, 1, the largest finite, ±∞, NaNs) and a
    /// sweep of the rest.
    #[test]
    fn positive_finite_is_finite_and_positive() {
        let check = |b: u32| {
            let x = f32::from_bits(b);
            assert_eq!(super::positive_finite(x), x.is_finite() && x > 0.0, "{b:#x}");
        };
        for edge in [
            0u32,
            1,
            0x007f_ffff,
            0x0080_0000,
            0x3f80_0000,
            0x7f7f_ffff,
            0x7f80_0000,
            0x7fc0_0000,
        ] {
            for b in edge.saturating_sub(3)..=edge.saturating_add(3) {
                check(b);
                check(b | 0x8000_0000);
            }
        }
        (0..=u32::MAX).step_by(997).for_each(check);
    }

    #[test]
    fn sqrt_is_libms_bit_for_bit() {
        let mut x = 1e-30f32;
        while x < 1e30 {
            assert_eq!(super::sqrt(x).to_bits(), libm::sqrtf(x).to_bits());
            x *= 1.0007;
        }
        assert!(super::sqrt(-1.0).is_nan());
        assert_eq!(super::sqrt(0.0), 0.0);
    }

    /// hypot against f64 across f32's whole range (both components from
    /// 10⁻⁴⁴ to 10³⁸, any ratio): within 1.5 ulp of the exact value, and
    /// never a spurious overflow or underflow.
    #[test]
    fn hypot_is_within_one_and_a_half_ulp_everywhere() {
        let mut worst = 0.0f64;
        let mut a = 1e-44f32;
        while a < 3e38 {
            let mut b = 1e-44f32;
            while b < 3e38 {
                for (x, y) in [(a, b), (-a, b), (a, -b)] {
                    let got = super::hypot(x, y) as f64;
                    let want = (x as f64).hypot(y as f64);
                    let ulp = (want as f32).abs().to_bits();
                    let ulp = (f32::from_bits(ulp + 1) - f32::from_bits(ulp)) as f64;
                    worst = worst.max((got - want).abs() / ulp);
                }
                b *= 3.7;
            }
            a *= 2.9;
        }
        assert!(worst <= 1.5, "{worst} ulp");
        assert_eq!(super::hypot(0.0, 0.0), 0.0);
        assert!(super::hypot(f32::NAN, 1.0).is_nan());
        assert_eq!(super::hypot(f32::INFINITY, 1.0), f32::INFINITY);
        assert_eq!(super::hypot(f32::NAN, f32::NEG_INFINITY), f32::INFINITY);
        assert_eq!(super::hypot(f32::MAX, f32::MAX), f32::INFINITY);
        assert_eq!(super::hypot(-f32::MAX, 0.0), f32::MAX);
        let tiny = f32::from_bits(1);
        assert_eq!(super::hypot(tiny, 0.0), tiny);
        assert_eq!(super::hypot(0.0, -tiny), tiny);
    }
}
