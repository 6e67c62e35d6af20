//! The two-tone line solve against the f64 reference line: the joint
//! (R, C) across the declared range, χ² as a chi-squared of 2 degrees of
//! freedom on a uniform line in noise, and the model check firing on what
//! a uniform line does not have (contacts, a parasitic capacitance).

mod common;
use common::{log_grid, rms_max, z_lossy, zeta_ref};
use dsp_core::dielectric::Dielectric;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::twotone::{
    bound_along, chi2_flag_of, hidden_along, solve, solve_from, z_sigma, Spread, Tone, CHI2_FLAG,
};
use dsp_core::Complex32;
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

/// The declared range: the higher tone at x = ωRC from 0.01 to 6 (the
/// policy keeps it ≤ 4), the lower one 2 to 8 times lower in frequency,
/// leads from none to the paper's sensor's (ℓ = 0.9).
const X_HI: (f64, f64) = (0.01, 6.0);
const RATIOS: [f64; 3] = [2.0, 4.0, 8.0];
const LEADS: [f64; 2] = [0.0, 0.9];

/// The reference impedance (Ω, f64) of a line R, C with leads ℓ at f, plus
/// `extra` (a contact's 2·R_c, or nothing), in parallel with `cp` (F).
fn z_ref(model: LineModel, lead: f64, r: f64, c: f64, f: f64, extra: f64, cp: f64) -> Complex64 {
    let w = TAU * f;
    let x = w * r * c;
    let z = (zeta_ref(model, x) + lead * x) / (w * c) + extra;
    if cp > 0.0 {
        1.0 / (1.0 / z + Complex64::new(0.0, w * cp))
    } else {
        z
    }
}

fn tone(z: Complex64, f: f64, sigma: f64) -> Tone {
    Tone {
        z: Complex32::new(z.re as f32, z.im as f32),
        f_hz: f as f32,
        sigma_ohm: sigma as f32,
    }
}

#[test]
fn the_joint_line_is_the_reference_line_across_the_range() {
    let (r, c) = (700e3, 210e-12);
    for model in [LineModel::Continuous, LineModel::Ladder(30)] {
        for lead in LEADS {
            let inv = Inverter::with_leads(model, 10.0, lead as f32).unwrap();
            let (mut ec, mut er, mut chi) = (vec![], vec![], 0.0f64);
            for x_hi in log_grid(X_HI.0, X_HI.1, 40) {
                for ratio in RATIOS {
                    let f_hi = x_hi / (TAU * r * c);
                    let f_lo = f_hi / ratio;
                    let tones = [f_lo, f_hi].map(|f| {
                        let z = z_ref(model, lead, r, c, f, 0.0, 0.0);
                        tone(z, f, 1e-4 * z.norm())
                    });
                    let s = solve(&inv, &Dielectric::IDEAL, &tones, 1.05 * c as f32)
                        .unwrap_or_else(|e| panic!("{model:?} ℓ {lead} x {x_hi} ratio {ratio}: {e}"));
                    ec.push(s.line.c_farad as f64 / c - 1.0);
                    er.push(s.line.r_ohm as f64 / r - 1.0);
                    chi = chi.max(s.chi2 as f64);
                    assert!((s.line.x as f64 / x_hi - 1.0).abs() < 1e-3);
                }
            }
            let ((c_rms, c_max), (r_rms, r_max)) = (rms_max(&ec), rms_max(&er));
            println!(
                "{model:?} ℓ = {lead}: C {c_rms:.1e} RMS / {c_max:.1e} max, R {r_rms:.1e} / {r_max:.1e}, χ² ≤ {chi:.1e}"
            );
            // f32 model and data: C within 2·10⁻⁵ RMS, 10⁻⁴ max; R within
            // 10⁻⁴ RMS, 10⁻³ max (at x = 0.01 the tones carry R in a
            // resistive part 10⁻³ of |Z|); exact data leave χ² ≪ 1.
            assert!(c_rms < 2e-5 && c_max < 1e-4, "C {c_rms} {c_max}");
            assert!(r_rms < 1e-4 && r_max < 1e-3, "R {r_rms} {r_max}");
            assert!(chi < 0.05, "χ² {chi}");
        }
    }
}

/// Noisy tones at f_hi/`below[k]` (x_hi at f_hi) at a relative 1σ `eps`
/// per component; returns the χ² of each draw, the errors of ln C and
/// the solver's σ of ln C.
#[allow(clippy::too_many_arguments)]
fn draws<const K: usize>(
    x_hi: f64,
    below: [f64; K],
    eps: f64,
    extra: f64,
    cp: f64,
    n: usize,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, f64) {
    let (r, c, lead) = (700e3, 210e-12, 0.0);
    let model = LineModel::Continuous;
    let inv = Inverter::with_leads(model, 10.0, lead as f32).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let f_hi = x_hi / (TAU * r * c);
    let (mut chi, mut lnc, mut sig) = (vec![], vec![], 0.0);
    for _ in 0..n {
        let tones = below.map(|b| {
            let f = f_hi / b;
            let z = z_ref(model, lead, r, c, f, extra, cp);
            let s = eps * z.norm();
            let (a, b) = (unit.sample(&mut rng), unit.sample(&mut rng));
            let zn = z + Complex64::new(s * a, s * b);
            tone(zn, f, s)
        });
        let s = solve(&inv, &Dielectric::IDEAL, &tones, c as f32).unwrap();

        chi.push(s.chi2 as f64);
        lnc.push((s.line.c_farad as f64 / c).ln());
        sig = s.sigma_ln_c as f64;
    }
    (chi, lnc, sig)
}

#[test]
fn chi2_of_a_uniform_line_in_noise_has_two_degrees_of_freedom() {
    for (k, (x_hi, ratio)) in [(0.3, 4.0), (2.0, 4.0), (4.0, 2.0), (4.0, 8.0)]
        .into_iter()
        .enumerate()
    {
        let n = 2000;
        let (chi, lnc, sigma) = draws(x_hi, [ratio, 1.0], 1e-3, 0.0, 0.0, n, 7 + k as u64);
        let mean = chi.iter().sum::<f64>() / n as f64;
        let flagged = chi.iter().filter(|&&v| v > CHI2_FLAG as f64).count();
        let m = lnc.iter().sum::<f64>() / n as f64;
        let sd = (lnc.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64).sqrt();
        println!("x {x_hi} ratio {ratio}: mean χ² {mean:.3}, flagged {flagged}/{n}, ln C sd {sd:.2e} vs σ {sigma:.2e}, bias {m:.1e}");
        // E χ² = 2 (sd of the mean of 2000: 0.045); P(χ² > 18.4) = 10⁻⁴,
        // 0.2 expected of 2000 (4 or more: 6·10⁻⁵).
        assert!((mean - 2.0).abs() < 0.15, "mean χ² {mean}");
        assert!(flagged <= 3, "{flagged} false flags");
        // The stated σ of ln C is the scatter's (within 10 %), unbiased.
        assert!((sd / sigma - 1.0).abs() < 0.1, "sd {sd} σ {sigma}");
        assert!(m.abs() < 4.0 * sd / (n as f64).sqrt() + 1e-5, "bias {m}");
    }
}

/// Three tones (the array's: the pair and the tone between them) leave
/// four degrees of freedom: E χ² = 4, flagged above
/// `chi2_flag_of(10⁻⁴, 3, ∞)` = 23.5 at the chance rate, σ of ln C the
/// scatter's.
#[test]
fn chi2_of_three_tones_has_four_degrees_of_freedom() {
    let flag = chi2_flag_of(1e-4, 3, 1_000_000) as f64;
    for (k, (x_hi, below)) in [
        (0.3, [4.0, 2.0, 1.0]),
        (3.0, [4.0, 2.0, 1.0]),
        (6.0, [3.0, 1.5, 1.0]),
    ]
    .into_iter()
    .enumerate()
    {
        let n = 2000;
        let (chi, lnc, sigma) = draws(x_hi, below, 1e-3, 0.0, 0.0, n, 17 + k as u64);
        let mean = chi.iter().sum::<f64>() / n as f64;
        let flagged = chi.iter().filter(|&&v| v > flag).count();
        let m = lnc.iter().sum::<f64>() / n as f64;
        let sd = (lnc.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64).sqrt();
        println!(
            "x {x_hi} {below:?}: mean χ² {mean:.3}, flagged {flagged}/{n}, ln C sd {sd:.2e} vs σ {sigma:.2e}"
        );
        // E χ² = 4 (sd of the mean of 2000: 0.063).
        assert!((mean - 4.0).abs() < 0.25, "mean χ² {mean}");
        assert!(flagged <= 3, "{flagged} false flags");
        assert!((sd / sigma - 1.0).abs() < 0.1, "sd {sd} σ {sigma}");
    }
}

#[test]
fn the_model_check_fires_on_contacts_and_parasitics_and_not_on_a_clean_line() {
    // A block's impedance to 10⁻⁴ (1024 pairs, 1000 counts of current,
    // 0.8 counts of noise give 5·10⁻⁵).
    let eps = 1e-4;
    for x_hi in [1.0, 2.0, 4.0] {
        let clean = draws(x_hi, [4.0, 1.0], eps, 0.0, 0.0, 200, 3).0;
        let contact = draws(x_hi, [4.0, 1.0], eps, 2.0 * 10e3, 0.0, 200, 3).0;
        let parasitic = draws(x_hi, [4.0, 1.0], eps, 0.0, 2e-12, 200, 3).0;
        let fired = |v: &[f64]| v.iter().filter(|&&c| c > CHI2_FLAG as f64).count();
        let median = |v: &[f64]| {
            let mut s = v.to_vec();
            s.sort_by(f64::total_cmp);
            s[s.len() / 2]
        };
        println!(
            "x {x_hi}: median χ² clean {:.1}, 2×10 kΩ contacts {:.0}, 2 pF parasitic {:.0}",
            median(&clean),
            median(&contact),
            median(&parasitic)
        );
        assert!(fired(&clean) == 0, "clean fired {}", fired(&clean));
        assert!(fired(&contact) >= 190, "contact fired {}", fired(&contact));
        assert!(fired(&parasitic) >= 190, "parasitic fired {}", fired(&parasitic));
    }
}

#[test]
fn the_noise_of_a_tone_follows_from_its_block() {
    // |Z| = 1 MΩ, 1024 pairs, 1000 and 500 counts, 0.8 counts each:
    // 1e6·√(2/1024)·0.8·√(1/1000² + 1/500²).
    let z = Complex32::new(6e5, -8e5);
    let s = z_sigma(z, 1024, 1000.0, 500.0, 0.8, 0.8);
    let expect = 1e6 * (2.0f64 / 1024.0).sqrt() * 0.8 * (1e-6f64 + 4e-6).sqrt();
    assert!((s as f64 / expect - 1.0).abs() < 1e-5, "{s} vs {expect}");
    assert!(z_sigma(z, 1024, 0.0, 500.0, 0.8, 0.8).is_infinite());
}

/// Tracking: from the previous record's line, 25 % off in R and in C, the
/// same joint line as from the single-tone inversions (within 10⁻⁵ of C,
/// 10⁻⁴ of R) across the declared range.
#[test]
fn a_tracked_start_converges_to_the_same_line() {
    let (r, c) = (700e3, 210e-12);
    let model = LineModel::Continuous;
    let inv = Inverter::with_leads(model, 10.0, 0.9).unwrap();
    let mut worst = (0f64, 0f64);
    for x_hi in log_grid(X_HI.0, X_HI.1, 25) {
        for ratio in RATIOS {
            let f_hi = x_hi / (TAU * r * c);
            let tones = [f_hi / ratio, f_hi].map(|f| {
                let z = z_ref(model, 0.9, r, c, f, 0.0, 0.0);
                tone(z, f, 1e-4 * z.norm())
            });
            let full = solve(&inv, &Dielectric::IDEAL, &tones, c as f32).unwrap();
            for (kr, kc) in [(1.25, 1.25), (0.75, 1.25), (1.25, 0.75), (0.75, 0.75)] {
                let t = solve_from(
                    &inv,
                    &Dielectric::IDEAL,
                    &tones,
                    (kr * r) as f32,
                    (kc * c) as f32,
                    0.0,
                )
                .unwrap_or_else(|e| panic!("x {x_hi} ratio {ratio} start {kr} {kc}: {e}"));
                let ec = (t.line.c_farad / full.line.c_farad - 1.0).abs() as f64;
                let er = (t.line.r_ohm / full.line.r_ohm - 1.0).abs() as f64;
                worst = (worst.0.max(ec), worst.1.max(er));
                assert!(
                    ec < 1e-5 && er < 1e-4,
                    "x {x_hi} ratio {ratio} start {kr} {kc}: C {ec}, R {er}"
                );
            }
        }
    }
    println!(
        "tracked start: C within {:.1e}, R within {:.1e} of the full solve",
        worst.0, worst.1
    );
    assert!(solve_from(
        &inv,
        &Dielectric::IDEAL,
        &[tone(Complex64::new(1e5, -1e6), 1e3, 10.0); 2],
        -1.0,
        1e-10,
        0.0
    )
    .is_err());
}

/// A lossy film: with its tan δ taken into the fit, the line comes back
/// as on a lossless one (C within 2·10⁻⁴, the first-order model's u²
/// term) and χ² stays at the noise's; ignored, tan δ = 10⁻² moves C by
/// 0.7 % and χ² far past the flag. With the loss fitted within the
/// silicone film's prior, a film 2σ (2·10⁻³) off the prior's mean reads
/// as 4 in χ² (the prior's residual) even on strong signals (σ 10⁻⁵ of
/// |Z|), and C stays as exact as with the loss known.
#[test]
fn a_lossy_film_is_fitted_with_its_loss() {
    let (r, c) = (700e3, 210e-12);
    let inv = |lead: f64| Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
    let lossy = |t: f64| Dielectric {
        loss_tangent: t as f32,
        spread: 0.0,
    };
    let (mut known, mut ignored, mut chi_known, mut chi_ignored) = (0f64, 0f64, 0f64, 0f64);
    let (mut off, mut chi_off) = (0f64, 0f64);
    for lead in LEADS {
        let inv = inv(lead);
        for tan_d in [1e-3, 3e-3, 1e-2] {
            for x_hi in log_grid(0.1, X_HI.1, 20) {
                for ratio in RATIOS {
                    let f_hi = x_hi / (TAU * r * c);
                    let at = |sigma: f64| {
                        [f_hi / ratio, f_hi].map(|f| {
                            let z = z_lossy(lead, r, c, f, tan_d);
                            tone(z, f, sigma * z.norm())
                        })
                    };
                    let tones = at(1e-4);
                    let k = solve(&inv, &lossy(tan_d), &tones, c as f32).unwrap();
                    known = known.max((k.line.c_farad as f64 / c - 1.0).abs());
                    chi_known = chi_known.max(k.chi2 as f64);
                    if let Ok(i) = solve(&inv, &Dielectric::IDEAL, &tones, c as f32) {
                        if tan_d == 1e-2 {
                            ignored = ignored.max((i.line.c_farad as f64 / c - 1.0).abs());
                            chi_ignored = chi_ignored.max(i.chi2 as f64);
                        }
                    }
                    // Assumed 2σ off, on strong signals, the loss fitted.
                    if tan_d < 1e-2 {
                        let d = Dielectric {
                            loss_tangent: (tan_d + 2e-3) as f32,
                            ..Dielectric::SILICONE
                        };
                        let s = solve(&inv, &d, &at(1e-5), c as f32).unwrap();
                        off = off.max((s.line.c_farad as f64 / c - 1.0).abs());
                        chi_off = chi_off.max(s.chi2 as f64);
                    }
                }
            }
        }
    }
    println!(
        "lossy film: C within {known:.1e} (χ² ≤ {chi_known:.2}) with its loss, {ignored:.1e} (χ² ≤ {chi_ignored:.0}) without; \
         2·10⁻³ off its assumed loss: C within {off:.1e}, χ² ≤ {chi_off:.2}"
    );
    assert!(
        known < 2e-4 && chi_known < 1.0,
        "known loss: C {known}, χ² {chi_known}"
    );
    assert!(
        ignored > 0.005 && chi_ignored > 1e3,
        "ignored loss: C {ignored}, χ² {chi_ignored}"
    );
    assert!(
        off < 2e-4 && chi_off < 5.0,
        "loss off by 2e-3: C {off}, χ² {chi_off}"
    );
}

/// What a one-tone perturbation can hide: a line read exactly but for one
/// tone pushed by ε (any direction, up to 20σ: an interferer at that
/// tone's frequency), fitted with the silicone film's loss free: C moves
/// by no more than `hidden_ln_c`·√χ² (to the fit's nonlinearity, 10 %,
/// and the joint line's own 10⁻⁴), across the declared range of x and
/// every tone, for two tones and for three.
#[test]
fn a_one_tone_perturbation_moves_c_by_at_most_what_chi2_allows() {
    let mut two = 0.0f64;
    for ratio in RATIOS {
        two = two.max(one_tone_pushes([ratio, 1.0]));
    }
    // A third tone between the two sees what one tone hides: the most C
    // can move per unit of √χ² is several times smaller.
    let three = one_tone_pushes([4.0, 2.0, 1.0]);
    println!("largest hidden_ln_c: two tones {two:.2e}, three {three:.2e}");
    assert!(three < 0.5 * two, "{three} vs {two}");
}

/// Every push of [`a_one_tone_perturbation_moves_c_by_at_most_what_chi2_allows`]
/// on tones at f_hi/`below[k]`; the largest `hidden_ln_c` met.
fn one_tone_pushes<const K: usize>(below: [f64; K]) -> f64 {
    let (r, c) = (700e3, 210e-12);
    let (mut worst, mut largest) = (0f64, 0f64);
    for lead in LEADS {
        let inv = Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
        for x_hi in log_grid(0.05, 5.0, 12) {
            let f_hi = x_hi / (TAU * r * c);
            for k in 0..K {
                for a in 0..12 {
                    let angle = TAU * a as f64 / 12.0;
                    let size = [2.0, 20.0][a % 2];
                    let mut tones = below.map(|b| {
                        let f = f_hi / b;
                        let z = z_lossy(lead, r, c, f, 3e-3);
                        tone(z, f, 1e-4 * z.norm())
                    });
                    let t = &mut tones[k];
                    let push =
                        Complex32::new(angle.cos() as f32, angle.sin() as f32) * (size as f32 * t.sigma_ohm);
                    t.z += push;
                    let s = solve(&inv, &Dielectric::SILICONE, &tones, c as f32).unwrap();
                    let e = (s.line.c_farad as f64 / c - 1.0).abs();
                    let bound = s.hidden_ln_c as f64 * (s.chi2 as f64).sqrt();
                    largest = largest.max(s.hidden_ln_c as f64);
                    if e > 1e-4 {
                        worst = worst.max(e / bound);
                    }
                    assert!(
                        e <= 1.1 * bound + 1e-4,
                        "ℓ {lead} x {x_hi:.2} {below:?} tone {k} ε {size}σ at {a}: C {e:.2e} > {bound:.2e} (χ² {})",
                        s.chi2
                    );
                }
            }
        }
    }
    println!("{below:?}: C error / (hidden·√χ²) ≤ {worst:.2} where C moved by more than 10⁻⁴");
    assert!(worst <= 1.1, "{worst}");
    largest
}

/// What one disturbance spread over every tone can hide
/// ([`hidden_along`]): on a line read exactly, a spread on one tone alone
/// gives that tone's one-tone bound, the worst of them
/// `hidden_ln_c` (to 10⁻³); and for spreads over every tone (each tone's
/// two quadratures drawn at random, up to 3σ), a push along a spread in
/// any of 72 directions moves C by at most the bound times √χ² (to 5 %
/// and 10⁻⁶: the fit's nonlinearity), and for the median spread the best
/// of them by at least 95 % of it (the bound is not loose; two tones and
/// the film's loss leave some spreads the fit can follow: an unbounded
/// spread); a push of unit amplitude moves C by |b| (`bound_along`'s
/// bound by the amplitude: at most, to 5 %, and at least 95 % of it in
/// the best direction); a spread given as a kernel and a factor per
/// tone (`Reach::along`, as the channels take it) gives the same
/// bound (three tones to 10⁻⁴; two, whose Q is what a near cancellation
/// leaves, to 6 % in f32). Across the declared range of x
/// and leads, two tones and three, the silicone film's loss fitted; and
/// somewhere a spread over the tones hides more than any one tone can.
#[test]
fn a_disturbance_spread_over_the_tones_moves_c_by_at_most_its_bound() {
    let mut beyond = 0f64;
    for ratio in RATIOS {
        beyond = beyond.max(spread_pushes([ratio, 1.0]));
    }
    beyond = beyond.max(spread_pushes([4.0, 2.0, 1.0]));
    println!("a spread hides up to {beyond:.2} times the one-tone bound");
    assert!(beyond > 1.5, "{beyond}");
}

/// A spread the line itself can make (a change of C and one of R, on
/// every tone) hides without bound: ∞; no spread, or a spread of
/// nothing, hides nothing: 0; a line out of the model's range: ∞.
#[test]
fn a_spread_the_line_can_follow_is_unbounded() {
    let (r, c, lead) = (700e3, 210e-12, 0.9);
    let film = Dielectric::SILICONE;
    let inv = Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
    let f_hi = 1.0 / (TAU * r * c);
    let z_at = |r: f64, c: f64, f: f64| z_lossy(lead, r, c, f, 3e-3);
    let tones = [4.0, 2.0, 1.0].map(|b| {
        let z = z_at(r, c, f_hi / b);
        tone(z, f_hi / b, 1e-4 * z.norm())
    });
    let at = solve(&inv, &film, &tones, c as f32).unwrap();
    let step = |z: Complex64| Complex32::new(z.re as f32, z.im as f32);
    let line: Spread<3> = core::array::from_fn(|k| {
        let f = tones[k].f_hz as f64;
        let z = z_at(r, c, f);
        [step(z_at(r, c * 1.001, f) - z), step(z_at(r * 1.001, c, f) - z)]
    });
    assert_eq!(hidden_along(&inv, &film, &tones, &at, [line]), f32::INFINITY);
    assert_eq!(hidden_along(&inv, &film, &tones, &at, []), 0.0);
    // One quadrature only (a disturbance of one phase): within the
    // tone's own bound.
    let mut one_phase = [[Complex32::new(0.0, 0.0); 2]; 3];
    one_phase[0][0] = Complex32::new(tones[0].sigma_ohm, 0.0);
    let h = hidden_along(&inv, &film, &tones, &at, [one_phase]);
    assert!(h > 0.0 && h <= 1.01 * at.hidden_ln_c, "{h} vs {}", at.hidden_ln_c);
    let nothing = [[Complex32::new(0.0, 0.0); 2]; 3];
    assert_eq!(hidden_along(&inv, &film, &tones, &at, [nothing]), 0.0);
    let mut beyond = at;
    beyond.line.r_ohm *= 1e4;
    assert_eq!(hidden_along(&inv, &film, &tones, &beyond, [line]), f32::INFINITY);
}

/// The pushes of [`a_disturbance_spread_over_the_tones_moves_c_by_at_most_its_bound`]
/// on tones at f_hi/`below[k]`; the most a spread's bound exceeded the
/// one-tone bound by.
fn spread_pushes<const K: usize>(below: [f64; K]) -> f64 {
    const DIRECTIONS: usize = 72;
    let (r, c) = (700e3, 210e-12);
    let film = Dielectric::SILICONE;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(55);
    let mut turns = rand_chacha::ChaCha8Rng::seed_from_u64(56);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let (mut beyond, mut bests, mut off) = (0f64, vec![], 0f64);
    for lead in LEADS {
        let inv = Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
        for x_hi in log_grid(0.05, 5.0, 10) {
            let f_hi = x_hi / (TAU * r * c);
            let tones = below.map(|b| {
                let f = f_hi / b;
                let z = z_lossy(lead, r, c, f, 3e-3);
                tone(z, f, 1e-4 * z.norm())
            });
            let at = solve(&inv, &film, &tones, c as f32).unwrap();
            let zero = Complex32::new(0.0, 0.0);
            let one_tone = |k: usize| -> f32 {
                let mut spread: Spread<K> = [[zero; 2]; K];
                let s = tones[k].sigma_ohm;
                spread[k] = [Complex32::new(s, 0.0), Complex32::new(0.0, s)];
                hidden_along(&inv, &film, &tones, &at, [spread])
            };
            let worst_one = (0..K).map(one_tone).fold(0f32, f32::max);
            let rel = (worst_one / at.hidden_ln_c - 1.0).abs();
            assert!(
                rel < 1e-2,
                "ℓ {lead} x {x_hi:.2} {below:?}: {worst_one} vs {}",
                at.hidden_ln_c
            );
            let spreads: Vec<Spread<K>> = (0..8)
                .map(|_| {
                    core::array::from_fn(|k| {
                        let s = tones[k].sigma_ohm * 3.0 * rng.gen::<f32>();
                        let mut draw = || Complex32::new(unit.sample(&mut rng), unit.sample(&mut rng)) * s;
                        [draw(), draw()]
                    })
                })
                .collect();
            let each: Vec<f32> = spreads
                .iter()
                .map(|b| hidden_along(&inv, &film, &tones, &at, [*b]))
                .collect();
            let all = hidden_along(&inv, &film, &tones, &at, spreads.iter().copied());
            assert_eq!(all, each.iter().copied().fold(0f32, f32::max));
            // A spread given as a kernel times each tone's factor (as
            // the channels take it: `instrument::spread`), the factor
            // turned into the reach once, gives the same bound (to 10⁻⁴
            // for three tones).
            let factor: [Complex32; 3] = core::array::from_fn(|_| {
                Complex32::from_polar(0.5 + turns.gen::<f32>(), TAU as f32 * turns.gen::<f32>())
            });
            let weights: [Complex32; 3] =
                core::array::from_fn(|k| factor[k] * tones.get(k).map_or(0.0, |t| 1.0 / t.sigma_ohm));
            let along = dsp_core::spread::reach(&inv, &film, &tones, &at).along(&weights);
            for (b, &h) in spreads.iter().zip(&each) {
                let kernel =
                    core::array::from_fn(|k| b.get(k).map_or([zero; 2], |q| q.map(|e| e / factor[k])));
                let own = along.bound(&kernel, 1.0, f32::INFINITY);
                off = off.max((own as f64 / h as f64 - 1.0).abs());
                // (Two tones leave Q the rest of a near cancellation, 4
                // measured numbers for 3 parameters: f32's rounding moves
                // it by some %, by another path to the same numbers.)
                let to = if K == 2 { 6e-2 } else { 1e-4 };
                assert!(
                    (own / h - 1.0).abs() < to || own == h,
                    "ℓ {lead} x {x_hi:.2} {below:?}: by kernel and factor {own} vs {h}"
                );
                if h.is_finite() {
                    beyond = beyond.max(h as f64 / worst_one as f64);
                }
                // Its amplitude at most 1 (a unit push): C moves by at
                // most |b|, bound_along's other bound.
                let by_size = bound_along(&inv, &film, &tones, &at, f32::INFINITY, [(*b, 1.0)]) as f64;
                assert_eq!(
                    bound_along(&inv, &film, &tones, &at, 2.0, [(*b, f32::INFINITY)]),
                    2.0 * h
                );
                let (mut best, mut most) = (0f64, 0f64);
                for d in 0..DIRECTIONS {
                    let angle = TAU * d as f64 / DIRECTIONS as f64;
                    let (ca, sa) = (angle.cos() as f32, angle.sin() as f32);
                    let mut pushed = tones;
                    for (t, q) in pushed.iter_mut().zip(b) {
                        t.z += q[0] * ca + q[1] * sa;
                    }
                    let s = solve(&inv, &film, &pushed, c as f32).unwrap();
                    let e = (s.line.c_farad as f64 / at.line.c_farad as f64).ln().abs();
                    let bound = h as f64 * (s.chi2 as f64).sqrt();
                    assert!(
                        e <= 1.05 * bound + 1e-6,
                        "ℓ {lead} x {x_hi:.2} {below:?} at {d}: C {e:.3e} > {bound:.3e}"
                    );
                    if bound > 0.0 {
                        best = best.max(e / bound);
                    }
                    most = most.max(e);
                }
                assert!(
                    most <= 1.05 * by_size + 1e-6 && most >= 0.95 * by_size,
                    "ℓ {lead} x {x_hi:.2} {below:?}: a unit push moved C by {most:.3e}, |b| {by_size:.3e}"
                );
                if h.is_finite() {
                    bests.push(best);
                }
            }
        }
    }
    // Not loose: in most spreads the best push reaches the bound (where
    // one does not, the film's prior, which the bound leaves out, sees
    // part of it).
    println!("{below:?}: a spread as kernel and factor is off bound_along's by {off:.1e} at most");
    bests.sort_by(f64::total_cmp);
    let median = bests[bests.len() / 2];
    println!(
        "{below:?}: the best push reaches {median:.3} of the bound (median), {:.3} at least",
        bests[0]
    );
    assert!(median >= 0.95, "{median}");
    beyond
}

/// Each tone's reach ([`dsp_core::twotone::Solution::tone_ln_c2`]): a
/// push of 2σ on one tone, in any of 24 directions, moves the fitted C
/// by at most √(reach)·2 (to 5 %: the fit's nonlinearity) and, in the
/// worst direction, by at least 90 % of it (a reach is not loose); pushes
/// on every tone at once move it by at most Σ_k √(reach_k)·2, which the
/// σ_lnC of the fit times the largest push, 2, does not bound. Across the
/// declared range of x, leads and tone ratios, two tones and three,
/// the silicone film's loss fitted.
#[test]
fn each_tones_reach_is_what_a_push_on_it_moves_c_by() {
    let mut beyond_sigma = 0f64;
    for ratio in RATIOS {
        beyond_sigma = beyond_sigma.max(pushes_within_reach([ratio, 1.0]));
    }
    beyond_sigma = beyond_sigma.max(pushes_within_reach([4.0, 2.0, 1.0]));
    println!("shared pushes: up to {beyond_sigma:.2} times σ_lnC·2");
    assert!(beyond_sigma > 1.2, "{beyond_sigma}");
}

/// The pushes of [`each_tones_reach_is_what_a_push_on_it_moves_c_by`] on
/// tones at f_hi/`below[k]`; the most a push on every tone moved C, over
/// σ_lnC·2.
fn pushes_within_reach<const K: usize>(below: [f64; K]) -> f64 {
    const SIZE: f32 = 2.0;
    let (r, c) = (700e3, 210e-12);
    let mut beyond_sigma = 0f64;
    for lead in LEADS {
        let inv = Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
        for x_hi in log_grid(0.05, 5.0, 12) {
            let f_hi = x_hi / (TAU * r * c);
            let tones = below.map(|b| {
                let f = f_hi / b;
                let z = z_lossy(lead, r, c, f, 3e-3);
                tone(z, f, 1e-4 * z.norm())
            });
            let at = solve(&inv, &Dielectric::SILICONE, &tones, c as f32).unwrap();
            let moved = |pushed: &[Tone; K]| {
                let s = solve(&inv, &Dielectric::SILICONE, pushed, c as f32).unwrap();
                (s.line.c_farad as f64 / at.line.c_farad as f64).ln().abs()
            };
            let reach = at.tone_ln_c2.map(|g2| (g2 as f64).sqrt());
            let unit = |a: usize| {
                let angle = TAU * a as f64 / 24.0;
                Complex32::new(angle.cos() as f32, angle.sin() as f32)
            };
            let push = |k: usize, a: usize| {
                let mut pushed = tones;
                pushed[k].z += unit(a) * (SIZE * pushed[k].sigma_ohm);
                let s = solve(&inv, &Dielectric::SILICONE, &pushed, c as f32).unwrap();
                (s.line.c_farad as f64 / at.line.c_farad as f64).ln()
            };
            // Each tone's direction that moves C up most.
            let mut up = [0usize; K];
            for k in 0..K {
                let bound = reach[k] * SIZE as f64;
                let moves: Vec<f64> = (0..24).map(|a| push(k, a)).collect();
                let most = moves.iter().fold(0f64, |m, e| m.max(e.abs()));
                assert!(
                    most <= 1.05 * bound + 0.05 * at.sigma_ln_c as f64,
                    "ℓ {lead} x {x_hi:.2} {below:?} tone {k}: {most:.3e} > {bound:.3e}"
                );
                assert!(
                    most >= 0.9 * bound,
                    "ℓ {lead} x {x_hi:.2} {below:?} tone {k}: {most:.3e} < {bound:.3e}"
                );
                up[k] = (0..24).max_by(|&a, &b| moves[a].total_cmp(&moves[b])).unwrap();
            }
            // Every tone pushed at once, each its way up.
            let mut pushed = tones;
            for k in 0..K {
                pushed[k].z += unit(up[k]) * (SIZE * pushed[k].sigma_ohm);
            }
            let e = moved(&pushed);
            let bound: f64 = reach[..K].iter().sum::<f64>() * SIZE as f64;
            assert!(
                e <= 1.05 * bound + 0.05 * at.sigma_ln_c as f64,
                "ℓ {lead} x {x_hi:.2} {below:?} all: {e:.3e} > {bound:.3e}"
            );
            beyond_sigma = beyond_sigma.max(e / (at.sigma_ln_c as f64 * SIZE as f64));
        }
    }
    beyond_sigma
}

/// The f64 optimum of the objective `refine` minimizes, for the
/// continuous line with leads ℓ on film `d`: the tones' weighted
/// residuals z/σ − (ζ + u·(ζ' − ζ))/(ωCσ), u = ln(1 − j·tan δ) (ζ' by
/// central differences of the reference, step 10⁻⁵ in ln x), and the
/// film's prior (t₀ − t)/σ_t; Gauss–Newton in (ln R, ln C, tan δ) with a
/// central-difference Jacobian to convergence. Returns (C, χ²).
fn optimum_f64(tones: &[Tone], lead: f64, d: &Dielectric, start: [f64; 3]) -> (f64, f64) {
    let fitted = d.spread > 0.0;
    let res = |p: &[f64; 3]| -> Vec<f64> {
        let (r, c, t) = (p[0].exp(), p[1].exp(), p[2]);
        let u = Complex64::new(1.0, -t).ln();
        let mut v = vec![];
        for tn in tones {
            let w = TAU * tn.f_hz as f64;
            let x = w * r * c;
            let zeta = |x: f64| zeta_ref(LineModel::Continuous, x) + lead * x;
            let h = 1e-5;
            let slope = (zeta(x * f64::exp(h)) - zeta(x * f64::exp(-h))) / (2.0 * h);
            let s = tn.sigma_ohm as f64;
            let m = (zeta(x) + u * (slope - zeta(x))) / (w * c * s);
            let z = Complex64::new(tn.z.re as f64, tn.z.im as f64) / s;
            v.push(z.re - m.re);
            v.push(z.im - m.im);
        }
        if fitted {
            v.push((d.loss_tangent as f64 - t) / d.spread as f64);
        }
        v
    };
    let n = if fitted { 3 } else { 2 };
    let mut p = start;
    for _ in 0..40 {
        let r0 = res(&p);
        let jac: Vec<Vec<f64>> = (0..n)
            .map(|k| {
                let h = if k == 2 { 1e-7 } else { 1e-6 };
                let (mut a, mut b) = (p, p);
                a[k] += h;
                b[k] -= h;
                let (ra, rb) = (res(&a), res(&b));
                ra.iter().zip(&rb).map(|(x, y)| -(x - y) / (2.0 * h)).collect()
            })
            .collect();
        // Normal equations JᵀJ·δ = −Jᵀr (J of the residual), by Gaussian
        // elimination.
        let mut m = vec![vec![0.0; n + 1]; n];
        for i in 0..n {
            for j in 0..n {
                m[i][j] = jac[i].iter().zip(&jac[j]).map(|(a, b)| a * b).sum();
            }
            m[i][n] = jac[i].iter().zip(&r0).map(|(a, b)| a * b).sum();
        }
        for i in 0..n {
            for k in i + 1..n {
                let f = m[k][i] / m[i][i];
                let pivot = m[i].clone();
                for (a, b) in m[k].iter_mut().zip(&pivot).skip(i) {
                    *a -= f * b;
                }
            }
        }
        let mut step = vec![0.0; n];
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| m[i][j] * step[j]).sum();
            step[i] = (m[i][n] - s) / m[i][i];
        }
        for k in 0..n {
            p[k] += step[k];
        }
    }
    let chi2 = res(&p).iter().map(|v| v * v).sum();
    (p[1].exp(), chi2)
}

/// A tracked solve that takes its last step without evaluating the model
/// (where the step's second-order term is under 0.03σ) lands where the
/// f64 optimum of the same objective is: C within 0.05σ of ln C (plus
/// 2·10⁻⁷, f32's evaluation) and χ² within 0.05·(1 + 2√χ²) (plus 10⁻³),
/// on noisy tones (10⁻⁴ and 10⁻³ of |Z|) across the declared range, both
/// films, with and without leads, from starts 0.3 % and 2 % off.
#[test]
fn a_tracked_solve_lands_on_the_f64_optimum() {
    let (r, c) = (700e3, 210e-12);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
    let (mut worst_c, mut worst_chi) = (0f64, 0f64);
    for film in [Dielectric::IDEAL, Dielectric::SILICONE] {
        for lead in LEADS {
            let inv = Inverter::with_leads(LineModel::Continuous, 10.0, lead as f32).unwrap();
            for x_hi in log_grid(0.05, X_HI.1, 9) {
                for ratio in RATIOS {
                    for eps in [1e-4, 1e-3] {
                        let f_hi = x_hi / (TAU * r * c);
                        let tones = [f_hi / ratio, f_hi].map(|f| {
                            let z = z_lossy(lead, r, c, f, film.loss_tangent as f64);
                            let s = eps * z.norm();
                            let n = Complex64::new(unit.sample(&mut rng), unit.sample(&mut rng)) * s;
                            tone(z + n, f, s)
                        });
                        let t0 = film.loss_tangent as f64;
                        let (c_ref, chi_ref) = optimum_f64(&tones, lead, &film, [r.ln(), c.ln(), t0]);
                        for off in [1.003, 1.02] {
                            let s = solve_from(
                                &inv,
                                &film,
                                &tones,
                                (r * off) as f32,
                                (c / off) as f32,
                                film.loss_tangent,
                            )
                            .unwrap();
                            let ec = (s.line.c_farad as f64 / c_ref).ln().abs();
                            let bound_c = 0.05 * s.sigma_ln_c as f64 + 2e-7;
                            let echi = (s.chi2 as f64 - chi_ref).abs();
                            let bound_chi = 0.05 * (1.0 + 2.0 * chi_ref.sqrt()) + 1e-3;
                            let what =
                                format!("{film:?} ℓ {lead} x {x_hi:.3} ratio {ratio} ε {eps} start {off}");
                            assert!(
                                ec <= bound_c,
                                "{what}: ln C off by {ec:.2e} (σ {:.2e})",
                                s.sigma_ln_c
                            );
                            assert!(echi <= bound_chi, "{what}: χ² {} vs {chi_ref}", s.chi2);
                            worst_c = worst_c.max(ec / s.sigma_ln_c as f64);
                            worst_chi = worst_chi.max(echi);
                        }
                    }
                }
            }
        }
    }
    println!("tracked solve against the f64 optimum: ln C within {worst_c:.3}σ, χ² within {worst_chi:.2e}");
}

/// Each tone's misfit to a solved line (`twotone::misfits`) against the
/// f64 distance of the tone from the reference impedance of that same
/// line (R and C as solved), in units of its σ (10⁻⁴ of |Z|): three tones
/// across the declared range (the highest at x from 0.01 to 6, the others
/// 2 and 4, or 4 and 8 times lower), both line models, leads none and the
/// paper's, one tone moved by 0, 3 or 30σ in a direction of its own.
/// Within 0.002σ RMS and 0.01σ at most.
#[test]
fn misfits_are_each_tones_distance_from_the_line() {
    use dsp_core::twotone::misfits;
    let (r, c) = (700e3, 210e-12);
    let mut err = vec![];
    let mut k = 0usize;
    for model in [LineModel::Continuous, LineModel::Ladder(30)] {
        for lead in LEADS {
            let inv = Inverter::with_leads(model, 10.0, lead as f32).unwrap();
            for x_hi in log_grid(X_HI.0, X_HI.1, 20) {
                for below in [[4.0, 2.0, 1.0], [8.0, 4.0, 1.0]] {
                    let f_hi = x_hi / (TAU * r * c);
                    let exact = below.map(|b| {
                        let z = z_ref(model, lead, r, c, f_hi / b, 0.0, 0.0);
                        tone(z, f_hi / b, 1e-4 * z.norm())
                    });
                    let s = solve(&inv, &Dielectric::IDEAL, &exact, c as f32).unwrap();
                    let (rs, cs) = (s.line.r_ohm as f64, s.line.c_farad as f64);
                    for m in [0.0, 3.0, 30.0] {
                        k += 1;
                        let mut tones = exact;
                        let j = k % 3;
                        let turn = k as f64 * 0.618_034 * TAU;
                        let sigma = tones[j].sigma_ohm as f64;
                        tones[j].z +=
                            Complex32::new((m * sigma * turn.cos()) as f32, (m * sigma * turn.sin()) as f32);
                        let got = misfits(&inv, &Dielectric::IDEAL, &tones, &s).unwrap();
                        for (t, g) in tones.iter().zip(got) {
                            let zt = Complex64::new(t.z.re as f64, t.z.im as f64);
                            let want = (zt - z_ref(model, lead, rs, cs, t.f_hz as f64, 0.0, 0.0)).norm()
                                / t.sigma_ohm as f64;
                            err.push(g as f64 - want);
                        }
                    }
                }
            }
        }
    }
    let (rms, max) = rms_max(&err);
    println!(
        "misfits: {rms:.2e} σ RMS, {max:.2e} σ max over {} tones",
        err.len()
    );
    assert!(rms < 2e-3 && max < 1e-2, "{rms} {max}");
}
