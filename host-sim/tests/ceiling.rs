//! The information bound of a record (`host_sim::ceiling`): the f64
//! Cramér–Rao bound is the fit's own covariance where both read the same
//! tones, and the ceilings of the documented sensors are on
//! docs/accuracy.md.

use dsp_core::dielectric::Dielectric;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::twotone::{self, Tone};
use host_sim::ceiling::{information, markdown, rows, z_sigma, Line, FILM_SPREAD};
use instrument::array::Layout;
use num_complex::Complex32;
use skin_sim::array::ArrayFrontEnd;
use std::f64::consts::TAU;

/// The fit's σ of ln C and its one-tone bound (`dsp_core::twotone`, f32,
/// three tones, the film's loss within its prior) against the f64
/// bound, both given the same tones and noise, over the range the fit
/// reads: lines of 0.1–10 MΩ and 100–300 pF, the paper's tab leads or
/// none, the three lowest tones of either layout, wherever x = ωRC at
/// the highest stays within the inverter's 10. On a lossless film the
/// two are one computation (f32 against f64); on a film of tan δ 3·10⁻³
/// the fit's model takes the loss to first order (`dsp_core::twotone`),
/// the bound exactly. Measured: lossless, σ within 1·10⁻⁶ rms and
/// 2·10⁻⁵ at worst, h within 2·10⁻⁶ and 3·10⁻⁵ (bounds 10⁻⁵, 10⁻⁴);
/// lossy, σ 0.18 % and 0.68 %, h 0.33 % and 0.97 % (bounds 0.5 %, 1.5 %).
#[test]
fn the_fits_sigma_is_the_information_bound() {
    for (loss_tangent, rms, worst) in [(0.0, 1e-5, 1e-4), (3e-3, 5e-3, 1.5e-2)] {
        let (ds, dh) = fit_against_bound(loss_tangent);
        let (rms_s, max_s, _) = host_sim::numerics::rms_max(ds.iter().copied());
        let (rms_h, max_h, _) = host_sim::numerics::rms_max(dh.iter().copied());
        println!(
            "tan δ {loss_tangent}: {} lines: σ {:.4} % rms, {:.4} % worst; h {:.4} % rms, {:.4} % worst",
            ds.len(),
            100.0 * rms_s,
            100.0 * max_s,
            100.0 * rms_h,
            100.0 * max_h
        );
        assert!(ds.len() > 500, "{}", ds.len());
        assert!(rms_s < rms && max_s < worst, "σ: {rms_s} rms, {max_s} worst");
        assert!(rms_h < rms && max_h < worst, "h: {rms_h} rms, {max_h} worst");
    }
}

/// The relative differences of the fit's σ_lnC and h from the bound's,
/// over the range, on a film of `loss_tangent`.
fn fit_against_bound(loss_tangent: f64) -> (Vec<f64>, Vec<f64>) {
    let film = Dielectric {
        loss_tangent: loss_tangent as f32,
        spread: FILM_SPREAD as f32,
    };
    let (mut ds, mut dh) = (vec![], vec![]);
    for layout in Layout::ALL {
        let fe = ArrayFrontEnd::reference(layout);
        let hz = layout.tones_hz().map(f64::from);
        let volts = layout.tone_volts();
        for lead_ratio in [0.0, skin_sim::sensor::SensorParams::PAPER.effects.lead_ratio()] {
            let inv =
                Inverter::with_leads(LineModel::Continuous, 10.0, lead_ratio).expect("the leads are valid");
            for i in 0..=40 {
                let r_ohm = 1e5 * 100f64.powf(i as f64 / 40.0);
                for c_pf in [100.0, 150.0, 200.0, 250.0, 300.0] {
                    let line = Line {
                        r_ohm,
                        c_farad: c_pf * 1e-12,
                        lead_ratio: f64::from(lead_ratio),
                        loss_tangent,
                    };
                    if TAU * hz[2] * r_ohm * line.c_farad > 10.0 {
                        continue;
                    }
                    let three: Vec<(f64, f64)> = (0..3)
                        .map(|k| {
                            (
                                hz[k],
                                z_sigma(&fe, line.impedance(hz[k]), volts[k], layout.instants()),
                            )
                        })
                        .collect();
                    let want = information(&line, &three, FILM_SPREAD).expect("three tones inform");
                    let tones: Vec<Tone> = three
                        .iter()
                        .map(|&(f, sigma)| {
                            let z = line.impedance(f);
                            Tone {
                                z: Complex32::new(z.re as f32, z.im as f32),
                                f_hz: f as f32,
                                sigma_ohm: sigma as f32,
                            }
                        })
                        .collect();
                    let got =
                        twotone::solve(&inv, &film, &[tones[0], tones[1], tones[2]], line.c_farad as f32)
                            .expect("the fit solves a line of its model");
                    ds.push(f64::from(got.sigma_ln_c) / want.sigma_ln_c - 1.0);
                    dh.push(f64::from(got.hidden_ln_c) / want.hidden_ln_c - 1.0);
                }
            }
        }
    }
    (ds, dh)
}

/// The bound is the noise's: with the film known exactly, σ and h (per
/// unit of the error's share, itself in units of the noise) halve with
/// the tones' noise; a film
/// known to its spread never knows C better than one known exactly.
#[test]
fn the_bound_scales_as_the_noise_does() {
    let line = Line {
        r_ohm: 2e6,
        c_farad: 230e-12,
        lead_ratio: 0.05,
        loss_tangent: 3e-3,
    };
    let tones = |scale: f64| -> Vec<(f64, f64)> {
        [250.0, 500.0, 1000.0]
            .iter()
            .map(|&f| (f, 1e-3 * scale * line.impedance(f).norm()))
            .collect()
    };
    let a = information(&line, &tones(1.0), 0.0).unwrap();
    let b = information(&line, &tones(0.5), 0.0).unwrap();
    assert!((b.sigma_ln_c / a.sigma_ln_c - 0.5).abs() < 1e-9, "{a:?} {b:?}");
    assert!((b.hidden_ln_c / a.hidden_ln_c - 0.5).abs() < 1e-9, "{a:?} {b:?}");
    let spread = information(&line, &tones(1.0), FILM_SPREAD).unwrap();
    assert!(spread.sigma_ln_c > a.sigma_ln_c, "{spread:?} {a:?}");
}

/// The ceilings of the documented sensors, on docs/accuracy.md.
#[test]
fn the_ceilings_are_tabulated() {
    let rows = rows();
    figures::check("docs/accuracy.md", "array-ceiling", &markdown(&rows)).unwrap();
}
