//! The fixed-point line models against f64 references, over the whole
//! declared range (n = 1..=64, x = ωRC ∈ [X_MIN, X_MAX]).
//!
//! References are computed independently of the kernels: the ladder by the
//! impedance (Möbius) recursion z ← R/n + 1/(jωC/n + 1/z), the continuous
//! line from num-complex's f64 `tanh`.

use dsp_core::tline::{LineModel, ModelError, N_MAX, X_MAX, X_MIN};
use num_complex::Complex64;

mod common;
use common::{continuous_ref, ladder_ref};
use proptest::prelude::*;

fn rel_err(got: dsp_core::Complex32, want: Complex64) -> f64 {
    (Complex64::new(got.re as f64, got.im as f64) - want).norm() / want.norm()
}

/// Log-spaced x over the declared range, plus both ends.
fn x_grid(points: usize) -> Vec<f64> {
    let (a, b) = ((X_MIN as f64).ln(), (X_MAX as f64).ln());
    (0..points)
        .map(|k| (a + (b - a) * k as f64 / (points - 1) as f64).exp())
        .map(|x| x as f32 as f64)
        .collect()
}

#[test]
fn ladder_within_1e4_over_whole_range() {
    let (mut max, mut ss, mut cnt, mut worst) = (0f64, 0f64, 0u32, (0u8, 0f64));
    for n in 1..=N_MAX {
        for x in x_grid(400) {
            let got = LineModel::Ladder(n).zeta(x as f32).unwrap();
            let e = rel_err(got, ladder_ref(n as u32, x));
            if e > max {
                worst = (n, x);
            }
            max = max.max(e);
            ss += e * e;
            cnt += 1;
        }
    }
    let rms = (ss / cnt as f64).sqrt();
    println!(
        "ladder: rms {rms:.2e}, max {max:.2e} at n={}, x={:.4e}",
        worst.0, worst.1
    );
    assert!(max < 1e-4, "max {max:e} at {worst:?}");
    assert!(rms < 1e-5, "rms {rms:e}");
}

#[test]
fn continuous_within_1e4_over_whole_range() {
    let (mut max, mut ss, mut cnt, mut worst) = (0f64, 0f64, 0u32, 0f64);
    for x in x_grid(20_000) {
        let got = LineModel::Continuous.zeta(x as f32).unwrap();
        let e = rel_err(got, continuous_ref(x));
        if e > max {
            worst = x;
        }
        max = max.max(e);
        ss += e * e;
        cnt += 1;
    }
    let rms = (ss / cnt as f64).sqrt();
    println!("continuous: rms {rms:.2e}, max {max:.2e} at x={worst:.4e}");
    assert!(max < 1e-4, "max {max:e} at {worst}");
    assert!(rms < 1e-5, "rms {rms:e}");
}

/// Re ζ and Im ζ each against its own size, over the whole declared range
/// and every model: |ζ| alone would hide an error in Re ζ (what a meter
/// reports as Rs), which is 10⁻⁵ of |ζ| at x = 10⁻⁵.
#[test]
fn real_and_imaginary_parts_each_within_1e4() {
    let models = (1..=N_MAX)
        .map(|n| (LineModel::Ladder(n), n as u32))
        .chain([(LineModel::Continuous, 0)]);
    let (mut re_max, mut im_max, mut re_ss, mut im_ss, mut cnt) = (0f64, 0f64, 0f64, 0f64, 0u32);
    let mut worst = (LineModel::Continuous, 0f64);
    for (m, n) in models {
        for x in x_grid(600) {
            let want = if n == 0 {
                continuous_ref(x)
            } else {
                ladder_ref(n, x)
            };
            let got = m.zeta(x as f32).unwrap();
            let re = (got.re as f64 - want.re).abs() / want.re;
            let im = (got.im as f64 - want.im).abs() / want.im.abs();
            if re > re_max {
                worst = (m, x);
            }

            re_max = re_max.max(re);
            im_max = im_max.max(im);
            re_ss += re * re;
            im_ss += im * im;
            cnt += 1;
        }
    }
    let (re_rms, im_rms) = ((re_ss / cnt as f64).sqrt(), (im_ss / cnt as f64).sqrt());
    println!("Re ζ relative: rms {re_rms:.2e} max {re_max:.2e} (worst {worst:?}); Im ζ: rms {im_rms:.2e} max {im_max:.2e}");
    assert!(
        re_max < 1e-4 && im_max < 1e-4,
        "Re {re_max:e} at {worst:?}, Im {im_max:e}"
    );
    assert!(re_rms < 1e-5 && im_rms < 1e-5, "Re {re_rms:e}, Im {im_rms:e}");
}

/// The case of the report: 1 kΩ, 10 pF at 200 Hz through a 30-element
/// ladder (x = 1.26·10⁻⁵) gives Rs = R·(31·61)/(6·900) = 350.2 Ω.
#[test]
fn ladder_series_resistance_at_tiny_x() {
    let z = LineModel::Ladder(30).impedance(1e3, 10e-12, 200.0).unwrap();
    assert!((z.re / 350.185 - 1.0).abs() < 1e-4, "Rs = {} Ω", z.re);
}

#[test]
fn range_edges_are_errors_not_garbage() {
    assert_eq!(
        LineModel::Continuous.zeta(X_MIN * 0.99),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(
        LineModel::Continuous.zeta(X_MAX * 1.01),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(LineModel::Continuous.zeta(f32::NAN), Err(ModelError::OutOfRange));
    assert_eq!(LineModel::Ladder(0).zeta(1.0), Err(ModelError::BadElements));
    assert_eq!(LineModel::Ladder(65).zeta(1.0), Err(ModelError::BadElements));
    assert_eq!(
        LineModel::Continuous.impedance(-1.0, 1e-10, 1e3),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(
        LineModel::Continuous.impedance(1e3, 1e-10, 0.0),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(
        LineModel::Continuous.impedance(1e3, 1e-10, 50.1e3),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(
        LineModel::Continuous.impedance(999.0, 1e-10, 1e3),
        Err(ModelError::OutOfRange)
    );
    assert_eq!(
        LineModel::Continuous.impedance(1e3, 1.01e-9, 1e3),
        Err(ModelError::OutOfRange)
    );
    // The corners of the physical range evaluate.
    for (r, c, f) in [
        (1e3, 10e-12, 100.0),
        (10e6, 1e-9, 50e3),
        (1e3, 1e-9, 50e3),
        (10e6, 10e-12, 100.0),
    ] {
        assert!(LineModel::Ladder(64).impedance(r, c, f).is_ok());
        assert!(LineModel::Continuous.impedance(r, c, f).is_ok());
    }
    // Both ends of the range evaluate.
    for m in [LineModel::Ladder(1), LineModel::Ladder(64), LineModel::Continuous] {
        for x in [X_MIN, X_MAX] {
            assert!(m.zeta(x).unwrap().im < 0.0);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]
    /// Physical units: R 1 kΩ..10 MΩ, C 10 pF..1 nF, f 100 Hz..50 kHz.
    #[test]
    fn impedance_matches_reference(
        lr in (1e3f64).ln()..(1e7f64).ln(),
        lc in (1e-11f64).ln()..(1e-9f64).ln(),
        lf in (100f64).ln()..(5e4f64).ln(),
        n in 1u8..=64,
        cont in any::<bool>(),
    ) {
        let (r, c, f) = (lr.exp() as f32, lc.exp() as f32, lf.exp() as f32);
        let (model, want_zeta) = if cont {
            let x = (std::f32::consts::TAU * f * r * c) as f64;
            (LineModel::Continuous, continuous_ref(x))
        } else {
            let x = (std::f32::consts::TAU * f * r * c) as f64;
            (LineModel::Ladder(n), ladder_ref(n as u32, x))
        };
        let z = model.impedance(r, c, f).unwrap();
        let want = want_zeta / (2.0 * std::f64::consts::PI * f as f64 * c as f64);
        prop_assert!(rel_err(z, want) < 1e-4, "{} vs {}", z, want);
    }
}
