//! The disturbance table (`host-sim disturbances`, docs/disturbances.md):
//! neither path leaves a valid record 1 % off in any class (the
//! multiplexed channel's two tones included: what sits within half a bin
//! of a tone, undeclared wiring), a far interferer leaves the multiplexed
//! channel's records valid and right, both paths keep a clean skin's
//! records, and the page shows what the code measures.

use host_sim::ceiling::Probe;
use host_sim::disturbances::{array_for, array_for_mains, array_in, markdown, rows, CLASSES};
use instrument::array::Layout;
use instrument::faults::{Flags, Thresholds};
use skin_sim::profile::Profile;

/// The array in 1 ms blocks (twice the noise, 14 residual degrees of
/// freedom, 1 kHz between bins) under every class: no valid record
/// beyond the tolerance it is vouched for within (1.6 %; the worst, an
/// undeclared dispersion of the film, 1.3 %), whatever flags a whole
/// record set flags it, and at least half of a clean skin's records are
/// kept (on this moving reference sensor 62 %: the rest are uncertain, their
/// bound past 1.6 %).
#[test]
#[ignore = "long: cargo xtask test --full"]
fn the_array_in_1_ms_blocks_vouches_for_no_wrong_record_either() {
    let tolerance = Thresholds::ARRAY_1MS.c_tolerance as f64;
    for class in CLASSES.iter() {
        let Some(a) = array_in(Layout::BLOCK_1MS, class) else {
            continue;
        };
        println!(
            "{:40} {:5} records, {:5} flagged, worst valid {:.3} %",
            class.name,
            a.records(),
            a.flagged(),
            a.worst_valid * 100.0
        );
        assert!(a.worst_valid < tolerance, "{}: {a:?}", class.name);
        if ["open sensor", "shorted sensor", "clipping"].contains(&class.name) {
            assert_eq!(a.flagged(), a.records(), "{}: {a:?}", class.name);
        }
        if class.name == CLASSES[0].name {
            assert!(a.flagged() * 2 <= a.records(), "clean skin: {a:?}");
        }
    }
}

#[test]
fn neither_path_vouches_for_a_wrong_record_under_any_disturbance() {
    let rows = rows();
    for (class, m, a) in &rows {
        if let Some(a) = a {
            assert_eq!(a.valid_off, 0, "array, {}: {a:?}", class.name);
        }
        assert_eq!(m.valid_off, 0, "multiplexed, {}: {m:?}", class.name);
        // What one tone cannot tell from the sensor, the second one
        // flags: most of the records, not a few.
        if [
            "mains harmonic at the tone",
            "interferer in the tone's bin",
            "alias of the tone",
            "contact resistance",
            "parasitic capacitance",
        ]
        .contains(&class.name)
        {
            assert!(
                m.flagged() * 10 >= m.records() * 9,
                "multiplexed, {}: {m:?}",
                class.name
            );
        }
        // Whatever flags a whole record set, flags it on both paths: a
        // stuck, open, shorted or clipped input is never read.
        if [
            "stuck ADC",
            "open sensor",
            "shorted sensor",
            "clipping",
            "step in a block",
            "burst",
        ]
        .contains(&class.name)
        {
            assert_eq!(m.flagged(), m.records(), "multiplexed, {}: {m:?}", class.name);
            assert!(
                a.as_ref().is_none_or(|a| a.flagged() == a.records()),
                "array, {}: {a:?}",
                class.name
            );
        }
    }
    // Far from the tone the lock-in's window rejects an interferer: ≥ 90 %
    // of the multiplexed channel's records stay valid (and, above, none
    // is 1 % off).
    let (_, far, _) = rows
        .iter()
        .find(|(c, _, _)| c.name == "interferer far from the tone")
        .expect("the far interferer's row");
    assert!(far.flagged() * 10 <= far.records(), "{far:?}");
    // A film that warms changes C itself: the records follow it, vouched
    // for, as on a clean skin.
    let (_, m, a) = rows
        .iter()
        .find(|(c, _, _)| c.name == "drift of C")
        .expect("the drift of C's row");
    let a = a.as_ref().expect("the array runs the drift");
    assert!(
        m.flagged() * 100 <= m.records() && a.flagged() * 100 <= a.records(),
        "{m:?} {a:?}"
    );
    // One tone's error alone (in its bin, a mains harmonic on it): the
    // array reads a record from the other two (TONE_LEFT_OUT), some 46-48 %
    // of them where the model check alone kept 6 %; a misfit spread over
    // the tones (undeclared wiring, a film's loss or dispersion) is never
    // read so.
    let array_of = |name: &str| {
        let (_, _, a) = rows.iter().find(|(c, _, _)| c.name == name).expect(name);
        a.clone().expect(name)
    };
    for name in ["mains harmonic at the tone", "interferer in the tone's bin"] {
        let a = array_of(name);
        assert!(a.flagged() * 10 <= a.records() * 6, "{name}: {a:?}");
    }
    for name in [
        "contact resistance",
        "parasitic capacitance",
        "dielectric loss",
        "dispersion of C",
    ] {
        let a = array_of(name);
        let rescued = a.availability.flagged[flag_index(Flags::TONE_LEFT_OUT)];
        assert!(rescued == 0 && a.moved == 0, "{name}: {a:?}");
        // Two tabs' 60 kΩ are small beside the line's 3 MΩ at the 250 Hz
        // tone: the records a stretching sensor reads there are right
        // (valid_off is 0 above): 18 % of them (9 % with the flatter
        // comb before, whose 250 Hz tone was 0.83 V, not 0.97 V).
        let share = if name == "contact resistance" { 75 } else { 99 };
        assert!(a.flagged() * 100 >= a.records() * share, "{name}: {a:?}");
    }
    // The clean skin: ≥ 99 % of the records vouched for on both paths.
    let (_, m, a) = &rows[0];
    let a = a.as_ref().expect("the array runs the clean skin");
    assert!(m.flagged() * 100 <= m.records(), "{m:?}");
    assert!(a.flagged() * 100 <= a.records(), "{a:?}");
    figures::check("docs/disturbances.md", "disturbances", &markdown(&rows)).unwrap();
}

/// A clean skin across the sensors the array is documented for
/// (electrodes 0.5–2 times the paper's, held or stretching at up to
/// 50 mm/s, both layouts): no valid record 1 % off, and the share kept
/// valid on docs/accuracy.md (the goal: ≥ 99 % at 250 records/s, ≥ 95 %
/// at 1,000, for every sensor).
#[test]
fn a_clean_skin_keeps_its_records_across_the_documented_sensors() {
    use host_sim::availability::{cases, markdown, run};
    let rows: Vec<_> = cases().into_iter().map(run).collect();
    for k in &rows {
        assert_eq!(k.all.valid_off, 0, "{k:?}");
        // The values interpolated for the others, never measurements,
        // stay within the tolerance here too (0.42 % at worst).
        assert!(k.interpolated.2 < 0.01, "{k:?}");
        // The paper's sensors held are read whole at 250 records/s.
        if k.case.rate_mm_s == 0.0 && k.case.r_scale <= 1.0 && k.case.layout == Layout::BLOCK_4MS {
            assert!(k.least >= 0.99, "{k:?}");
        }
        // Never more than the block can tell: a reader past the noise
        // ceiling vouches for records whose σ of C leaves one in 10⁵ past
        // 1 % by noise alone (`host_sim::ceiling`).
        let ceiling = host_sim::ceiling::run(k.case, Probe::COMB);
        let share = k.all.availability.share().unwrap_or(0.0);
        assert!(
            share <= ceiling.noise.all && k.least <= ceiling.noise.least,
            "{k:?} {ceiling:?}"
        );
    }
    figures::check("docs/accuracy.md", "array-availability", &markdown(&rows)).unwrap();
}

/// Cases of [`availability_fuzz`]: `FUZZ_CASES` / 500, at least 8 (each
/// case is sixteen sensors for 2.2 s).
fn availability_cases() -> u32 {
    let all: u32 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    (all / 500).max(8)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: availability_cases(),
        failure_persistence: None,
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// A clean skin anywhere in the documented range (electrodes 0.5–2
    /// times the paper's, held or stretching at up to 50 mm/s, any phase
    /// of its cycle, either layout): no valid record 1 % off; and where
    /// the availability goal holds today (electrodes up to the paper's,
    /// held, 250 records/s), every sensor keeps ≥ 99 % of its records
    /// valid. (Moving, it does not yet: electrodes 0.91 times the paper's
    /// at 5 mm/s left a sensor 98 %, UNCERTAIN.) Nor does any case keep
    /// more, or its least sensor more, than its noise ceiling
    /// (`host_sim::ceiling`): a reader past it vouches for records whose
    /// σ of C leaves one in 10⁵ past 1 %.
    #[test]
    fn availability_fuzz(
        r_scale in 0.5f64..2.0,
        rate in proptest::prop_oneof![proptest::strategy::Just(0.0f64), 5.0f64..50.0],
        phase_s in 0.0f64..10.0,
        short in proptest::bool::weighted(0.25),
        seed in proptest::prelude::any::<u64>(),
    ) {
        let case = host_sim::availability::Case {
            layout: if short { Layout::BLOCK_1MS } else { Layout::BLOCK_4MS },
            r_scale,
            rate_mm_s: rate,
            phase_s,
            seed,
        };
        let k = host_sim::availability::run(case);
        proptest::prop_assert_eq!(k.all.valid_off, 0, "{:?}", k);
        if !short && r_scale <= 1.0 && rate == 0.0 {
            proptest::prop_assert!(k.least >= 0.99, "{:?}", k);
        }
        // Never more than the blocks can tell (`host_sim::ceiling`).
        let ceiling = host_sim::ceiling::run(case, Probe::COMB);
        let share = k.all.availability.share().unwrap_or(0.0);
        proptest::prop_assert!(
            share <= ceiling.noise.all && k.least <= ceiling.noise.least,
            "{:?} {:?}",
            k,
            ceiling
        );
    }
}

/// A persistent interferer on a tone (500 Hz, the lowest of the three
/// the paper's sensors read): within a second every channel has moved
/// its three tones off it and says so on every record from then on
/// (`TONE_MOVED`), and none is 1 % off. On a mains harmonic exactly in
/// the tone's bin, a skin held keeps 99.6 % of its records, stretching
/// 98.1 %: the three it moves to (250 Hz, 1 and 2 kHz) stay in the
/// line's sensitive range while the electrodes' resistance peaks. (With
/// 500 Hz the lowest tone a stretching skin kept 76 %, and 46 %
/// unmoved.) The rest are UNCERTAIN: an interferer near the 500 Hz tone
/// may leak into the adjacent 250 Hz up to five times what the residual
/// shows (`Layout::near_leak`), and the bound takes it so. An interferer
/// a few hertz off the tone leaks into 250 Hz and 1 kHz, which the
/// three moved to read, and into the residual: the channel fits the
/// avoided tone's sideband beside the comb (`instrument::sideband`),
/// which takes the leak out to first order and bounds what is left by
/// how fast the sideband turns. 5 Hz off, a held skin keeps 98.2 % of
/// its records and a stretching one 95.7 % (85 % before the sideband);
/// an alias 20 Hz off, 97.4 % held and 75.9 % stretching (none before),
/// the rest UNCERTAIN where the electrodes' resistance peaks: 20 Hz off,
/// the leak left into 250 Hz is 1.8 % of the interferer, and the bound
/// holds it, not yet the 90 % asked. (Measured over 4 s; the test runs
/// 3.) A clean skin never moves.
#[test]
fn the_array_moves_off_a_tone_an_interferer_occupies() {
    let class = |name: &str| *CLASSES.iter().find(|c| c.name == name).expect(name);
    let held = Profile::Constant(15.0);
    let moving = Profile::paper(20.0);
    let run = |name: &str, p: &Profile| {
        array_for(Layout::BLOCK_4MS, &class(name), p, 3.0, 1.0).expect("the array runs sinusoids")
    };
    let cases = [
        ("mains harmonic at the tone", &held, 99, true),
        ("mains harmonic at the tone", &moving, 97, true),
        ("interferer in the tone's bin", &held, 96, true),
        ("interferer in the tone's bin", &moving, 93, true),
        ("alias of the tone", &held, 95, true),
        ("alias of the tone", &moving, 70, true),
        ("clean", &moving, 99, false),
    ];
    let outcomes: Vec<_> = cases.iter().map(|&(name, p, _, _)| run(name, p)).collect();
    for ((name, p, _, _), o) in cases.iter().zip(&outcomes) {
        println!("{name}, {p:?}: {} ({})", o.availability, o.availability.why());
    }
    for ((name, p, share, moves), o) in cases.into_iter().zip(&outcomes) {
        let a = &o.availability;
        assert_eq!(o.valid_off, 0, "{name}: {o:?}");
        assert!(
            a.valid * 100 >= a.records * share,
            "{name}, {p:?}: {a} ({})",
            a.why()
        );
        let moved = if moves { o.records() } else { 0 };
        assert_eq!(o.moved, moved, "{name}, {p:?}: {o:?}");
    }
}

/// Mains hum, strong (200 counts of the multiplexer's scale, 3,200 of the
/// array's) or weak (2 counts, 0.05 % of full scale), on a skin held or
/// stretching at 20 mm/s: from one second after it starts, the array
/// keeps at least 99 % of its records valid and none wrong, where it kept
/// none and a quarter before it followed the hum across blocks
/// ([`dsp_core::hum`]). 60 Hz hum likewise on a reader set for it; on
/// one set for 50 Hz it is not taken out, and nothing valid is wrong
/// either.
#[test]
fn the_array_takes_mains_hum_out_of_its_records() {
    let class = |name: &str| *CLASSES.iter().find(|c| c.name == name).expect(name);
    let held = Profile::Constant(15.0);
    let moving = Profile::paper(20.0);
    for name in ["mains hum", "weak mains hum"] {
        for p in [&held, &moving] {
            let o =
                array_for(Layout::BLOCK_4MS, &class(name), p, 3.0, 1.0).expect("the array runs sinusoids");
            let a = &o.availability;
            assert_eq!(o.valid_off, 0, "{name}: {o:?}");
            assert!(
                a.valid * 100 >= a.records * 99,
                "{name}, {p:?}: {a} ({})",
                a.why()
            );
        }
    }
    let mut sixty = class("weak mains hum");
    if let host_sim::disturbances::Front::Sine { hz, .. } = &mut sixty.front {
        *hz = 60.0;
    }
    let o = array_for(Layout::BLOCK_4MS, &sixty, &moving, 2.0, 1.0).expect("the array runs sinusoids");
    assert_eq!(o.valid_off, 0, "{o:?}");
    let o =
        array_for_mains(Layout::BLOCK_4MS, &sixty, &moving, 2.0, 1.0, 60).expect("the array runs sinusoids");
    let a = &o.availability;
    assert_eq!(o.valid_off, 0, "{o:?}");
    assert!(a.valid * 100 >= a.records * 99, "60 Hz: {a} ({})", a.why());
}

/// The position of `flag` in an availability's counts (bit order).
fn flag_index(flag: u16) -> usize {
    Flags::NAMES
        .iter()
        .position(|&(f, _)| f == flag)
        .expect("every flag has a name")
}
