//! micromath against libm for each f32 function on the device path (exp,
//! ln, sqrt, hypot: `libm::expf`, `logf`, `sqrtf`, `hypotf` in dsp-core
//! and the channel), both against f64, over the ranges the device uses
//! them on. The figures are the README's; the firmware's `dsp-bench`
//! counts each one's instructions on the Cortex-M4.
//!
//! Held here: libm within 2·10⁻⁷ relative (ln: 2·10⁻⁶ absolute)
//! everywhere; micromath within the bounds below (its ln is 0.12 off at
//! worst over this range, 0.04 at 10⁻¹², far from the 0.1 % its own tests
//! state near 1), which decide where it may serve:
//! the inversion needs C to 10⁻⁵ (its Gauss–Newton and D(x) roots take
//! ln and exp of quantities whose errors pass straight into C), a
//! policy's peak decay or a stretch table's interpolation only 10⁻².

use micromath::F32;

/// Relative error statistics of `f` against `reference` over `xs`: (RMS,
/// max). For ln the absolute error (an error of ln x is a relative error
/// of x; near x = 1 a relative error of ln x means nothing).
fn errors(xs: &[f64], f: impl Fn(f32) -> f32, reference: impl Fn(f64) -> f64) -> (f64, f64) {
    errors_as(xs, f, reference, false)
}

fn errors_as(
    xs: &[f64],
    f: impl Fn(f32) -> f32,
    reference: impl Fn(f64) -> f64,
    absolute: bool,
) -> (f64, f64) {
    let (mut ss, mut mx) = (0.0f64, 0.0f64);
    for &x in xs {
        let want = reference(x as f32 as f64);
        let got = f(x as f32) as f64;
        let e = if absolute || want == 0.0 {
            (got - want).abs()
        } else {
            (got - want).abs() / want.abs()
        };
        ss += e * e;
        mx = mx.max(e);
    }
    ((ss / xs.len() as f64).sqrt(), mx)
}

/// Log-spaced points from a to b, and `n` linear points where `linear`.
fn grid(a: f64, b: f64, n: usize, linear: bool) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let u = k as f64 / (n - 1) as f64;
            if linear {
                a + (b - a) * u
            } else {
                a * (b / a).powf(u)
            }
        })
        .collect()
}

#[test]
fn micromath_and_libm_against_f64_on_the_device_path() {
    let n = 20_001;
    // exp: the inversion's e^(ln R), e^(ln C) (|x| ≤ 30), the policy's
    // peak decay e^(−Δt/τ) (−10..0).
    let exp_x = grid(-30.0, 30.0, n, true);
    // ln: of R (10³–10⁷ Ω), C (10⁻¹¹–10⁻⁹ F), x = ωRC (10⁻⁵–10³), D.
    let ln_x = grid(1e-12, 1e7, n, false);
    let sqrt_x = grid(1e-12, 1e12, n, false);
    let hyp: Vec<f64> = grid(1e-3, 1e7, n, false);
    let rows = [
        (
            "exp",
            "−30..30",
            errors(&exp_x, |x| F32(x).exp().0, f64::exp),
            errors(&exp_x, libm::expf, f64::exp),
            (1e-2, 2e-7),
        ),
        (
            "ln (absolute)",
            "10⁻¹²..10⁷",
            errors_as(&ln_x, |x| F32(x).ln().0, f64::ln, true),
            errors_as(&ln_x, libm::logf, f64::ln, true),
            (0.15, 2e-6),
        ),
        (
            "sqrt",
            "10⁻¹²..10¹²",
            errors(&sqrt_x, |x| F32(x).sqrt().0, f64::sqrt),
            errors(&sqrt_x, libm::sqrtf, f64::sqrt),
            (1e-1, 1e-7),
        ),
        (
            "hypot",
            "(x, 1.7x), x 10⁻³..10⁷",
            errors(
                &hyp,
                |x| F32(x).hypot(F32(x * 1.7)).0,
                |x| x.hypot(x as f32 as f64 * 1.7f32 as f64),
            ),
            errors(
                &hyp,
                |x| libm::hypotf(x, x * 1.7),
                |x| x.hypot(x as f32 as f64 * 1.7f32 as f64),
            ),
            (1e-1, 2e-7),
        ),
    ];
    println!("| function | range | micromath RMS | micromath max | libm RMS | libm max |");
    println!("|---|---|---:|---:|---:|---:|");
    for (name, range, m, l, (m_bound, l_bound)) in rows {
        println!(
            "| {name} | {range} | {:.1e} | {:.1e} | {:.1e} | {:.1e} |",
            m.0, m.1, l.0, l.1
        );
        assert!(l.1 <= l_bound, "libm {name}: {}", l.1);
        assert!(m.1 <= m_bound, "micromath {name}: {}", m.1);
        // micromath's error is far above what the inversion may carry.
        assert!(
            m.1 > 1e-5,
            "micromath {name} is exact enough for the inversion: {}",
            m.1
        );
    }
}
