//! `identify` on data from `rig-sim`, a generator written apart from
//! `skin-sim` (its own line discretisation, film dynamics, meter, noise
//! and effect shapes): one hidden effect per set, drawn over its physical
//! range.
//!
//! Held here: clean sets come out clean; effects outside the library
//! (Cole–Cole relaxation, blocking contacts) come out unexplained, never
//! as a library effect; the families the library's shapes cover are named
//! right and explained to the noise. The survey over every family
//! (`survey`, ignored: `cargo xtask survey`, or `cargo test --profile
//! quick -p host-sim --test second_generator -- --ignored --nocapture
//! survey` with `SEEDS=n`, `FAMILY=name`)
//! prints the survey's table over every family, the localized bumps of
//! stretch and resistance included.

mod survey;

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options, Report, Verdict};
use host_sim::model::Effect;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rig_sim::meter::Dynamics;
use rig_sim::{Bench, Family};
use std::path::Path;
use survey::{named, Hidden, Tally};

fn run(dir: &Path, bench: &Bench) -> Report {
    bench.write(dir).unwrap();
    identify(&read_dir(dir).unwrap(), Options::default()).unwrap()
}

/// The survey over every family (`cargo xtask survey`): `SEEDS` sets
/// (default 50), one hidden effect each drawn over its physical range;
/// every tenth set is clean and every tenth (from the fifth) has an
/// effect outside the library; `FAMILY=name` draws only that family,
/// `FIRST=k` starts at seed k (another draw), `SURVEY_DIR=dir` keeps the
/// sets in `dir`. Prints a row per set and the survey's summary.
#[test]
#[ignore = "survey: cargo xtask survey"]
fn survey() {
    let tmp = tempfile::tempdir().unwrap();
    // `SURVEY_DIR=dir` keeps the sets there (for `host-sim identify`).
    let dir = std::env::var_os("SURVEY_DIR").map_or(tmp.path().to_path_buf(), Into::into);
    let var = |name: &str, default: u64| {
        std::env::var(name)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let (n, first) = (var("SEEDS", 50), var("FIRST", 0));
    let fam: Option<String> = std::env::var("FAMILY").ok();
    let mut tally = Tally::new("rig-sim (second generator)");
    for seed in first..first + n {
        let mut rng = ChaCha8Rng::seed_from_u64(5000 + seed);
        let lib = Family::IN_LIBRARY;
        let family = match (&fam, seed % 10) {
            (Some(f), _) => Some(
                *lib.iter()
                    .chain(&Family::OUTSIDE)
                    .find(|x| x.name() == f)
                    .unwrap_or_else(|| panic!("no family {f}")),
            ),
            (None, 9) => None,
            (None, 4) => Some(Family::OUTSIDE[(seed / 10) as usize % Family::OUTSIDE.len()]),
            (None, _) => Some(lib[rng.gen_range(0..lib.len())]),
        };
        let (fx, meter, v) = match family {
            Some(f) => f.draw(&mut rng),
            None => (Default::default(), rig_sim::meter::Meter::BENCH, 0.0),
        };
        let t = std::time::Instant::now();
        let r = run(&dir.join(format!("s{seed}")), &Bench::new(fx, meter, seed));
        let hidden = match family {
            None => Hidden::Clean,
            Some(f) if f.catalogue_ids().is_empty() => Hidden::Outside,
            Some(_) => Hidden::InLibrary,
        };
        let name = family.map_or("clean", |f| f.name());
        let right = |ids: &[&str]| family.is_some_and(|f| f.named_right_at(ids, &meter, 0.02));
        tally.add(seed, (name, hidden, v), &r, &right, t.elapsed().as_secs_f64());
    }
    tally.print();
}

#[test]
fn clean_sets_are_clean() {
    let tmp = tempfile::tempdir().unwrap();
    for seed in [1, 2, 3] {
        let b = Bench::new(Default::default(), rig_sim::meter::Meter::BENCH, seed);
        let r = run(&tmp.path().join(format!("c{seed}")), &b);
        assert!(
            !r.unexplained && r.accepted.is_none(),
            "seed {seed}: baseline {:.4} pF against a floor of {:.4} pF, named {:?}",
            r.baseline().rms_pf,
            r.noise_floor_pf,
            named(&r)
        );
        assert!(r.baseline().rms_pf <= 1.2 * r.noise_floor_pf, "seed {seed}");
    }
}

/// A blocking contact (a contact with a capacitance in series, outside
/// the library; the survey's seed 14): a contact resistance with a
/// resistance profile takes > 99 % of the misfit (20.98 pF to 0.10 pF)
/// and is named, never called explained; the remainder is stated per
/// file and gathers at the sweep's lowest frequencies, where a series
/// capacitance tells, and the report says a dependence on frequency is
/// missing.
#[test]
fn a_cause_taking_most_of_the_misfit_is_named_with_its_remainder() {
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5014);
    let (fx, meter, _) = Family::BlockingContact.draw(&mut rng);
    let r = run(tmp.path(), &Bench::new(fx, meter, 14));
    println!("{}", r.verdict());
    assert_eq!(r.kind(), Verdict::Named, "{}", r.verdict());
    assert!(r.accepted.is_none() && !r.unexplained);
    assert!(named(&r).contains(&"contact_resistance"), "{:?}", named(&r));
    let rem = r.remainder.as_ref().expect("a remainder");
    assert!(rem.taken >= Options::default().named_share, "{}", rem.taken);
    assert!(rem.files.iter().any(|x| x.beyond(Options::default().explained)));
    let sweep = rem
        .files
        .iter()
        .find(|x| x.file == "sweep.csv")
        .expect("the sweep");
    let at = sweep.frequency_span_hz.expect("where in the sweep");
    assert!(at.gathers() && at.from < 300.0, "{at:?}");
    assert!(
        rem.hints.iter().any(|h| h.contains("frequency")),
        "{:?}",
        rem.hints
    );
    let j = r.json();
    assert_eq!(j["verdict"], "named_with_remainder");
    assert_eq!(j["unexplained"], false);
    assert_eq!(j["effects"].as_array().unwrap().len(), named(&r).len());
    assert_eq!(j["remainder"]["files"].as_array().unwrap().len(), rem.files.len());
    assert!(r.markdown("s14", None).contains("## What is left"));
}

/// A sine-shaped stretch bulge (the survey's seed 11): sin(πξ) is the
/// symmetric mode of power about 1.2 ((4ξ(1 − ξ))^k), which names and
/// explains it, its power stated in the verdict, its family note and
/// report.json; a bump as wide as the sensor, where listed beside it, is
/// the same thing in other terms.
#[test]
fn a_sine_bulge_is_named_a_bulge_with_its_power() {
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5011);
    let family = Family::IN_LIBRARY[rng.gen_range(0..Family::IN_LIBRARY.len())];
    assert_eq!(family, Family::StretchBulge, "the survey's draw");
    let (fx, meter, _) = family.draw(&mut rng);
    let r = run(tmp.path(), &Bench::new(fx, meter, 11));
    println!("{}", r.verdict());
    assert_eq!(r.kind(), Verdict::Explained, "{}", r.verdict());
    let f = r.named_fit().expect("named");
    assert_eq!(f.effects, [Effect::StretchBulge], "{}", r.verdict());
    let k = f.params.get(Effect::BulgePower);
    assert!((1.1..1.35).contains(&k), "power {k}");
    let family = host_sim::identify::family::note(f).unwrap_or_default();
    assert!(family.contains("symmetric bulge of power"), "{family}");
    assert!(r.verdict().contains(&family) && r.verdict().contains("power"));
    assert_eq!(r.json()["family"], family.as_str());
    for c in &r.competing {
        if c.fit.effects.contains(&Effect::StretchBump) {
            assert!(c.same_family, "{}", r.verdict());
        }
    }
}

/// Outside the library, nothing is called explained: a library effect
/// may take most of the misfit (named with a remainder, which the
/// report locates and traces), or none does (unexplained).
#[test]
#[ignore = "long: cargo xtask test --full"]
fn effects_outside_the_library_are_not_called_explained() {
    let tmp = tempfile::tempdir().unwrap();
    for (family, seed) in [
        (Family::Relaxation, 0),
        (Family::Relaxation, 1),
        (Family::BlockingContact, 2),
        (Family::BlockingContact, 3),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(7000 + seed);
        let (fx, meter, v) = family.draw(&mut rng);
        let r = run(&tmp.path().join(format!("o{seed}")), &Bench::new(fx, meter, seed));
        assert!(
            r.baseline().rms_pf > 3.0 * r.noise_floor_pf,
            "{} {v:e}: too weak to test",
            family.name()
        );
        println!("{} {v:e}: {}", family.name(), r.verdict());
        assert!(
            r.kind() != Verdict::Explained && r.accepted.is_none(),
            "{} {v:e}: {}",
            family.name(),
            r.verdict()
        );
        if let Some(rem) = &r.remainder {
            assert!(rem.files.iter().any(|x| x.beyond(Options::default().explained)));
            assert!(!rem.hints.is_empty());
        }
    }
}

/// The families whose shapes the library covers today, with the ranges it
/// covers (see the module doc for the rest).
const COVERED: [Family; 7] = [
    Family::Parasitic,
    Family::FilmDispersion,
    Family::Offset,
    Family::Leads,
    Family::Contact,
    Family::Window,
    Family::FirstOrder,
];

#[test]
#[ignore = "long: cargo xtask test --full"]
fn covered_families_are_named_right_and_explained() {
    let (detectable, bad) = covered_families(0..14);
    assert!(detectable >= 11, "only {detectable} detectable");
    assert!(bad.is_empty(), "{bad:#?}");
}

/// The fast pass's share of [`covered_families_are_named_right_and_explained`]:
/// its first set (a parasitic capacitance), with every check it makes of
/// a set.
#[test]
fn a_covered_family_is_named_right_and_explained() {
    let (detectable, bad) = covered_families(0..1);
    assert_eq!(detectable, 1);
    assert!(bad.is_empty(), "{bad:#?}");
}

/// One set of a covered family per seed: how many were detectable, and
/// what went wrong with any (undetectable but reported, named wrong, or
/// not explained to 1.5× the noise).
fn covered_families(seeds: std::ops::Range<u64>) -> (usize, Vec<String>) {
    let tmp = tempfile::tempdir().unwrap();
    let (mut detectable, mut right, mut bad) = (0, 0, vec![]);
    let n = seeds.end - seeds.start;
    for seed in seeds {
        let mut rng = ChaCha8Rng::seed_from_u64(9000 + seed);
        let family = COVERED[seed as usize % COVERED.len()];
        let (mut fx, meter, v) = family.draw(&mut rng);
        // Within the covered range: contacts to 300 kOhm per tab.
        fx.contact_ohm = fx.contact_ohm.min(300e3);
        let r = run(&tmp.path().join(format!("k{seed}")), &Bench::new(fx, meter, seed));
        let (nf, b, f) = (r.noise_floor_pf, r.baseline().rms_pf, r.final_fit().rms_pf);
        let ids = named(&r);
        println!(
            "{seed} {} {v:e}: {:.1}x noise -> {ids:?} {:.2}x {}",
            family.name(),
            b / nf,
            f / nf,
            r.final_fit().label()
        );
        if b <= 1.5 * nf {
            if r.kind() != Verdict::Clean {
                bad.push(format!(
                    "seed {seed}: undetectable {} reported as {ids:?}",
                    family.name()
                ));
            }
            continue;
        }
        detectable += 1;
        if family.named_right_at(&ids, &meter, 0.02) {
            right += 1;
        } else {
            bad.push(format!("seed {seed}: {} named {ids:?}", family.name()));
        }
        if f > 1.5 * nf {
            bad.push(format!(
                "seed {seed}: {} after {:.2}x noise",
                family.name(),
                f / nf
            ));
        }
    }
    println!("detectable {detectable}/{n}, named right {right}");
    (detectable, bad)
}

/// Meters that average their own readings, one per row, some rows late:
/// a running mean of 2–16 readings and an exponentially
/// weighted mean, drawn over their physical ranges. Each is named as a
/// meter kernel with its delay inside it (not a time offset as well),
/// and explained to 1.3× the noise.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn meters_averaging_their_readings_are_named_with_their_delay() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bad = vec![];
    for seed in 0..6u64 {
        let family = [Family::MovingMean, Family::Ewma][seed as usize % 2];
        let mut rng = ChaCha8Rng::seed_from_u64(9500 + seed);
        let (fx, meter, v) = family.draw(&mut rng);
        let r = run(&tmp.path().join(format!("d{seed}")), &Bench::new(fx, meter, seed));
        let (nf, f) = (r.final_noise_pf(), r.final_fit().rms_pf);
        let ids = named(&r);
        println!(
            "{seed} {} {:?} (centroid {v:.3} s): {ids:?} {:.2}x noise, {}",
            family.name(),
            meter.dynamics,
            f / nf,
            r.final_fit().label()
        );
        assert!(
            r.baseline().rms_pf > 3.0 * r.noise_floor_pf,
            "seed {seed}: too weak to test"
        );
        if !(family.named_right(&ids) && ids.len() == 1) {
            bad.push(format!("seed {seed}: {} named {ids:?}", family.name()));
        }
        if f > 1.3 * nf {
            bad.push(format!("seed {seed}: after {:.2}x noise", f / nf));
        }
        // N, the weight and the delay, as fitted.
        let p = r.final_fit().params;
        let delay_rows = -p.get(Effect::TimeOffset) / 0.02;
        let (got, want, d) = match meter.dynamics {
            Dynamics::MovingMean { readings, delay } => (p.get(Effect::MeterMean), readings as f64, delay),
            Dynamics::Ewma { weight, delay } => (1.0 - p.get(Effect::MeterEwma), weight, delay),
            _ => unreachable!(),
        };
        println!("  fitted {got:.3} for {want:.3}, delay {delay_rows:.2} rows for {d}");
        let close = match meter.dynamics {
            Dynamics::MovingMean { .. } => (got - want).abs() <= 0.5,
            _ => (got / want - 1.0).abs() <= 0.1,
        };
        if !close || (delay_rows - d as f64).abs() > 0.5 {
            bad.push(format!(
                "seed {seed}: fitted {got} for {want}, delay {delay_rows} rows for {d}"
            ));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

/// Localized bumps of stretch and of the film's resistance,
/// drawn by the second generator over their physical ranges (its own
/// sine-squared shape, placed by where it starts and ends, its mean taken
/// out on its own cells): each named as a profile of its quantity and
/// explained to 1.5× the noise, with the bump's place within 0.1 of the
/// truth where a bump is named.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn localized_bumps_are_named_and_explained() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bad = vec![];
    for seed in 0..4u64 {
        let family = [Family::StretchBump, Family::ResistanceBump][seed as usize % 2];
        let mut rng = ChaCha8Rng::seed_from_u64(9800 + seed);
        let (fx, meter, v) = family.draw(&mut rng);
        let bump = if family == Family::StretchBump {
            fx.stretch_bump
        } else {
            fx.resistance_bump
        };
        let r = run(&tmp.path().join(format!("b{seed}")), &Bench::new(fx, meter, seed));
        let (nf, b, f) = (r.final_noise_pf(), r.baseline().rms_pf, r.final_fit().rms_pf);
        let ids = named(&r);
        println!(
            "{seed} {} {v:.3} {bump:?}: {:.1}x noise -> {ids:?} {:.2}x, {}",
            family.name(),
            b / r.noise_floor_pf,
            f / nf,
            r.final_fit().label()
        );
        if !family.named_right_at(&ids, &meter, 0.02) {
            bad.push(format!("seed {seed}: {} named {ids:?}", family.name()));
        }
        if f > 1.5 * nf {
            bad.push(format!(
                "seed {seed}: {} after {:.2}x noise",
                family.name(),
                f / nf
            ));
        }
        if let Some(a) = r
            .accepted
            .as_ref()
            .filter(|a| a.effects.iter().any(|e| Effect::BUMPS.contains(e)))
        {
            let centre = a.params.get(Effect::BumpCentre);
            // The truth's centre, where its bump lies on the sensor.
            let on = (bump.start.max(0.0), bump.end.min(1.0));
            if centre < on.0 - 0.1 || centre > on.1 + 0.1 {
                bad.push(format!("seed {seed}: bump at {centre:.3}, the truth over {on:?}"));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

/// A stretch bump of +0.55 at the read end reaching past it (the
/// survey's seed 26: ξ from −0.07 to 0.45), where the local stretch runs
/// to 1.4× the calibrated 30 mm: the library's bump at the truth leaves
/// 14× the sum of squares (3.8× the RMS, on the coarse copy) of a wide
/// mirror bump of the other sign, which leaves 1.5× the noise; a second effect (a resistance bump of 0.2 %) took
/// that to 1.49× and was named. It takes 12 % of the misfit: never
/// named, so the set is unexplained, the best attempt the stretch bump
/// (a wrong effect is never named; see `docs/identify.md`).
#[test]
#[ignore = "long: cargo xtask test --full"]
fn a_second_effect_that_only_bends_the_model_is_not_named() {
    let tmp = tempfile::tempdir().unwrap();
    let fx = rig_sim::sensor::Effects {
        stretch_bump: rig_sim::sensor::Bump {
            amplitude: 0.55,
            start: -0.072,
            end: 0.448,
        },
        ..Default::default()
    };
    let r = run(tmp.path(), &Bench::new(fx, rig_sim::meter::Meter::BENCH, 26));
    println!("{}", r.verdict());
    let ids = named(&r);
    assert!(
        ids.is_empty() || Family::StretchBump.named_right(&ids),
        "{}",
        r.verdict()
    );
    let pair = r
        .pairs
        .iter()
        .find(|p| p.effects == [Effect::StretchBump, Effect::ResistanceBump])
        .expect("the pair was tried");
    assert!(
        pair.rms_pf <= 1.5 * pair.noise_pf
            && pair
                .unresolved
                .as_deref()
                .is_some_and(|u| u.contains("too little to name")),
        "{:?} at {:.2}x",
        pair.unresolved,
        pair.rms_pf / pair.noise_pf
    );
}

/// A lock-in's output filter of 2–4 first-order sections in cascade
/// (12–24 dB/octave; the second generator's own digital sections, run on
/// its millisecond samples): named as the meter's response with its
/// order (a shape in time chosen by BIC over the first-order response),
/// the order within 0.3 of the sections and n·τ within 5 % of the
/// truth, explained to 1.3× the noise; a first-order meter stays first
/// order (no order named).
#[test]
#[ignore = "long: cargo xtask test --full"]
fn lock_in_filters_are_named_with_their_order() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bad = vec![];
    for (seed, tau_s, sections) in [(0u64, 0.04, 2usize), (1, 0.025, 3), (2, 0.05, 4), (3, 0.08, 1)] {
        let dynamics = if sections == 1 {
            Dynamics::FirstOrder { tau_s }
        } else {
            Dynamics::Cascade { tau_s, sections }
        };
        let meter = rig_sim::meter::Meter {
            dynamics,
            ..rig_sim::meter::Meter::BENCH
        };
        let r = run(
            &tmp.path().join(format!("l{seed}")),
            &Bench::new(Default::default(), meter, seed),
        );
        let (nf, f) = (r.final_noise_pf(), r.final_fit().rms_pf);
        let ids = named(&r);
        let fit = r.final_fit();
        let (tau, order) = (
            fit.params.get(Effect::MeterResponse),
            fit.params.get(Effect::MeterOrder),
        );
        println!(
            "{sections} x {tau_s} s: {ids:?} {:.2}x noise, {} (tau {tau:.4} s, order {order:.2})",
            f / nf,
            fit.label()
        );
        if ids != ["meter_response"] {
            bad.push(format!("{sections} x {tau_s}: named {ids:?}"));
            continue;
        }
        let n = if fit.fitted.contains(&Effect::MeterOrder) {
            order
        } else {
            1.0
        };
        if (n - sections as f64).abs() > 0.3 || (n * tau / (sections as f64 * tau_s) - 1.0).abs() > 0.05 {
            bad.push(format!("{sections} x {tau_s}: fitted order {n:.2}, tau {tau:.4}"));
        }
        if sections == 1 && fit.fitted.contains(&Effect::MeterOrder) {
            bad.push(format!("first order named with an order {order:.2}"));
        }
        if f > 1.3 * nf {
            bad.push(format!("{sections} x {tau_s}: after {:.2}x noise", f / nf));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
