//! `fixture::Fixture::remove` against an f64 reference across its declared
//! range: the line behind a parasitic capacitance and contact resistance
//! comes back within 1e-5 relative (max) and 1e-6 (RMS).

mod common;
use common::continuous_ref;
use dsp_core::fixture::{Fixture, FixtureError};
use dsp_core::Complex32;
use num_complex::Complex64;
use std::f64::consts::TAU;

#[test]
fn removes_parasitic_capacitance_and_contacts_across_the_range() {
    let (mut worst, mut ss, mut n) = (0.0f64, 0.0f64, 0usize);
    let logs = |a: f64, b: f64, k: usize, i: usize| a * (b / a).powf(i as f64 / (k - 1) as f64);
    for ir in 0..9 {
        let r = logs(1e3, 10e6, 9, ir);
        for ic in 0..5 {
            let c = logs(10e-12, 1e-9, 5, ic);
            for jf in 0..7 {
                let f = logs(100.0, 50e3, 7, jf);
                let w = TAU * f;
                let zl = continuous_ref(w * r * c) / (w * c);
                for cp in [0.0, 1e-12, 10e-12, 100e-12] {
                    for rs in [0.0, 1e3, 50e3, 1e6] {
                        if rs > zl.norm() {
                            continue; // outside the declared range
                        }
                        let y = (zl + rs).inv() + Complex64::new(0.0, w * cp);
                        if (zl + rs).inv().norm() < 0.1 * y.norm() {
                            continue; // the line under 10 % of the admittance
                        }
                        let zm = y.inv();
                        let fx = Fixture {
                            parallel_farad: cp as f32,
                            series_ohm: rs as f32,
                        };
                        let got = fx
                            .remove(Complex32::new(zm.re as f32, zm.im as f32), f as f32)
                            .unwrap();
                        let e = (Complex64::new(got.re as f64, got.im as f64) - zl).norm() / zl.norm();
                        worst = worst.max(e);
                        ss += e * e;
                        n += 1;
                    }
                }
            }
        }
    }
    let rms = (ss / n as f64).sqrt();
    println!("{n} points: max {worst:.2e}, RMS {rms:.2e}");
    assert!(n > 3000, "{n}");
    assert!(worst < 1e-5, "max {worst}");
    assert!(rms < 1e-6, "RMS {rms}");
}

#[test]
fn no_fixture_is_the_identity_and_too_much_capacitance_is_an_error() {
    let z = Complex32::new(2.0e5, -1.3e5);
    assert_eq!(Fixture::NONE.remove(z, 6e3), Ok(z));
    // A 200 pF capacitor read as if 300 pF were parasitic: nothing left.
    let zc = Complex32::new(0.0, (-1.0 / (TAU * 1e3 * 200e-12)) as f32);
    let fx = Fixture {
        parallel_farad: 300e-12,
        series_ohm: 0.0,
    };
    assert_eq!(fx.remove(zc, 1e3), Err(FixtureError::NothingLeft));
}
