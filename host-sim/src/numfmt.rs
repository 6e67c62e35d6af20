//! Numbers into the text of data files: the same bytes as Rust's `{}` and
//! `{:.N}`, several times faster.
//!
//! Rust's fixed-precision formatting (`{:.4}`) is exact, and pays for it:
//! most values go through a big-number algorithm (Dragon4), which made
//! formatting three quarters of replaying a recorded stream. Here a value
//! x with precision p is rounded as the integer nearest x·10ᵖ, formed in
//! f64: that product is within half an ulp of the exact one, so its
//! rounding is the exact one's unless it lies within an ulp of a half;
//! those rare values (and any beyond 2⁵², or not finite) go to `{:.N}`
//! itself: the same bytes. Shortest round-trip text comes from `ryu`,
//! written as `{}` writes it (no exponent, no trailing ".0"; where `ryu`
//! would use an exponent, `{}` writes it): as short as `{}`'s and reading
//! back to the same bits, though where two shortest texts are equally
//! near (2677396.25 as an f32: "2677396.2" or ".3") `ryu` takes the even
//! digit and `{}` the larger. `the_text_is_rusts_own` holds every function
//! to that.

use std::io::Write;

/// 10ᵖ for p = 0..=9, exact in f64.
const POW10: [u64; 10] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
];

/// Append `x` as `format!("{x:.prec$}")` would write it.
pub fn fixed(out: &mut Vec<u8>, x: f64, prec: usize) {
    if let Some(q) = scaled(x, prec) {
        if x.is_sign_negative() {
            out.push(b'-');
        }
        let mut ints = itoa::Buffer::new();
        if prec == 0 {
            out.extend_from_slice(ints.format(q).as_bytes());
            return;
        }
        let p = POW10[prec];
        out.extend_from_slice(ints.format(q / p).as_bytes());
        out.push(b'.');
        let frac = ints.format(q % p).as_bytes();
        out.resize(out.len() + prec - frac.len(), b'0');
        out.extend_from_slice(frac);
    } else {
        // Exact ties and near-ties, huge values, NaN and infinities.
        let _ = write!(out, "{x:.prec$}");
    }
}

/// round(|x|·10ᵖ) when the f64 product rounds as the exact one does.
fn scaled(x: f64, prec: usize) -> Option<u64> {
    let p = *POW10.get(prec)? as f64;
    let y = x.abs() * p;
    // Finite and below 2⁵²: every integer and half is representable.
    if y.is_nan() || y >= 4_503_599_627_370_496.0 {
        return None;
    }
    let floor = y.floor();
    let frac = y - floor;
    // |y − exact| ≤ ulp(y)/2: decide only at least an ulp from the half.
    let ulp = (y * f64::EPSILON).max(f64::MIN_POSITIVE);
    if (frac - 0.5).abs() <= ulp {
        return None;
    }
    Some(floor as u64 + u64::from(frac > 0.5))
}

/// Append `x` as its shortest text that reads back to it, as `{}` writes
/// (module docs).
pub fn shortest(out: &mut Vec<u8>, x: f64) {
    shortest_of(out, x, x.fract() == 0.0, x.abs() < 1e15, x as i64);
}

/// Append the f32 `x` as [`shortest`] does an f64.
pub fn shortest_f32(out: &mut Vec<u8>, x: f32) {
    shortest_of(out, x, x.fract() == 0.0, x.abs() < 1e15, x as i64);
}

/// [`shortest`] of an f32 or f64 `x`, told whether it is `whole`, `small`
/// enough for an i64 (|x| < 10¹⁵) and its value `as_int` as one.
fn shortest_of<T>(out: &mut Vec<u8>, x: T, whole: bool, small: bool, as_int: i64)
where
    T: ryu::Float + std::fmt::Display + Copy + PartialEq + Into<f64>,
{
    let v: f64 = x.into();
    // Whole numbers (frequencies, counts) as integers: `{}`'s text.
    if whole && small && !(v == 0.0 && v.is_sign_negative()) {
        int(out, as_int);
        return;
    }
    if v.is_finite() {
        let mut b = ryu::Buffer::new();
        if push_plain(out, b.format_finite(x)) {
            return;
        }
    }
    let _ = write!(out, "{x}");
}

/// `ryu`'s text as `{}` writes it: false (nothing written) where it has
/// an exponent.
fn push_plain(out: &mut Vec<u8>, s: &str) -> bool {
    if s.contains('e') {
        return false;
    }
    out.extend_from_slice(s.strip_suffix(".0").unwrap_or(s).as_bytes());
    true
}

/// Append an integer.
pub fn int(out: &mut Vec<u8>, i: impl itoa::Integer) {
    out.extend_from_slice(itoa::Buffer::new().format(i).as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn text(f: impl FnOnce(&mut Vec<u8>)) -> String {
        let mut v = vec![];
        f(&mut v);
        String::from_utf8(v).unwrap()
    }

    /// Values a data file holds, and the ones that make formatting hard:
    /// any bit pattern, exact halves at every precision, and values one
    /// ulp either side of them.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>(),
            (-1e7f64..1e7),
            (-1e-3f64..1e-3),
            (any::<i32>(), 0usize..8, -1i64..=1).prop_map(|(k, p, d)| {
                let half = (k as f64 + 0.5) / POW10[p] as f64;
                f64::from_bits((half.to_bits() as i64 + d) as u64)
            }),
            (-100_000i64..100_000).prop_map(|k| k as f64),
            Just(1e15),
            Just(999_999_999_999_999.0),
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(-1e300),
            Just(5e-324),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200_000))]

        #[test]
        fn the_text_is_rusts_own(x in value(), prec in 0usize..=9) {
            prop_assert_eq!(text(|o| fixed(o, x, prec)), format!("{x:.prec$}"));
            let (ours, std) = (text(|o| shortest(o, x)), format!("{x}"));
            prop_assert_eq!(ours.len(), std.len(), "{} vs {}", ours, std);
            prop_assert!(ours.parse::<f64>().unwrap().to_bits() == x.to_bits() || x.is_nan(), "{}", ours);
            for y in [x as f32, f32::from_bits(x.to_bits() as u32)] {
                let (ours, std) = (text(|o| shortest_f32(o, y)), format!("{y}"));
                prop_assert_eq!(ours.len(), std.len(), "{} vs {}", ours, std);
                prop_assert!(ours.parse::<f32>().unwrap().to_bits() == y.to_bits() || y.is_nan(), "{}", ours);
            }
        }
    }
}
