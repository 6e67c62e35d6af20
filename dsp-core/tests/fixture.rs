//! `fixture::Fixture::remove` against an f64 reference across its declared
//! range: the line behind a parasitic capacitance and contact resistance
//! comes back within 1e-5 relative (max) and 1e-6 (RMS); its slope
//! (`Fixture::slope`) within 1e-5 (max) and 2e-6 (RMS) of the f64
//! derivative; a tone's noise behind the wiring (`Fixture::take_out`)
//! within 1e-5 (max) and 2e-6 (RMS) of the f64 σ·|slope|, which the
//! noise of a Monte Carlo draw has.

mod common;
use common::continuous_ref;
use dsp_core::fixture::{Fixture, FixtureError};
use dsp_core::Complex32;
use num_complex::Complex64;
use std::f64::consts::TAU;

#[test]
fn removes_parasitic_capacitance_and_contacts_across_the_range() {
    let (mut worst, mut ss) = (0.0f64, 0.0f64);
    let points = declared_range();
    for &(f, zl, cp, rs, zm) in &points {
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
    }
    let rms = (ss / points.len() as f64).sqrt();
    println!("{} points: max {worst:.2e}, RMS {rms:.2e}", points.len());
    assert!(points.len() > 3000, "{}", points.len());
    assert!(worst < 1e-5, "max {worst}");
    assert!(rms < 1e-6, "RMS {rms}");
}

/// Every point of the declared range where the line keeps at least 10 %
/// of the measured admittance: (f Hz, the line's Z, C_p F, R_s Ω, the
/// measured Z).
fn declared_range() -> Vec<(f64, Complex64, f64, f64, Complex64)> {
    let mut out = vec![];
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
                        let y = (zl + rs).inv() + Complex64::new(0.0, w * cp);
                        if rs > zl.norm() || (zl + rs).inv().norm() < 0.1 * y.norm() {
                            continue;
                        }
                        out.push((f, zl, cp, rs, y.inv()));
                    }
                }
            }
        }
    }
    out
}

#[test]
fn the_slope_behind_the_wiring_is_the_f64_derivative() {
    let (mut worst, mut ss) = (0.0f64, 0.0f64);
    let points = declared_range();
    for &(f, _, cp, rs, zm) in &points {
        let w = TAU * f;
        // The f64 reference: d/dZ of 1/(1/Z − jωC_p) − R_s, by its
        // central difference (checked against the closed form).
        let behind = |z: Complex64| (z.inv() - Complex64::new(0.0, w * cp)).inv() - rs;
        let h = zm * 1e-6;
        let numeric = (behind(zm + h) - behind(zm - h)) / (h * 2.0);
        let zy = zm * (zm.inv() - Complex64::new(0.0, w * cp));
        let exact = (zy * zy).inv();
        assert!(
            (numeric - exact).norm() < 1e-6 * exact.norm(),
            "{numeric} {exact}"
        );
        let fx = Fixture {
            parallel_farad: cp as f32,
            series_ohm: rs as f32,
        };
        let got = fx.slope(Complex32::new(zm.re as f32, zm.im as f32), f as f32);
        let e = (Complex64::new(got.re as f64, got.im as f64) - exact).norm() / exact.norm();
        worst = worst.max(e);
        ss += e * e;
    }
    let rms = (ss / points.len() as f64).sqrt();
    println!("{} points: max {worst:.2e}, RMS {rms:.2e}", points.len());
    assert!(points.len() > 3000);
    assert!(worst < 1e-5, "max {worst}");
    assert!(rms < 2e-6, "RMS {rms}");
}

/// The σ `take_out` gives each tone behind the wiring against the f64
/// σ·|d(Z_line)/d(Z_meas)| across the declared range; and that this is
/// the noise's own σ there: round Gaussian noise on the measured
/// impedance, taken behind the wiring in f64, has that σ on each
/// component (5,000 draws at the points where the wiring grows it most
/// and least, within 5 % and with no correlation between the components
/// beyond 0.05).
#[test]
fn the_noise_behind_the_wiring_grows_with_its_slope() {
    use dsp_core::twotone::Tone;
    let (mut worst, mut ss) = (0.0f64, 0.0f64);
    let points = declared_range();
    let mut scales = vec![];
    for &(f, _, cp, rs, zm) in &points {
        let w = TAU * f;
        let zy = zm * (zm.inv() - Complex64::new(0.0, w * cp));
        let exact = 1.0 / zy.norm_sqr();
        let fx = Fixture {
            parallel_farad: cp as f32,
            series_ohm: rs as f32,
        };
        let mut tones = [Tone {
            z: Complex32::new(zm.re as f32, zm.im as f32),
            f_hz: f as f32,
            sigma_ohm: 1.0,
        }];
        fx.take_out(&mut tones).unwrap();
        let e = (tones[0].sigma_ohm as f64 - exact).abs() / exact;
        worst = worst.max(e);
        ss += e * e;
        scales.push((exact, f, cp, rs, zm));
    }
    let rms = (ss / points.len() as f64).sqrt();
    println!("{} points: max {worst:.2e}, RMS {rms:.2e}", points.len());
    assert!(points.len() > 3000);
    assert!(worst < 1e-5, "max {worst}");
    assert!(rms < 2e-6, "RMS {rms}");
    // The map is conformal: round noise stays round, scaled.
    scales.sort_by(|a, b| a.0.total_cmp(&b.0));
    let grows = scales.last().unwrap();
    assert!(
        grows.0 > 2.0,
        "the range holds a wiring that grows the noise: {}",
        grows.0
    );
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut gauss = move || {
        let mut u = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            ((rng >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (TAU * b).cos()
    };
    for &(scale, f, cp, rs, zm) in [scales[0], *grows].iter() {
        let w = TAU * f;
        let behind = |z: Complex64| (z.inv() - Complex64::new(0.0, w * cp)).inv() - rs;
        let sigma = 1e-5 * zm.norm();
        let z0 = behind(zm);
        let n = 5000;
        let (mut sre, mut sim, mut sx) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let d = behind(zm + Complex64::new(sigma * gauss(), sigma * gauss())) - z0;
            sre += d.re * d.re;
            sim += d.im * d.im;
            sx += d.re * d.im;
        }
        let (sd_re, sd_im) = ((sre / n as f64).sqrt(), (sim / n as f64).sqrt());
        let want = scale * sigma;
        println!(
            "scale {scale:.3}: σ re {:.4}, im {:.4} of σ·|slope|",
            sd_re / want,
            sd_im / want
        );
        assert!((sd_re / want - 1.0).abs() < 0.05 && (sd_im / want - 1.0).abs() < 0.05);
        assert!((sx / n as f64).abs() < 0.05 * want * want);
    }
}

#[test]
fn tones_behind_the_wiring_are_each_removed_or_none() {
    use dsp_core::twotone::Tone;
    let fx = Fixture {
        parallel_farad: 10e-12,
        series_ohm: 2e3,
    };
    let tone = |z: Complex32, f_hz: f32| Tone {
        z,
        f_hz,
        sigma_ohm: 7.0,
    };
    let tones = [
        tone(Complex32::new(3e5, -4e5), 250.0),
        tone(Complex32::new(2e5, -1e5), 1e3),
    ];
    let behind = fx.behind(&tones).unwrap();
    for (b, t) in behind.iter().zip(&tones) {
        assert_eq!((b.z, b.f_hz), (fx.remove(t.z, t.f_hz).unwrap(), t.f_hz));
        let scale = fx.slope(t.z, t.f_hz).norm();
        assert!((b.sigma_ohm / (7.0 * scale) - 1.0).abs() < 1e-5, "{b:?}");
    }
    // A tone the parasitic capacitance explains leaves none.
    let open = tone(Complex32::new(0.0, (-1.0 / (TAU * 1e3 * 5e-12)) as f32), 1e3);
    assert_eq!(fx.behind(&[tones[0], open]), Err(FixtureError::NothingLeft));
    // In place, the tones before the one that failed are taken out.
    let mut partly = [tones[0], open, tones[1]];
    assert_eq!(fx.take_out(&mut partly), Err(FixtureError::NothingLeft));
    assert_eq!([partly[0], partly[1], partly[2]], [behind[0], open, tones[1]]);
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
