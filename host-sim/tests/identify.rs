//! `identify` on data sets with an undeclared effect in them: one effect of
//! the library, chosen at random with a random strength, is switched on in
//! the simulated sensor or the simulated recording, and nothing tells
//! `identify` which.
//!
//! Over 50 seeds, in the sets where the effect is detectable (baseline RMS
//! above 1.5× the noise floor): the right effect is named in ≥ 90 %, the
//! error after is within 1.5× the noise floor, and where the baseline is
//! at least 7.5× the noise floor (so that a 5× drop can still end above
//! the noise) the error drops by ≥ 5×. Sets with no effect come out clean;
//! an effect outside the library (dielectric dispersion) is never called
//! explained (unexplained, or named with the remainder located);
//! the repository's example data set (`data/example`, rig-sim) comes out clean.

use host_sim::chain::Meter;
use host_sim::dataset::read_dir;
use host_sim::experiments::{dataset, with_effects};
use host_sim::identify::{identify, Options, Report, Verdict};
use host_sim::model::{Effect, EffectSet};
use indicatif::ProgressBar;
use skin_sim::rng::Rng;
use std::path::Path;

/// A hidden effect: the sensor's effects, the meter, and the truth.
fn hidden(effect: Effect, v: f64) -> (EffectSet, Meter) {
    let fx = EffectSet::NONE.with(effect, v);
    (fx, Meter::lcr(&fx))
}

/// [`hidden`], a bump placed and sized by `rng`: centred 0.1–0.9 along
/// the sensor, 0.25–0.8 of it wide at its foot.
fn hidden_with(effect: Effect, v: f64, rng: &mut Rng) -> (EffectSet, Meter) {
    let (fx, meter) = hidden(effect, v);
    if !Effect::BUMPS.contains(&effect) {
        return (fx, meter);
    }
    let fx = fx
        .with(Effect::BumpCentre, 0.1 + 0.8 * rng.uniform())
        .with(Effect::BumpWidth, log_uniform(0.25, 0.8, false, rng));
    (fx, meter)
}

/// Whether `named` is the right answer for `effect` at strength `v` (SI):
/// the effect itself, or, for a meter kernel whose centroid (T/2, τ) is
/// under one row interval (20 ms), the delay it causes (`time_offset`),
/// which is all the rows resolve of it (or any kernel, all of which it
/// reads as); for a profile along the sensor, any shape of the same
/// quantity (a wide bump is a mode to the data).
fn named_right(effect: Effect, v: f64, named: &[&str]) -> bool {
    let centroid = match effect {
        Effect::MeterLag => 0.5 * v,
        Effect::MeterResponse => v,
        Effect::MeterMean => 0.5 * (v - 1.0) * 0.02,
        Effect::MeterEwma => v / (1.0 - v) * 0.02,
        _ => f64::INFINITY,
    };
    // A bump is a profile of its quantity: a wide one reads as a mode.
    let shapes: &[&str] = match effect {
        Effect::StretchBump | Effect::StretchBulge | Effect::NonuniformStretch => {
            &["stretch_bump", "stretch_bulge", "nonuniform_stretch"]
        }
        Effect::ResistanceBump | Effect::ResistanceBulge | Effect::ResistanceGradient => {
            &["resistance_bump", "resistance_bulge", "resistance_gradient"]
        }
        _ => &[],
    };
    // A kernel shorter than a row: any kernel, or the delay.
    let kernels = [
        "meter_lag",
        "meter_response",
        "meter_mean",
        "meter_ewma",
        "time_offset",
    ];
    named == [effect.id()]
        || (centroid < 0.02 && named.len() == 1 && kernels.contains(&named[0]))
        || (!named.is_empty() && named.iter().all(|n| shapes.contains(n)))
}

/// A log-uniform magnitude in [lo, hi], with a random sign if `signed`.
fn log_uniform(lo: f64, hi: f64, signed: bool, rng: &mut Rng) -> f64 {
    let m = lo * (hi / lo).powf(rng.uniform());
    if signed && rng.uniform() < 0.5 {
        -m
    } else {
        m
    }
}

/// Random strength of `effect` (SI): log-uniform magnitude over a
/// range from barely to clearly detectable, random sign where it has one.
fn strength(effect: Effect, rng: &mut Rng) -> f64 {
    let (lo, hi, signed): (f64, f64, bool) = match effect {
        Effect::ContactResistance => (2e3, 50e3, false),
        Effect::ParasiticCapacitance => (0.5e-12, 20e-12, false),
        Effect::ResistanceGradient => (0.05, 0.6, true),
        // 5–100 nS on 200 pF.
        Effect::DielectricLeakage => (25.0, 500.0, false),
        Effect::MeterLag => (10e-3, 150e-3, false),
        Effect::MeterResponse => (10e-3, 150e-3, false),
        Effect::TimeOffset => (5e-3, 80e-3, true),
        Effect::NonuniformStretch => (0.05, 0.5, true),
        Effect::StretchBulge => (0.05, 0.4, true),
        Effect::ResistanceBulge => (0.05, 0.6, true),
        Effect::LeadResistance => (0.05, 0.5, false),
        Effect::ElectrodeDispersion => (3e-6, 100e-6, false),
        // 3–12 readings of 20 ms; a memory of 0.3–0.85 (τ of 0.4–5.7 rows).
        Effect::MeterMean => (3.0, 12.0, false),
        Effect::MeterEwma => (0.3, 0.85, false),
        // A stretch bump's peak within the calibration's reach (37 mm at
        // 30 mm, as the stretch bulge's); a patch 1.2–4 times the film's
        // mean resistance, or down to a fifth.
        Effect::StretchBump => (0.1, 0.4, true),
        Effect::ResistanceBump => (0.2, 3.0, true),
        Effect::DielectricDispersion | Effect::DielectricLoss => unreachable!("not in the library"),
        Effect::BumpCentre | Effect::BumpWidth | Effect::MeterOrder | Effect::BulgePower => {
            unreachable!("shape parameters")
        }
    };
    log_uniform(lo, hi, signed, rng)
}

/// Random strength of `effect` (SI) over its physical range (the
/// catalogue's notes; what a user's sensor or meter may have, detectable
/// or not): log-uniform magnitude, random sign where it has one.
fn physical_strength(effect: Effect, rng: &mut Rng) -> f64 {
    let (lo, hi, signed): (f64, f64, bool) = match effect {
        // Silver paint to a dry press contact.
        Effect::ContactResistance => (100.0, 1e6, false),
        Effect::ParasiticCapacitance => (0.2e-12, 50e-12, false),
        Effect::ResistanceGradient => (0.02, 0.95, true),
        // 0.4–400 nS on 200 pF.
        Effect::DielectricLeakage => (2.0, 2000.0, false),
        // One sample to seconds, as far as the 30 s traces hold (±2 s,
        // τ to 1 s: `host_sim::model::search`).
        Effect::MeterLag => (5e-3, 1.9, false),
        Effect::MeterResponse => (5e-3, 0.95, false),
        Effect::TimeOffset => (2e-3, 1.9, true),
        Effect::NonuniformStretch => (0.02, 0.95, true),
        Effect::StretchBulge => (0.02, 0.95, true),
        Effect::ResistanceBulge => (0.02, 0.95, true),
        Effect::LeadResistance => (0.02, 0.9, false),
        Effect::ElectrodeDispersion => (1e-6, 1e-3, false),
        // A logger's running mean of 2 to 50 readings; a digital filter's
        // memory from 0.1 to 0.98 (τ to 49 rows, 1 s).
        Effect::MeterMean => (2.0, 50.0, false),
        Effect::MeterEwma => (0.1, 0.98, false),
        // A press or a fold (the catalogue's notes), a thin or thick patch.
        Effect::StretchBump => (0.02, 0.95, true),
        Effect::ResistanceBump => (0.02, 0.95, true),
        Effect::DielectricDispersion | Effect::DielectricLoss => unreachable!("not in the library"),
        Effect::BumpCentre | Effect::BumpWidth | Effect::MeterOrder | Effect::BulgePower => {
            unreachable!("shape parameters")
        }
    };
    log_uniform(lo, hi, signed, rng)
}

/// The survey over the physical ranges (`cargo xtask survey`, beside the
/// second generator's): `SEEDS` sets (default 50), one hidden effect each
/// at [`physical_strength`]; a row per set and the summary the README
/// quotes.
#[test]
#[ignore = "survey: cargo xtask survey"]
fn survey() {
    let tmp = tempfile::tempdir().unwrap();
    let n: u64 = std::env::var("SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    let library: Vec<Effect> = Effect::library().collect();
    println!("| seed | hidden | value | baseline/noise | named | after/noise | drop |");
    println!("|---|---|---:|---:|---|---:|---:|");
    let (mut det, mut right, mut drops, mut worst) = (0, 0, vec![], 0.0f64);
    for seed in 0..n {
        let mut rng = Rng::new(7000 + seed);
        let effect = library[(rng.uniform() * library.len() as f64) as usize % library.len()];
        let v = physical_strength(effect, &mut rng);
        let (fx, meter) = hidden_with(effect, v, &mut rng);
        let r = run(&tmp.path().join(format!("p{seed}")), fx, meter, seed);
        let nf = r.noise_floor_pf;
        // After: against the floor seen through the final model.
        let fnf = r.final_noise_pf();
        let (b, f) = (r.baseline().rms_pf, r.final_fit().rms_pf);
        let named: Vec<&str> = r
            .accepted
            .iter()
            .flat_map(|a| a.effects.iter().map(|e| e.id()))
            .collect();
        println!(
            "| {seed} | {} | {:.4} {} | {:.1} | {} | {:.2} | {:.1} |",
            effect.id(),
            effect.info().display(v),
            effect.info().display_unit,
            b / nf,
            r.outcome(),
            f / fnf,
            b / f
        );
        if b <= 1.5 * nf {
            continue;
        }
        det += 1;
        if named_right(effect, v, &named) {
            right += 1;
        }
        drops.push(b / f);
        worst = worst.max(f / fnf);
    }
    drops.sort_by(f64::total_cmp);
    println!(
        "\nskin-sim, physical ranges: {right}/{det} detectable named right, median drop {:.1}x, after <= {worst:.2}x noise",
        drops.get(drops.len() / 2).copied().unwrap_or(f64::NAN)
    );
}

fn run(dir: &Path, fx: EffectSet, meter: Meter, seed: u64) -> Report {
    dataset(dir, with_effects(fx), meter, seed, ProgressBar::hidden()).unwrap();
    identify(&read_dir(dir).unwrap(), Options::default()).unwrap()
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn undeclared_effects_are_named_and_explained_over_50_seeds() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut detectable, mut right, mut bad) = (0, 0, vec![]);
    println!("| seed | hidden | value | baseline/noise | named | fitted | after/noise | drop |");
    let library: Vec<Effect> = Effect::library().collect();
    let n = library.len();
    for seed in 0..50u64 {
        let mut rng = Rng::new(1000 + seed);
        let effect = library[(rng.uniform() * n as f64) as usize % n];
        let v = strength(effect, &mut rng);
        let (fx, meter) = hidden_with(effect, v, &mut rng);
        let r = run(&tmp.path().join(format!("s{seed}")), fx, meter, seed);
        let nf = r.noise_floor_pf;
        let (b, f) = (r.baseline().rms_pf, r.final_fit().rms_pf);
        let named: Vec<&str> = r
            .named_fit()
            .into_iter()
            .flat_map(|a| a.effects.iter().map(|e| e.id()))
            .collect();
        let show = |v: f64| effect.info().display(v);
        let fitted = show(r.named_fit().map_or(f64::NAN, |a| a.params.get(effect)));
        let v_si = v;
        let v = show(v);
        println!(
            "| {seed} | {} | {v:.4} | {:.1} | {} | {fitted:.4} | {:.2} | {:.1} |",
            effect.id(),
            b / nf,
            match r.kind() {
                Verdict::Unexplained => "UNEXPLAINED".into(),
                Verdict::Named => format!("{} + remainder", named.join("+")),
                _ => named.join("+"),
            },
            f / nf,
            b / f
        );
        if b <= 1.5 * nf {
            // Not detectable: must not be dressed up as an effect.
            if r.kind() != Verdict::Clean {
                bad.push(format!(
                    "seed {seed}: undetectable {} reported as {named:?}",
                    effect.id()
                ));
            }
            continue;
        }
        detectable += 1;
        if named_right(effect, v_si, &named) {
            right += 1;
        }
        if f > 1.5 * nf {
            bad.push(format!("seed {seed}: {} after {:.2}× noise", effect.id(), f / nf));
        }
        if b >= 7.5 * nf && b < 5.0 * f {
            bad.push(format!("seed {seed}: {} dropped only {:.1}×", effect.id(), b / f));
        }
    }
    println!("detectable {detectable}/50, right effect named in {right}");
    assert!(
        detectable >= 35,
        "only {detectable} detectable sets: strengths too weak"
    );
    assert!(
        right as f64 >= 0.9 * detectable as f64,
        "right effect in {right}/{detectable}"
    );
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn clean_sets_are_clean_and_outside_effects_are_not_called_explained() {
    let tmp = tempfile::tempdir().unwrap();
    for seed in [21, 22, 23] {
        let r = run(
            &tmp.path().join(format!("clean{seed}")),
            EffectSet::NONE,
            Meter::LCR,
            seed,
        );
        assert!(
            !r.unexplained && r.accepted.is_none(),
            "seed {seed}: {}",
            r.verdict()
        );
    }
    // Dielectric dispersion: the permittivity falls with frequency. No
    // candidate is this mechanism.
    for (seed, k) in [(31, 0.005), (32, 0.01), (33, -0.01)] {
        let fx = EffectSet::NONE.with(Effect::DielectricDispersion, k);
        let r = run(&tmp.path().join(format!("disp{seed}")), fx, Meter::LCR, seed);
        println!("dispersion {k}: {}", r.verdict());
        // Never called explained: at most named with the remainder the
        // report locates (at some frequencies more than at others).
        assert!(r.accepted.is_none(), "dispersion {k}: {}", r.verdict());
        let j = r.json();
        assert_ne!(j["verdict"], "explained");
        assert_eq!(j["unexplained"], r.named.is_none());
        assert_eq!(
            j["effects"].as_array().unwrap().len(),
            r.named.as_ref().map_or(0, |f| f.effects.len())
        );
        if r.named.is_some() {
            assert!(!j["remainder"]["hints"].as_array().unwrap().is_empty());
        }
    }
}

#[test]
fn the_example_data_set_is_clean() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example");
    let r = identify(&read_dir(&dir).unwrap(), Options::default()).unwrap();
    println!("{}", r.verdict());
    assert!(!r.unexplained && r.accepted.is_none(), "{}", r.verdict());
    let j = r.json();
    for k in ["rms_pf", "max_pf"] {
        assert!(j["baseline"][k].as_f64().unwrap() > 0.0);
        assert!(j["final"][k].as_f64().unwrap() > 0.0);
    }
    assert!(j["noise_floor_pf"].as_f64().unwrap() > 0.0);
    assert_eq!(j["unexplained"], false);
    assert_eq!(j["effects"].as_array().unwrap().len(), 0);
}

#[test]
fn a_found_effect_reports_its_parameter_and_uncertainty() {
    let tmp = tempfile::tempdir().unwrap();
    let (fx, meter) = hidden(Effect::ParasiticCapacitance, 8e-12);
    let r = run(&tmp.path().join("p"), fx, meter, 7);
    let j = r.json();
    let e = &j["effects"][0];
    assert_eq!(e["id"], "parasitic_capacitance");
    let p = e["params"]["parasitic_capacitance_pf"].as_f64().unwrap();
    let s = e["uncertainty"]["parasitic_capacitance_pf"].as_f64().unwrap();
    assert!((p - 8.0).abs() < 0.1, "{p}");
    assert!(s > 0.0 && s < 0.1, "{s}");
    assert!((p - 8.0).abs() < 5.0 * s + 0.05, "{p} ± {s}");
    assert!(e["rms_pf_after"].as_f64().unwrap() <= 1.5 * j["noise_floor_pf"].as_f64().unwrap());
    // Identifiability: the found capacitance is pinned down; a candidate
    // kernel fitted to data without dynamics is not (its window or stamp
    // undetermined, or the two trading against each other).
    assert_eq!(
        j["identifiability"].as_array().unwrap().len(),
        0,
        "{}",
        j["identifiability"]
    );
    let lag = j["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["ids"][0] == "meter_lag")
        .unwrap();
    let notes: Vec<&str> = lag["identifiability"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert!(
        !notes.is_empty()
            && notes
                .iter()
                .all(|n| n.contains("window_ms") || n.contains("offset_ms")),
        "{notes:?}"
    );
    assert!(j["final"]["rms_pf"].as_f64().unwrap() * 5.0 < j["baseline"]["rms_pf"].as_f64().unwrap());
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn tab_leads_are_recovered_with_their_uncertainty() {
    let tmp = tempfile::tempdir().unwrap();
    let (fx, meter) = hidden(Effect::LeadResistance, 0.4);
    let r = run(&tmp.path().join("l"), fx, meter, 11);
    let j = r.json();
    let e = &j["effects"][0];
    assert_eq!(e["id"], "lead_resistance", "{}", r.markdown("l", None));
    let p = e["params"]["lead_fraction"].as_f64().unwrap();
    let s = e["uncertainty"]["lead_fraction"].as_f64().unwrap();
    assert!((p - 0.4).abs() < 0.01, "{p}");
    assert!(s > 0.0 && (p - 0.4).abs() < 5.0 * s + 1e-3, "{p} ± {s}");
    assert!(e["rms_pf_after"].as_f64().unwrap() <= 1.5 * j["noise_floor_pf"].as_f64().unwrap());
}

/// A trace of 10⁶ rows (30 s at 30 µs, one of the set's six traces
/// interpolated onto a fine grid with fresh noise on each row): `identify`
/// decimates it to every 250th row, says so in its reports, and still
/// finds the hidden contact resistance.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn a_million_row_trace_is_decimated_and_still_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let fx = EffectSet::NONE.with(Effect::ContactResistance, 30e3);
    dataset(dir, with_effects(fx), Meter::lcr(&fx), 7, ProgressBar::hidden()).unwrap();
    let path = dir.join("trace_20mmps_2000hz.csv");
    let n = 1_000_000usize;
    host_sim::experiments::dense_trace(&path, n, 0.03, 11).unwrap();
    let ds = read_dir(dir).unwrap();
    let r = identify(&ds, Options::default()).unwrap();
    assert_eq!(r.decimated.len(), 1, "{:?}", r.decimated);
    let (file, read, every) = &r.decimated[0];
    assert_eq!(
        (file.as_str(), *read, *every),
        ("trace_20mmps_2000hz.csv", n, 250)
    );
    assert!(r.markdown("d", None).contains("decimated to every 250th"));
    assert_eq!(r.json()["decimated"][0]["kept_every"], 250);
    let best = &r.singles[0];
    assert_eq!(best.effects, vec![Effect::ContactResistance], "{}", r.verdict());
    let v = best.params.get(Effect::ContactResistance);
    assert!((v / 30e3 - 1.0).abs() < 0.05, "{v}");
}

/// Time effects beyond the catalogue's first guesses (±0.5 s offsets,
/// 1 s windows): searched as far as the 30 s traces hold (±2 s), each
/// named and its parameter recovered.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn time_effects_are_searched_as_far_as_the_trace_holds() {
    let tmp = tempfile::tempdir().unwrap();
    for (k, (effect, v)) in [
        (Effect::TimeOffset, -1.6),
        (Effect::TimeOffset, 1.2),
        (Effect::MeterLag, 1.8),
        (Effect::MeterResponse, 0.8),
    ]
    .into_iter()
    .enumerate()
    {
        let (fx, meter) = hidden(effect, v);
        let r = run(&tmp.path().join(format!("t{k}")), fx, meter, 20 + k as u64);
        let j = r.json();
        let reach = j["search"]["reach_s"].as_f64().unwrap();
        assert!((reach - 2.0).abs() < 0.01, "reach {reach} s");
        let f = r
            .accepted
            .as_ref()
            .unwrap_or_else(|| panic!("{}: {}", effect.id(), r.verdict()));
        // A first-order response read every row is an exponentially
        // weighted mean of the readings, of memory e^(−Δ/τ): the same
        // meter, named either way (its τ recovered from the memory).
        println!("{}", r.verdict());
        if effect == Effect::MeterResponse && f.effects == [Effect::MeterEwma] {
            let m = f.params.get(Effect::MeterEwma);
            let tau = -0.02 / m.ln();
            assert!(
                (tau / v - 1.0).abs() < 0.05,
                "τ {tau} from memory {m} against {v}"
            );
            continue;
        }
        assert_eq!(f.effects, [effect], "{}", r.verdict());
        let (mut got, sigma) = (f.params.get(effect), f.sigma_of(effect));
        // A response fitted with its order: its centroid n·τ, and n
        // within 0.1 of one (at τ = 0.8 s the order takes up a mismatch
        // of 0.001 pF the first-order fit leaves: 1.04, n·τ within
        // 0.2 %).
        if f.fitted.contains(&Effect::MeterOrder) {
            let n = f.params.get(Effect::MeterOrder);
            assert!((n - 1.0).abs() <= 0.1, "order {n}: {}", r.verdict());
            got *= n;
        }
        assert!(
            (got - v).abs() < 0.02 * v.abs() + 5.0 * sigma,
            "{}: {got} ± {sigma} against {v}",
            effect.id()
        );
        assert_eq!(j["effects"][0]["at_limit"], false);
        assert!(f.rms_pf <= 1.5 * f.noise_pf, "{}", r.verdict());
    }
}

/// A lock-in's output filter of several sections (the project's own
/// generator: n first-order sections of τ, a fractional n mixing the next
/// order in part): named as the meter's response with its order, n within
/// 0.05 and τ within 2 % (5σ), explained to 1.3× the noise.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn a_response_of_several_sections_is_named_with_its_order() {
    let tmp = tempfile::tempdir().unwrap();
    for (k, (tau, order)) in [(0.04, 3.0), (0.03, 2.5)].into_iter().enumerate() {
        let fx = EffectSet::NONE
            .with(Effect::MeterResponse, tau)
            .with(Effect::MeterOrder, order);
        let r = run(
            &tmp.path().join(format!("o{k}")),
            fx,
            Meter::lcr(&fx),
            40 + k as u64,
        );
        let f = r.accepted.as_ref().unwrap_or_else(|| panic!("{}", r.verdict()));
        println!("{}", r.verdict());
        assert_eq!(f.effects, [Effect::MeterResponse], "{}", r.verdict());
        assert!(f.fitted.contains(&Effect::MeterOrder), "{}", r.verdict());
        let (n, sn) = (f.params.get(Effect::MeterOrder), f.sigma_of(Effect::MeterOrder));
        let (t, st) = (
            f.params.get(Effect::MeterResponse),
            f.sigma_of(Effect::MeterResponse),
        );
        assert!(
            (n - order).abs() < 0.05 + 5.0 * sn,
            "order {n} ± {sn} against {order}"
        );
        assert!(
            (t - tau).abs() < 0.02 * tau + 5.0 * st,
            "τ {t} ± {st} against {tau}"
        );
        assert!(f.rms_pf <= 1.3 * f.noise_pf, "{}", r.verdict());
    }
}

/// Competing explanations: a model that explains the data as well (BIC
/// within the margin) is listed beside the accepted one, with what would
/// separate the two, and the verdict says the data cannot tell them
/// apart; a model that only extends the accepted one, or explains less,
/// is not a competitor. (On these simulated sets the library's effects
/// are far apart, so the rival is the runner-up given the accepted fit's
/// figures: the selection's bookkeeping, and the sweep that separates a
/// resistance gradient from a parasitic capacitance.)
#[test]
#[ignore = "long: cargo xtask test --full"]
fn competing_explanations_are_listed_with_what_separates_them() {
    let tmp = tempfile::tempdir().unwrap();
    let fx = EffectSet::NONE.with(Effect::ParasiticCapacitance, 2e-12);
    dataset(
        tmp.path(),
        with_effects(fx),
        Meter::lcr(&fx),
        5,
        ProgressBar::hidden(),
    )
    .unwrap();
    let ds = read_dir(tmp.path()).unwrap();
    let mut r = identify(&ds, Options::default()).unwrap();
    let acc = r.accepted.clone().expect("parasitic capacitance found");
    assert_eq!(acc.effects, [Effect::ParasiticCapacitance]);
    assert!(r.competing.is_empty(), "{}", r.verdict());
    let prep = host_sim::model::Prepared::new(&ds, true).unwrap();
    // The runner-up, as if it explained as well: a competitor.
    let mut rival = r
        .singles
        .iter()
        .find(|f| f.effects == [Effect::ResistanceGradient])
        .unwrap()
        .clone();
    (rival.rms_pf, rival.noise_pf, rival.bic) = (acc.rms_pf, acc.noise_pf, acc.bic + 3.0);
    // An extension of the accepted model, and a model 20 BIC worse: not.
    let mut extension = rival.clone();
    extension.effects = vec![Effect::ParasiticCapacitance, Effect::ResistanceGradient];
    let mut worse = rival.clone();
    worse.effects = vec![Effect::ContactResistance];
    worse.bic = acc.bic + 20.0;
    r.singles.extend([rival.clone(), worse]);
    r.pairs.push(extension);
    r.competing = host_sim::identify::compete::competitors(&prep, &r);
    assert_eq!(
        r.competing.len(),
        1,
        "{:?}",
        r.competing.iter().map(|c| c.fit.label()).collect::<Vec<_>>()
    );
    let c = &r.competing[0];
    assert_eq!(c.fit.effects, [Effect::ResistanceGradient]);
    assert!((c.delta_bic - 3.0).abs() < 1e-9);
    // Their static sweeps part at high frequency (the gradient's fitted
    // value leaves pF between them there).
    assert!(
        c.separation.starts_with("a static sweep would: at "),
        "{}",
        c.separation
    );
    let v = r.verdict();
    assert!(
        v.contains("but as well by resistance_gradient (ΔBIC +3.0; a static sweep would"),
        "{v}"
    );
    assert!(v.contains("these data cannot tell them apart"), "{v}");
    assert_eq!(r.json()["competing"][0]["effects"][0], "resistance_gradient");
    // Two meter kernels differ only in time.
    let mut kernel = rival.clone();
    kernel.effects = vec![Effect::MeterMean];
    kernel.params = EffectSet::NONE.with(Effect::MeterMean, 4.0);
    r.accepted = Some(kernel.clone());
    kernel.effects = vec![Effect::MeterEwma];
    kernel.params = EffectSet::NONE.with(Effect::MeterEwma, 0.6);
    r.singles = vec![kernel];
    r.pairs.clear();
    let c = host_sim::identify::compete::competitors(&prep, &r);
    assert_eq!(c.len(), 1);
    assert!(
        c[0].separation.contains("rows finer than the kernels"),
        "{}",
        c[0].separation
    );
}
