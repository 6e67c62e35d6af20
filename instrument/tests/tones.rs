//! The array on the host: sixteen simulated sensors read at once through
//! the comb front end (`skin_sim::array`), each block demodulated by
//! dsp-core's comb and turned into a record by `instrument::tones`
//! (`instrument::reader`: the chain the firmware's `skin-array` runs in
//! QEMU and `skin-array-board` on the board).

use dsp_core::fixture::Fixture;
use instrument::array::{Frame, Layout, BLOCK_INSTANTS, RATE_HZ, SENSORS, TONES};
use instrument::calib::{CalTable, POINTS};
use instrument::effects::Effect;
use instrument::faults::Flags;
use instrument::reader::ArrayReader;
use instrument::sensor::{self as skin_sensor, Sensors};
use instrument::tones::{ToneRecord, ToneSettings};
use skin_sim::array::ArrayFrontEnd;
use skin_sim::frontend::Disturbance;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};

/// Records and the truth (C, F) beside each, per sensor.
type Run = Vec<Vec<(ToneRecord, f64)>>;

/// The paper's calibration for every sensor.
fn paper_cal() -> &'static CalTable<POINTS> {
    &skin_sim::sensor::PAPER_CALIBRATION
}

/// Run the array for `seconds` with sensor s of `params(s)` under
/// `profile(s)`, the firmware reading every sensor as a clean paper
/// sensor (its leads, no wiring) on the paper's calibration.
fn run(
    params: impl Fn(usize) -> SensorParams,
    profile: impl Fn(usize) -> Profile<'static>,
    seconds: f64,
    seed: u64,
) -> Run {
    run_with(
        Layout::BLOCK_4MS,
        &[*paper_cal(); SENSORS],
        params,
        profile,
        seconds,
        seed,
        (&Disturbance::NONE, 0.0),
    )
}

/// [`run`] in blocks of `layout`, sensor s on table `tables[s]` (with
/// the paper's leads), an interferer `hum` (its hum fields) on every
/// sensor's current input from `onset_s` on (nothing added before).
fn run_with<'a>(
    layout: Layout,
    tables: &[CalTable<POINTS>; SENSORS],
    params: impl Fn(usize) -> SensorParams,
    profile: impl Fn(usize) -> Profile<'a>,
    seconds: f64,
    seed: u64,
    hum: (&Disturbance, f64),
) -> Run {
    let lead = SensorParams::PAPER.effects.lead_ratio();
    let each = Sensors::from_fn(|s| skin_sensor::Sensor::calibrated(tables[s], lead, Fixture::NONE).unwrap());
    run_on(layout, &each, params, profile, seconds, seed, hum)
}

/// [`run_with`], the firmware reading sensor s as `each`'s.
fn run_on<'a>(
    layout: Layout,
    each: &Sensors<POINTS, SENSORS>,
    params: impl Fn(usize) -> SensorParams,
    profile: impl Fn(usize) -> Profile<'a>,
    seconds: f64,
    seed: u64,
    (hum, onset_s): (&Disturbance, f64),
) -> Run {
    let fe = ArrayFrontEnd::reference(layout);
    let settings = ToneSettings::new(layout, fe.dsp_front_end(), each);
    let mut sensors: Vec<Sensor> = (0..SENSORS).map(|s| Sensor::settled(params(s))).collect();
    let mut reader = ArrayReader::new(layout, each).unwrap();
    let mut rng = Rng::new(seed);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let block_us = layout.block_us();
    let blocks = (seconds * 1e6 / block_us as f64) as u64;
    let mut out: Run = vec![Vec::new(); SENSORS];
    let hz = layout.tones_hz().map(|f| f as f64);
    for b in 0..blocks {
        let t_us = b * block_us + block_us / 2;
        let t = t_us as f64 * 1e-6;
        let mut z = [[num_complex::Complex64::new(0.0, 0.0); TONES]; SENSORS];
        let mut truth = [0.0; SENSORS];
        for (s, sensor) in sensors.iter_mut().enumerate() {
            sensor.advance(&profile(s), t);
            z[s] = sensor.impedances(&hz);
            truth[s] = sensor.truth().c_farad;
        }
        let t0_s = (b * block_us) as f64 * 1e-6;
        let on = if t0_s >= onset_s { hum } else { &Disturbance::NONE };
        let d = Disturbance { t0_s, ..*on };
        let clipped = fe.frame(&z, &[d; SENSORS], &mut rng, &mut frame);
        reader.read(
            &settings,
            t_us,
            |a| layout.rows(&frame[a]),
            |input| clipped[input],
            |rec| {
                let s = usize::from(rec.sensor);
                out[s].push((rec, truth[s]));
            },
        );
    }
    out
}

/// (valid records, RMS and max relative error of C over them).
fn stats(recs: &[(ToneRecord, f64)]) -> (usize, f64, f64) {
    let e: Vec<f64> = recs
        .iter()
        .filter(|(r, _)| r.flags.valid())
        .map(|(r, c)| r.c_farad as f64 / c - 1.0)
        .collect();
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    (e.len(), rms, e.iter().fold(0.0f64, |m, v| m.max(v.abs())))
}

#[test]
fn sixteen_sensors_at_once_within_a_thousandth_under_the_papers_stretching() {
    let bounds = Bounds {
        rms: 1e-3,
        valid: 0.98,
        z_max: 6.0,
    };
    sixteen_sensors_under_the_papers_stretching(Layout::BLOCK_4MS, &bounds, 1);
}

/// The same at 1000 records/s: 1 ms blocks, a quarter of the conversions
/// a record, twice the noise (0.05 % RMS, within a thousandth
/// still). The noise's σ is estimated from the block's 14 residual
/// degrees of freedom, so the error over it has Student's heavier tails:
/// t with 14 degrees of freedom puts 77 of 150 000 records beyond 4.5
/// (62 here), the largest beyond 8 one run in five and beyond 12 one in
/// 700 (8.7 here, 7.2 with the flatter comb before). A σ understated
/// twofold would fail the RMS. Each record's bound doubles with the
/// noise, and so does the tolerance it is vouched for within (1.6 %,
/// [`instrument::faults::Thresholds::ARRAY_1MS`]); where the stretched
/// sensor's resistance peaks and the policy sits at 1 and 2 kHz (a pair
/// a factor of 2 apart, the 4 ms comb's 500 Hz and 2 kHz are 4), the
/// bound still passes it: 68–89 % of each sensor's records are valid,
/// their largest error 0.65 %.
#[test]
fn sixteen_sensors_at_a_thousand_records_a_second_within_a_thousandth() {
    let bounds = Bounds {
        rms: 1e-3,
        valid: 0.6,
        z_max: 12.0,
    };
    sixteen_sensors_under_the_papers_stretching(Layout::BLOCK_1MS, &bounds, 2);
}

/// Every sensor the paper's, on the 20 mm/s trapezoid, each started 0.6
/// s after the one before; 12 s: a whole cycle for every one. Each
/// sensor's valid records within `bounds` RMS of the truth and its
/// tolerance at most, as many valid as `bounds` says, false model
/// flags as chance says, the stated σ honest.
fn sixteen_sensors_under_the_papers_stretching(layout: Layout, bounds: &Bounds, seed: u64) {
    let seconds = 12.0;
    let out = run_with(
        layout,
        &[*paper_cal(); SENSORS],
        |_| SensorParams::PAPER,
        |s| Profile::Table(leaked_delay(s as f64 * 0.6)),
        seconds,
        seed,
        (&Disturbance::NONE, 0.0),
    );
    let (mut false_flags, mut records) = (0, 0);
    for (s, recs) in out.iter().enumerate() {
        let (valid, rms, max) = stats(recs);
        let model = recs.iter().filter(|(r, _)| r.flags.has(Flags::MODEL)).count();
        println!(
            "sensor {s:2}: {valid}/{} valid, C rms {:.3} % max {:.3} %, model flags {model}, tones {:?}",
            recs.len(),
            rms * 100.0,
            max * 100.0,
            recs.last().unwrap().0.f_hz
        );
        assert_eq!(recs.len(), (seconds * layout.records_per_s() as f64) as usize);
        assert!(
            valid as f64 >= bounds.valid * recs.len() as f64,
            "sensor {s}: {valid} valid"
        );
        assert!(rms < bounds.rms, "sensor {s}: rms {rms}");
        // Every valid record within the tolerance it is vouched for.
        let tolerance = instrument::faults::Thresholds::array(&layout).c_tolerance as f64;
        assert!(max < tolerance, "sensor {s}: max {max}");
        records += recs.len();
        // A clean sensor trips the model check as often as chance says
        // (10⁻⁴ a record), give or take.
        false_flags += model;
    }
    check_false_flags(false_flags, records);
    // Each record's stated σ of C is honest: the errors of the valid
    // records over their σ have an rms of 1 (1.07: σ is itself estimated
    // from the block); the largest errors, ≈ 0.35 %, are ≈ 4σ where the
    // stretched sensor's resistance peaks and σ of C is ≈ 0.1 %, the
    // largest in σ 5.3 of 48 000.
    let z: Vec<f64> = out
        .iter()
        .flatten()
        .filter(|(r, _)| r.flags.valid())
        .map(|(r, c)| (r.c_farad as f64 / c - 1.0) / r.sigma_ln_c as f64)
        .collect();
    let z_rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    let z_max = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!(
        "error / stated sigma: rms {z_rms:.3}, max {z_max:.1} over {} records",
        z.len()
    );
    assert!((0.9..1.2).contains(&z_rms), "{z_rms}");
    assert!(z_max < bounds.z_max, "{z_max}");
}

/// What [`sixteen_sensors_under_the_papers_stretching`] asserts.
struct Bounds {
    /// Each sensor's RMS relative error of C over its valid records.
    rms: f64,
    /// Each sensor's fraction of records valid, at least.
    valid: f64,
    /// The largest error over its stated σ.
    z_max: f64,
}

/// A clean sensor trips the model check about as often as chance says
/// (10⁻⁴ a record at the flag of `twotone::chi2_flag`, which allows for
/// the noise σ being estimated from the block).
fn check_false_flags(false_flags: usize, records: usize) {
    let rate = false_flags as f64 / records as f64;
    println!("false model flags: {false_flags} in {records} ({rate:.1e})");
    assert!(rate < 5e-4, "{rate:e}");
}

/// The paper's 20 mm/s trapezoid started `delay` s late, as a table.
fn leaked_delay(delay: f64) -> &'static [(f64, f64)] {
    let mut pts = vec![(0.0, 0.0)];
    let mut t0 = delay;
    while t0 < 40.0 {
        pts.extend([(t0, 0.0), (t0 + 1.5, 30.0), (t0 + 5.0, 30.0), (t0 + 6.5, 0.0)]);
        t0 += 10.0;
    }
    Box::leak(pts.into_boxed_slice())
}

#[test]
fn the_model_check_fires_on_contacts_and_parasitics_and_not_on_clean_sensors() {
    // Sensors 0–5 clean, 6–8 with 30 kΩ of undeclared contact per tab
    // (2 % of the paper's cycled sensor), 9–10 with 150 kΩ, 11–15 with
    // 2 pF of undeclared cable capacitance (1 % of it); all stretched,
    // their silicone film as the firmware assumes it.
    let params = |s: usize| {
        let mut p = SensorParams::PAPER;
        p.effects = match s {
            0..=5 => p.effects,
            6..=8 => p.effects.with(Effect::ContactResistance, 30e3),
            9..=10 => p.effects.with(Effect::ContactResistance, 150e3),
            _ => p.effects.with(Effect::ParasiticCapacitance, 2e-12),
        };
        p
    };
    let out = run(params, |_| Profile::paper(20.0), 4.0, 2);
    let mut clean_flags = 0;
    for (s, recs) in out.iter().enumerate() {
        let solved = recs.iter().filter(|(r, _)| r.chi2 > 0.0).count();
        let model = recs.iter().filter(|(r, _)| r.flags.has(Flags::MODEL)).count();
        let median = {
            let mut c: Vec<f32> = recs.iter().map(|(r, _)| r.chi2).collect();
            c.sort_by(f32::total_cmp);
            c[c.len() / 2]
        };
        let worst = recs
            .iter()
            .filter(|(r, _)| r.flags.valid())
            .fold(0f64, |m, (r, c)| m.max((r.c_farad as f64 / c - 1.0).abs()));
        println!(
            "sensor {s:2}: model flags {model} of {solved}, median chi2 {median:.1}, worst valid C {:.3} %",
            worst * 100.0
        );
        // Whatever the check lets through is right.
        assert!(
            worst < 0.01,
            "sensor {s}: a valid record {:.2} % off",
            worst * 100.0
        );
        match s {
            0..=5 => clean_flags += model,
            // A small contact moves C by less than the tolerance, and the
            // model's floor (the film's loss known to ±2·10⁻³) lets it
            // pass; it still lifts χ² above a clean sensor's.
            6..=8 => assert!(median > 1.0, "sensor {s}: median χ² {median}"),
            // A large one or a parasitic is told apart by its records:
            // most of them flagged, the median χ² above the flag.
            _ => {
                assert!(
                    model as f64 >= 0.5 * solved as f64,
                    "sensor {s}: {model} of {solved} flagged"
                );
                assert!(
                    median > dsp_core::twotone::CHI2_FLAG,
                    "sensor {s}: median χ² {median}"
                );
            }
        }
    }
    // The clean sensors: at most 10⁻³ of their records flagged, 10× the
    // flag's chance rate. With the model's floor of 2·10⁻³ of |Z| (the
    // film's loss tangent known to ±2·10⁻³, `Dielectric::SILICONE`), the
    // floor, not the noise, sets χ² on these strong signals: median ≈ 0.
    println!("clean sensors: {clean_flags} model flags");
    assert!(clean_flags <= 6, "{clean_flags}");
}

#[test]
fn a_skin_of_different_sensors_reads_each_on_its_own_table() {
    // Sixteen sensors made one by one: rest capacitances from 150 to
    // 290 pF (the design range), the paper's electrodes, on the 20 mm/s
    // trapezoid. Each sensor's own table is its linear calibration.
    let c_rest = |s: usize| 150e-12 + 140e-12 * s as f64 / 15.0;
    let params = |s: usize| SensorParams {
        c_rest_farad: c_rest(s),
        ..SensorParams::PAPER
    };
    let own: Vec<CalTable<POINTS>> = (0..SENSORS)
        .map(|s| CalTable::linear(c_rest(s), SensorParams::PAPER.rest_length_mm))
        .collect();
    let tables: [CalTable<POINTS>; SENSORS] = core::array::from_fn(|s| own[s]);
    let profile = |s: usize| Profile::Table(leaked_delay(s as f64 * 0.6));
    let out = run_with(
        Layout::BLOCK_4MS,
        &tables,
        params,
        profile,
        10.0,
        3,
        (&Disturbance::NONE, 0.0),
    );
    // The stretch each record gives against the stretch its sensor's C
    // means, and the same with one table for all.
    let shared = paper_cal();
    for (s, recs) in out.iter().enumerate() {
        let (valid, rms, _) = stats(recs);
        let (mut sq, mut max, mut shared_max) = (0f64, 0f64, 0f64);
        for (r, c) in recs.iter().filter(|(r, _)| r.flags.valid()) {
            let truth = own[s].stretch(*c as f32) as f64;
            let e = r.stretch_mm as f64 - truth;
            sq += e * e;
            max = max.max(e.abs());
            shared_max = shared_max.max((shared.stretch(r.c_farad) as f64 - truth).abs());
        }
        let s_rms = (sq / valid as f64).sqrt();
        println!(
            "sensor {s:2} ({:.0} pF): {valid} valid, C rms {:.3} %, stretch rms {s_rms:.3} mm max {max:.3} mm; one table for all: {shared_max:.1} mm off",
            c_rest(s) * 1e12,
            rms * 100.0
        );
        // Every sensor ≥ 97 % vouched for (at 290 pF the lowest pair
        // leaves the third tone at x ≈ 6.5, where what a one-tone error
        // could hide behind χ² grows, `instrument::joint::hidden`; the
        // 150 pF one keeps 97.3 %, where it kept 99.8 % until the records
        // bounded what one interferer spread over their three tones
        // hides, `instrument::spread`).
        assert!(valid * 1000 >= recs.len() * 970, "sensor {s}: {valid} valid");
        assert!(rms < 1e-3, "sensor {s}: C rms {rms}");
        // 0.1 % of C is 0.1–0.13 mm of a 100 mm sensor stretched 0–30 mm
        // (the largest errors: 4σ, 0.4 % of C, at 30 mm).
        assert!(
            s_rms < 0.1 && max < 0.6,
            "sensor {s}: stretch rms {s_rms} max {max}"
        );
        // The shared table is wrong by the sensors' spread (but for the
        // sensor nearest the paper's).
        if (c_rest(s) / SensorParams::PAPER.c_rest_farad - 1.0).abs() > 0.05 {
            assert!(shared_max > 5.0, "sensor {s}: {shared_max}");
        }
    }
}

/// Each sensor's film read as its own: sixteen sensors of electrodes 1.35
/// times the paper's with short tab leads (ℓ = 0.1, the hand-made skin's
/// slowest), films of tan δ 1–5·10⁻³ (the spread of silicone), on the
/// 20 mm/s trapezoid, each read once on its material's film (3·10⁻³ ±
/// 1·10⁻³) and once on its own tan δ as a calibration stores it
/// (`SensorSettings::loss_tangent`). Where the electrodes' resistance
/// peaks, a fit whose prior sits away from the film pays the distance in
/// χ², and the model check's history takes it for an error it must
/// bound: on its own film every sensor keeps 99 % of its records; on the
/// material's, those at the spread's ends keep fewer. None valid 1 %
/// off either way.
#[test]
fn each_sensor_is_read_on_its_own_film() {
    let film = |s: usize| 1e-3 + 4e-3 * s as f64 / 15.0;
    let params = |s: usize| {
        let mut p = SensorParams::PAPER.with_electrodes_scaled(1.35);
        p.effects = p
            .effects
            .with(Effect::LeadResistance, 0.1)
            .with(Effect::DielectricLoss, film(s));
        p
    };
    let lead = params(0).effects.lead_ratio();
    let profile = |s: usize| Profile::Table(leaked_delay(s as f64 * 0.6));
    let read = |own: bool| {
        let each = Sensors::from_fn(|s| {
            skin_sensor::Sensor::calibrated(*paper_cal(), lead, Fixture::NONE)
                .unwrap()
                .with_loss_tangent(own.then_some(film(s) as f32))
        });
        let out = run_on(
            Layout::BLOCK_4MS,
            &each,
            params,
            profile,
            10.0,
            11,
            (&Disturbance::NONE, 0.0),
        );
        out.iter()
            .map(|recs| {
                let off = recs
                    .iter()
                    .filter(|(r, c)| r.flags.valid() && (r.c_farad as f64 / c - 1.0).abs() > 0.01)
                    .count();
                (stats(recs).0 as f64 / recs.len() as f64, off)
            })
            .collect::<Vec<_>>()
    };
    let (material, own) = (read(false), read(true));
    for s in 0..SENSORS {
        println!(
            "sensor {s:2}, tan δ {:.2}·10⁻³: valid {:.1} % on the material's film, {:.1} % on its own",
            film(s) * 1e3,
            material[s].0 * 100.0,
            own[s].0 * 100.0
        );
        assert_eq!((material[s].1, own[s].1), (0, 0), "sensor {s}: valid 1 % off");
        assert!(own[s].0 >= 0.99, "sensor {s}: {:.3} valid", own[s].0);
    }
    let least = |v: &[(f64, usize)]| v.iter().map(|x| x.0).fold(1.0, f64::min);
    assert!(
        least(&material) < least(&own) - 0.01,
        "the material's film costs the sensors at its spread's ends: {} against {}",
        least(&material),
        least(&own)
    );
}

/// A sensor calibrated, then swapped for another, is not read with the
/// wrong table: the records say so. Every sensor is calibrated as the
/// paper's (its leads and its table); the skin holds others, at rest.
/// Sensors 0–7 rest 15 % lower in C (the spread of hand-made sensors):
/// below the table's span, every stretch record is flagged `OFF_TABLE`.
/// Sensors 8–15 have the paper's C but no tab leads: the two tones
/// disagree with the calibrated line, and the model check flags them
/// `MODEL`. Neither is ever a stretch vouched for.
#[test]
fn a_swapped_sensor_is_flagged_not_read_with_the_wrong_table() {
    let params = |s: usize| {
        let mut p = SensorParams::PAPER;
        if s < 8 {
            p.c_rest_farad *= 0.85;
        } else {
            p.effects = p.effects.with(Effect::LeadResistance, 0.0);
        }
        p
    };
    let out = run(params, |_| Profile::Constant(0.0), 2.0, 5);
    for (s, recs) in out.iter().enumerate() {
        let solved: Vec<&ToneRecord> = recs.iter().map(|(r, _)| r).filter(|r| r.c_farad > 0.0).collect();
        let off = solved.iter().filter(|r| r.flags.has(Flags::OFF_TABLE)).count();
        let model = solved.iter().filter(|r| r.flags.has(Flags::MODEL)).count();
        let vouched = solved.iter().filter(|r| r.flags.stretch_valid()).count();
        println!(
            "sensor {s:2}: {} solved, {off} off the table, {model} model, {vouched} stretch vouched for",
            solved.len()
        );
        assert!(solved.len() > 400, "sensor {s}");
        assert_eq!(vouched, 0, "sensor {s}: a swapped sensor's stretch vouched for");
        if s < 8 {
            assert_eq!(off, solved.len(), "sensor {s}");
        } else {
            assert_eq!(model, solved.len(), "sensor {s}");
        }
    }
    // The same skin calibrated as itself: its stretch is vouched for.
    let own = run(|_| SensorParams::PAPER, |_| Profile::Constant(0.0), 2.0, 5);
    for recs in &own {
        let vouched = recs.iter().filter(|(r, _)| r.flags.stretch_valid()).count();
        assert!(vouched * 10 > recs.len() * 9, "{vouched} of {}", recs.len());
    }
}

/// `record_every`: the reader solves every block and reports one block
/// in every n, the first included; sensors not in use report nothing.
#[test]
fn one_block_in_every_n_is_reported_and_empty_sockets_never() {
    let fe = ArrayFrontEnd::REFERENCE;
    let mut each = Sensors::all(skin_sensor::Sensor::uncalibrated(200e-12));
    each.of_mut(3).in_use = false;
    let settings = ToneSettings {
        record_every: 3,
        ..ToneSettings::new(Layout::BLOCK_4MS, fe.dsp_front_end(), &each)
    };
    let mut reader = ArrayReader::new(Layout::BLOCK_4MS, &each).unwrap();
    let frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let block = reader.demodulate(|a| &frame[a][..]);
    let mut got = vec![];
    for k in 0..7u64 {
        reader.solve(
            &settings,
            k * 4000,
            &block,
            |_| false,
            |r| got.push((k, r.sensor)),
        );
    }
    let blocks: std::collections::BTreeSet<u64> = got.iter().map(|g| g.0).collect();
    assert_eq!(blocks.into_iter().collect::<Vec<_>>(), vec![0, 3, 6]);
    assert_eq!(got.len(), 3 * 15);
    assert!(got.iter().all(|g| g.1 != 3));
}

/// A calibration step's sweep: each block at the pair the sweep names,
/// whatever the policy says; every tone of the comb measured within it,
/// and the line read as well at each pair; then the policy again.
#[test]
fn a_sweep_measures_every_sensor_at_every_pair_then_gives_the_policy_back() {
    use instrument::sweep::Sweep;
    let fe = ArrayFrontEnd::REFERENCE;
    let paper = SensorParams::PAPER;
    let lead = paper.effects.lead_ratio();
    let each = Sensors::all(skin_sensor::Sensor::calibrated(*paper_cal(), lead, Fixture::NONE).unwrap());
    let mut settings = ToneSettings::new(Layout::BLOCK_4MS, fe.dsp_front_end(), &each);
    let mut sensors: Vec<Sensor> = (0..SENSORS).map(|_| Sensor::settled(paper)).collect();
    let mut reader = ArrayReader::new(Layout::BLOCK_4MS, &each).unwrap();
    let mut rng = Rng::new(11);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let hz = Layout::BLOCK_4MS.tones_hz().map(|f| f as f64);
    let mut sweep = Sweep::new();
    let mut pairs = vec![];
    for b in 0..400u64 {
        if b == 200 {
            sweep.start(40);
        }
        settings.sweep = sweep.next_block();
        let t_us = b * 4000 + 2000;
        let mut z = [[num_complex::Complex64::new(0.0, 0.0); TONES]; SENSORS];
        let mut truth = 0.0;
        for (s, sensor) in sensors.iter_mut().enumerate() {
            sensor.advance(&Profile::Constant(10.0), t_us as f64 * 1e-6);
            z[s] = sensor.impedances(&hz);
            truth = sensor.truth().c_farad;
        }
        let clipped = fe.frame(&z, &[Disturbance::NONE; SENSORS], &mut rng, &mut frame);
        let mut recs = vec![];
        reader.read(
            &settings,
            t_us,
            |a| &frame[a][..],
            |i| clipped[i],
            |r| recs.push(r),
        );
        let r = recs[0];
        pairs.push((b, r.f_hz, settings.sweep));
        if b >= 200 && r.flags.valid() {
            assert!((r.c_farad as f64 / truth - 1.0).abs() < 0.005, "block {b}: {r:?}");
        }
    }
    // Before: the policy's pair; during: the sweep's four, 40 blocks each;
    // after: the policy's again.
    let tones = Layout::BLOCK_4MS.tones_hz();
    for (b, f, forced) in &pairs {
        match b {
            200..=359 => {
                let hi = 1 + ((b - 200) / 40) as u8;
                assert_eq!(*forced, Some(hi));
                let [lo, hi] = instrument::tones::ToneChannel::pair_of(hi);
                assert_eq!(*f, [tones[lo], tones[hi]], "block {b}");
            }
            _ => assert_eq!(*forced, None, "block {b}"),
        }
    }
    let during: std::collections::BTreeSet<u32> = pairs[200..360]
        .iter()
        .flat_map(|p| p.1.map(|f| f as u32))
        .collect();
    assert_eq!(during.len(), TONES, "every tone of the comb: {during:?}");
    assert_eq!(pairs[399].1, pairs[199].1, "the policy's pair again");
}

/// An open fixture: each sensor unplugged, its cable left on the front
/// end (0.5–20 pF across it). No record's stretch is valid (the smaller
/// cables are flagged open, the larger read off the table), and every one carries both tones' impedances, 1/(jωC_p) within the block's noise:
/// what `live calibrate --open` fits the cable's capacitance from.
#[test]
fn an_open_fixture_is_flagged_and_its_cable_measured() {
    use num_complex::Complex64;
    let fe = ArrayFrontEnd::REFERENCE;
    let paper = SensorParams::PAPER;
    let each = Sensors::from_fn(|_| {
        skin_sensor::Sensor::calibrated(*paper_cal(), paper.effects.lead_ratio(), Fixture::NONE).unwrap()
    });
    let settings = ToneSettings::new(Layout::BLOCK_4MS, fe.dsp_front_end(), &each);
    let mut reader = ArrayReader::new(Layout::BLOCK_4MS, &each).unwrap();
    let mut rng = Rng::new(11);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let cable = |s: usize| 0.5e-12 + 19.5e-12 * s as f64 / (SENSORS - 1) as f64;
    let hz = Layout::BLOCK_4MS.tones_hz().map(|f| f as f64);
    let z: [[Complex64; TONES]; SENSORS] = core::array::from_fn(|s| {
        hz.map(|f| Complex64::new(0.0, core::f64::consts::TAU * f * cable(s)).inv())
    });
    // Per sensor, per tone: the admittances read.
    let mut y: Vec<Vec<(f32, Complex64)>> = vec![vec![]; SENSORS];
    let (mut records, mut open) = (0, 0);
    for b in 0..250u64 {
        let clipped = fe.frame(&z, &[Disturbance::NONE; SENSORS], &mut rng, &mut frame);
        reader.read(
            &settings,
            b * 4000 + 2000,
            |a| &frame[a],
            |input| clipped[input],
            |rec| {
                records += 1;
                // Flagged: open where the current is below the threshold,
                // else a capacitor of a few pF, far off the stretch table.
                assert!(!rec.flags.stretch_valid(), "{rec:?}");
                open += rec.flags.has(Flags::OPEN) as usize;
                for (f, z) in rec.f_hz.iter().zip(rec.z) {
                    assert!(z.re.is_finite() && z.im.is_finite() && z != dsp_core::Complex32::new(0.0, 0.0));
                    y[usize::from(rec.sensor)].push((*f, Complex64::new(z.re as f64, z.im as f64).inv()));
                }
            },
        );
    }
    assert_eq!(records, 250 * SENSORS);
    assert!(open >= records / 8, "{open} of {records} open");
    for (s, ys) in y.iter().enumerate() {
        // C_p = Im Y / ω, each tone's mean over its records.
        let mut tones: Vec<f32> = ys.iter().map(|(f, _)| *f).collect();
        tones.sort_by(f32::total_cmp);
        tones.dedup();
        for f in tones {
            let at: Vec<f64> = ys
                .iter()
                .filter(|(g, _)| *g == f)
                .map(|(_, y)| y.im / (core::f64::consts::TAU * f as f64))
                .collect();
            let mean = at.iter().sum::<f64>() / at.len() as f64;
            assert!(
                (mean - cable(s)).abs() < 0.02e-12 + 0.01 * cable(s),
                "sensor {s} at {f} Hz: {:.3} pF for {:.3} pF over {} records",
                mean * 1e12,
                cable(s) * 1e12,
                at.len()
            );
        }
    }
}

/// The paper's 20 mm/s trapezoid (0 → 30 mm in 1.5 s, held 3.5 s, back,
/// at rest 3.5 s) from `phase` s into its 10 s period, for a second.
fn at_phase(phase: f64) -> Vec<(f64, f64)> {
    let corners = [(0.0, 0.0), (1.5, 30.0), (5.0, 30.0), (6.5, 0.0), (10.0, 0.0)];
    let at = |t: f64| {
        let t = t.rem_euclid(10.0);
        let k = corners.windows(2).position(|w| t <= w[1].0).unwrap_or(3);
        let ((t0, s0), (t1, s1)) = (corners[k], corners[k + 1]);
        s0 + (s1 - s0) * (t - t0) / (t1 - t0)
    };
    let mut pts = vec![(0.0, at(phase))];
    for p in 0..2 {
        for &(tc, _) in &corners[..4] {
            let t = p as f64 * 10.0 + tc - phase;
            if t > 0.0 && t < 1.0 {
                pts.push((t, at(tc)));
            }
        }
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    pts.push((1.0, at(phase + 1.0)));
    pts
}

/// Cases of [`interferers_never_leave_a_wrong_valid_record`]: `FUZZ_CASES`
/// (default 100 000, 24 million records; `cargo xtask fuzz` runs more).
fn interferer_cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: interferer_cases(),
        failure_persistence: None,
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// An interferer of any frequency (DC to past the inputs' 25 kHz
    /// sample rate: near a tone, between tones, at an alias) and any
    /// amplitude up to the rails, on every sensor's current input, while
    /// the sensors stretch on the paper's trapezoid from a random phase,
    /// their electrodes 0.5–1.5 times the paper's: no record flagged
    /// valid is more than 1 % off the truth.
    #[test]
    fn interferers_never_leave_a_wrong_valid_record(
        hz in 0.5f32..40_000.0,
        log_counts in -1.0f32..4.5,
        phase in 0.0f32..1.0,
        start in 0.0f64..10.0,
        r_scale in 0.5f64..1.5,
        seed in proptest::prelude::any::<u64>(),
    ) {
        let case = Interfered { hz, log_counts, phase, start, r_scale, seed };
        if let Err(e) = interfered_for(&case, 0.06) {
            proptest::prop_assert!(false, "{e}");
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: (interferer_cases() / 20).max(8),
        failure_persistence: None,
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// A persistent interferer on one of the comb's tones (within 125 Hz,
    /// half a bin, of it, or of its alias about the 25 kHz sample rate),
    /// long enough for the channels to move off it (0.6 s,
    /// `instrument::avoid`) and fit its sideband (`instrument::sideband`),
    /// while the sensors stretch: no record flagged valid is more than
    /// 1 % off, before the move or after it. (`FUZZ_CASES` / 20 cases, as
    /// the two after it. It found [`a_rescued_pair_beside_an_alias_is_not_vouched_for`],
    /// [`a_shift_shared_by_the_pair_is_bounded_as_shared`] and
    /// [`an_interferer_spread_over_two_tones_is_bounded_as_spread`]:
    /// docs/accuracy.md.)
    #[test]
    fn moved_channels_never_leave_a_wrong_valid_record(
        tone in 0usize..TONES,
        off_hz in -125.0f32..125.0,
        alias in proptest::prelude::any::<bool>(),
        log_counts in 0.0f32..3.5,
        phase in 0.0f32..1.0,
        start in 0.0f64..10.0,
        r_scale in 0.5f64..1.5,
        seed in proptest::prelude::any::<u64>(),
    ) {
        let hz = near_tone(tone, off_hz, alias);
        let case = Interfered { hz, log_counts, phase, start, r_scale, seed };
        if let Err(e) = interfered_for(&case, 0.6) {
            proptest::prop_assert!(false, "{e}");
        }
    }

    /// An interferer in a tone's bin (within 125 Hz of it, or of its
    /// alias) that starts after the model check's history of calm blocks
    /// is full (`instrument::joint::Quiet`, 256 blocks), of any amplitude
    /// from 0.1 counts (a quarter of a tone's noise σ) to 3000, the electrodes
    /// 0.5–2 times the paper's and stretching: the records that history
    /// vouches for before it has seen the interferer are never 1 % off.
    /// (Each case is up to 1.4 s of sixteen sensors.)
    #[test]
    fn late_interferers_never_leave_a_wrong_valid_record(
        tone in 0usize..TONES,
        off_hz in proptest::prop_oneof![-2.0f32..2.0, -125.0f32..125.0],
        alias in proptest::prelude::any::<bool>(),
        log_counts in proptest::prop_oneof![-0.5f32..1.5, -1.0f32..3.5],
        phase in 0.0f32..1.0,
        start in 0.0f64..10.0,
        onset_s in 1.05f64..1.2,
        r_scale in 0.5f64..2.0,
        seed in proptest::prelude::any::<u64>(),
    ) {
        let hz = near_tone(tone, off_hz, alias);
        let during = (onset_s, onset_s + 0.2);
        let case = Interfered { hz, log_counts, phase, start, r_scale, seed };
        if let Err(e) = interfered_from(&case, during) {
            proptest::prop_assert!(false, "{e}");
        }
    }

    /// Sensors as a calibration leaves them: 0–20 pF of cable, tab leads
    /// from none to the paper's, films of tan δ 1–5·10⁻³, each known to
    /// the device as its calibration knows it (C_p within 0.02 pF, tan δ
    /// within 0.1·10⁻³, or the film left to its material's), the
    /// electrodes 0.5–2 times the paper's and stretching, under an
    /// interferer of any frequency and amplitude (a hundredth of a count
    /// in half the cases: none to speak of): no record
    /// flagged valid is more than 1 % off. (Each tone's noise is taken
    /// behind the cable, `Fixture::take_out`, and each sensor's film is
    /// its own, `Sensor::film`: what these cases hold to the truth.)
    #[test]
    fn wired_sensors_never_leave_a_wrong_valid_record(
        hz in 0.5f32..40_000.0,
        log_counts in proptest::prop_oneof![-3.0f32..-2.0, -1.0f32..4.5],
        phase in 0.0f32..1.0,
        start in 0.0f64..10.0,
        r_scale in 0.5f64..2.0,
        seed in proptest::prelude::any::<u64>(),
    ) {
        let mut rng = Rng::new(seed ^ 0x5eed);
        let wiring: [Wiring; SENSORS] = core::array::from_fn(|_| Wiring::draw(&mut rng));
        let case = Interfered { hz, log_counts, phase, start, r_scale, seed };
        if let Err(e) = wired_for(&wiring, &case) {
            proptest::prop_assert!(false, "{e}");
        }
    }
}

/// One sensor's wiring and film, and what its calibration knows of them.
#[derive(Clone, Copy, Debug)]
struct Wiring {
    cable_farad: f64,
    leads: f64,
    loss: f64,
    known_cable_farad: f32,
    known_loss: Option<f32>,
}

impl Wiring {
    fn draw(rng: &mut Rng) -> Self {
        let cable_farad = 20e-12 * rng.uniform();
        let loss = 1e-3 + 4e-3 * rng.uniform();
        let known_loss = (rng.uniform() < 0.75).then(|| (loss + 1e-4 * (2.0 * rng.uniform() - 1.0)) as f32);
        Self {
            cable_farad,
            leads: 0.6415 * rng.uniform(),
            loss,
            known_cable_farad: (cable_farad + 0.02e-12 * (2.0 * rng.uniform() - 1.0)).max(0.0) as f32,
            known_loss,
        }
    }
}

/// A case of [`wired_sensors_never_leave_a_wrong_valid_record`]: 0.3 s,
/// long enough for the model check's history to bound the last records
/// (`instrument::joint::QUIET_MIN_BLOCKS`).
fn wired_for(wiring: &[Wiring; SENSORS], case: &Interfered) -> Result<(), String> {
    let (hum, r_scale) = (case.interferer(), case.r_scale);
    let params = |s: usize| {
        let w = wiring[s];
        let mut p = SensorParams::PAPER.with_electrodes_scaled(r_scale);
        p.effects = instrument::effects::EffectSet::NONE
            .with(Effect::LeadResistance, w.leads)
            .with(Effect::ParasiticCapacitance, w.cable_farad)
            .with(Effect::DielectricLoss, w.loss);
        p
    };
    let each = Sensors::from_fn(|s| {
        let w = wiring[s];
        let fixture = Fixture {
            parallel_farad: w.known_cable_farad,
            series_ohm: 0.0,
        };
        skin_sensor::Sensor::calibrated(*paper_cal(), params(s).effects.lead_ratio(), fixture)
            .unwrap()
            .with_loss_tangent(w.known_loss)
    });
    let table = at_phase(case.start);
    let out = run_on(
        Layout::BLOCK_4MS,
        &each,
        params,
        |_| Profile::Table(&table),
        0.3,
        case.seed,
        (&hum, 0.0),
    );
    none_off(&out, |s| {
        format!(
            "sensor {s} ({:?}), {} Hz of {} counts",
            wiring[s], case.hz, hum.hum_i
        )
    })
}

/// A case the fuzz target found once it tried interferers to 125 Hz
/// from a tone: an alias of 396.97 Hz, 103 Hz below the 500 Hz tone,
/// of 21.4 counts, on sensors whose electrodes are 1.38 times the
/// paper's: sensor 6's record, rescued from 250 Hz and 1 kHz without
/// 500 Hz, was vouched for 1.26 % off behind a pair χ² of 0.39. An
/// interferer 0.4 of a bin below 500 Hz leaks into 250 Hz up to five
/// times what the residual shows; the bound of a record rescued without
/// a tone takes its neighbours' share so (`Layout::near_leak`).
#[test]
fn a_rescued_pair_beside_an_alias_is_not_vouched_for() {
    let hz = near_tone(1, -103.033_226, true);
    interfered_for(
        &Interfered {
            hz,
            log_counts: 1.330_690_5,
            phase: 0.506_403_86,
            start: 0.137_238_927_957_033_02,
            r_scale: 1.380_016_162_183_304,
            seed: 5_371_320_281_391_996_586,
        },
        0.6,
    )
    .unwrap();
}

/// A case the moved-channel target found tried to 125 Hz: an interferer
/// 120 Hz below the 500 Hz tone, of 19 counts, on electrodes 1.33 times
/// the paper's: a record rescued from 250 Hz and 1 kHz was vouched for
/// 1.10 % off. The interferer shifts both tones of the pair at once; the
/// bound took the larger shift alone.
#[test]
fn a_shift_shared_by_the_pair_is_bounded_as_shared() {
    let hz = near_tone(1, -119.703_964, false);
    interfered_for(
        &Interfered {
            hz,
            log_counts: 1.277_844_1,
            phase: 0.434_864_67,
            start: 0.940_157_405_638_630_7,
            r_scale: 1.327_724_798_406_766_2,
            seed: 14_070_057_087_953_212_397,
        },
        0.6,
    )
    .unwrap();
}

/// A case the moved-channel target found tried to 125 Hz: an interferer
/// 66 Hz below the 250 Hz tone (0.26 of a bin), of 12.7 counts, on
/// electrodes 1.49 times the paper's: sensor 12's record at 326 ms was
/// vouched for 1.02 % off behind quiet inputs. The interferer puts a
/// fifth of its error into 500 Hz, nearly in phase, which hides twice
/// as much behind χ² as an error at one tone; the record's bound takes
/// every such spread (`instrument::spread`).
#[test]
fn an_interferer_spread_over_two_tones_is_bounded_as_spread() {
    let hz = near_tone(0, -65.996_02, false);
    interfered_for(
        &Interfered {
            hz,
            log_counts: 1.104_828,
            phase: 0.251_562_86,
            start: 0.0,
            r_scale: 1.489_338_459_897_335_6,
            seed: 8_840_742_424_399_232_566,
        },
        0.6,
    )
    .unwrap();
}

/// `off_hz` from the 4 ms comb's tone `tone`, or (`alias`) from its alias
/// about the inputs' sample rate, Hz.
fn near_tone(tone: usize, off_hz: f32, alias: bool) -> f32 {
    let at = Layout::BLOCK_4MS.tone_hz(tone) + off_hz;
    if alias {
        RATE_HZ as f32 - at
    } else {
        at
    }
}

/// A case the fuzz target found: an interferer at 24 495.9 Hz, the alias
/// of 504.1 Hz, 4 Hz from the 500 Hz tone, of 12.2 counts, on sensors
/// whose electrodes are 1.48 times the paper's: with the line fitted to
/// the pair alone, sensor 1's record was vouched for 1.03 % off behind a
/// χ² of 6.2 (two tones let an error at one of them move C 5 times as
/// far per unit of √χ² as three do). The tone between the pair is fitted
/// too: it sees what the pair hides.
#[test]
fn an_alias_next_to_the_lower_tone_is_not_vouched_for() {
    let case = Interfered {
        hz: 24_495.941,
        log_counts: 1.0869603,
        phase: 0.87565297,
        start: 6.889701292577919,
        r_scale: 1.480042810892388,
        seed: 10068520996498014150,
    };
    interfered_for(&case, 0.06).unwrap();
}

/// One case of [`interferers_never_leave_a_wrong_valid_record`] (0.06 s)
/// or of [`moved_channels_never_leave_a_wrong_valid_record`], over
/// `duration_s`: every valid record within 1 % of its truth, or the first
/// that is not.
fn interfered_for(case: &Interfered, duration_s: f64) -> Result<(), String> {
    interfered_from(case, (0.0, duration_s))
}

/// [`interfered_for`] with the interferer on from `onset_s` to the end of
/// the run, `until_s`: a clean skin before it.
fn interfered_from(case: &Interfered, (onset_s, duration_s): (f64, f64)) -> Result<(), String> {
    let (hum, r_scale) = (case.interferer(), case.r_scale);
    let params = |_| SensorParams::PAPER.with_electrodes_scaled(r_scale);
    let table = at_phase(case.start);
    let out = run_with(
        Layout::BLOCK_4MS,
        &[*paper_cal(); SENSORS],
        params,
        |_| Profile::Table(&table),
        duration_s,
        case.seed,
        (&hum, onset_s),
    );
    none_off(&out, |s| {
        format!("sensor {s}, {} Hz of {} counts", case.hz, hum.hum_i)
    })
}

/// A case of the interferer targets: an interferer of `hz` and
/// 10^`log_counts` counts at `phase` (turns) on every sensor's current
/// input, the sensors `start` s into the paper's cycle, their electrodes
/// `r_scale` times the paper's, the front end's noise drawn from `seed`.
#[derive(Clone, Copy, Debug)]
struct Interfered {
    hz: f32,
    log_counts: f32,
    phase: f32,
    start: f64,
    r_scale: f64,
    seed: u64,
}

impl Interfered {
    /// The interferer on a sensor's current input.
    fn interferer(&self) -> Disturbance {
        Disturbance {
            hum_hz: self.hz,
            hum_i: 10f32.powf(self.log_counts),
            hum_phase_turns: self.phase,
            ..Disturbance::NONE
        }
    }
}

/// Every valid record of `out` within 1 % of its truth, or the first that
/// is not, named by `what(sensor)`.
fn none_off(out: &Run, what: impl Fn(usize) -> String) -> Result<(), String> {
    for (s, recs) in out.iter().enumerate() {
        for (r, c) in recs.iter().filter(|(r, _)| r.flags.valid()) {
            if (r.c_farad as f64 / c - 1.0).abs() >= 0.01 {
                return Err(format!(
                    "{}: C {:.2} pF vs {:.2} pF ({r:?})",
                    what(s),
                    r.c_farad * 1e12,
                    c * 1e12
                ));
            }
        }
    }
    Ok(())
}

/// Rows short of a block (a DMA half cut short, a layout's block read
/// through another's rows) are no block: every record flagged open, no
/// line, no panic; and a 1 ms reader reads the first 25 rows of a frame
/// only, whatever the rest holds.
#[test]
fn rows_short_of_a_block_read_as_no_excitation() {
    use instrument::reader::Demodulated;
    let layout = Layout::BLOCK_1MS;
    let fe = ArrayFrontEnd::reference(layout);
    let paper = SensorParams::PAPER;
    let each = Sensors::all(
        skin_sensor::Sensor::calibrated(*paper_cal(), paper.effects.lead_ratio(), Fixture::NONE).unwrap(),
    );
    let settings = ToneSettings::new(layout, fe.dsp_front_end(), &each);
    let mut reader = ArrayReader::new(layout, &each).unwrap();
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let hz = layout.tones_hz().map(|f| f as f64);
    let z = [Sensor::settled(paper).impedances(&hz); SENSORS];
    let clipped = fe.frame(&z, &[Disturbance::NONE; SENSORS], &mut Rng::new(3), &mut frame);
    let mut recs = vec![];
    reader.read(
        &settings,
        500,
        |a| &frame[a][..24],
        |i| clipped[i],
        |r| recs.push(r),
    );
    assert_eq!(recs.len(), SENSORS);
    assert!(
        recs.iter().all(|r| r.flags.has(Flags::OPEN) && r.c_farad == 0.0),
        "{recs:?}"
    );
    // The whole frame's rows given: the first 25 are the block, the
    // rest (here garbage) is not read.
    let mut whole = Demodulated::EMPTY;
    reader.demodulate_into(|a| layout.rows(&frame[a]), &mut whole);
    for rows in frame.iter_mut() {
        for row in rows[25..].iter_mut() {
            *row = [i16::MAX; 4];
        }
    }
    let mut again = Demodulated::EMPTY;
    reader.demodulate_into(|a| &frame[a][..], &mut again);
    assert_eq!(whole.i.map(|t| t.x), again.i.map(|t| t.x));
    assert_eq!(whole.v.n, 25);
}

/// Where a clean skin loses records while it stretches (the paper's
/// electrodes at 50 mm/s, twice them at 20 mm/s), the policy is already
/// at the comb's lowest three (250 Hz, 500 Hz and 1 kHz) on every one of
/// them: what would keep them is a lower tone or more signal, not an
/// earlier step down.
#[test]
fn records_lost_while_stretching_are_read_at_the_lowest_pair() {
    let layout = Layout::BLOCK_4MS;
    // The pair's lower tone and the third tone's highest.
    let (lowest, third) = (layout.tone_hz(0), layout.tone_hz(2));
    for (rate, r_scale) in [(50.0, 1.0), (20.0, 2.0)] {
        let params = |_| SensorParams::PAPER.with_electrodes_scaled(r_scale);
        let profile = |_| Profile::paper(rate);
        let out = run_with(
            Layout::BLOCK_4MS,
            &[*paper_cal(); SENSORS],
            params,
            profile,
            4.0,
            7,
            (&Disturbance::NONE, 0.0),
        );
        let lost: Vec<&ToneRecord> = out
            .iter()
            .flatten()
            .map(|(r, _)| r)
            // (Past the first 0.1 s, where the policy steps down from
            // its start.)
            .filter(|r| !r.flags.valid() && r.t_us >= 100_000)
            .collect();
        assert!(!lost.is_empty(), "{rate} mm/s, {r_scale}×: none lost");
        for r in lost {
            assert_eq!(r.f_hz[0], lowest, "{rate} mm/s, {r_scale}×: {r:?}");
            assert!(r.f_hz[1] <= third, "{rate} mm/s, {r_scale}×: {r:?}");
        }
    }
}

/// A case the fuzz found (10⁵ cases): an alias at 404 Hz, between the
/// 250 and 500 Hz tones, leaks into both; the pair of those two passes
/// its check and the pairs with the clean 1 kHz tone fail tenfold, but
/// the 1 kHz tone is no further from the pair's line than a disturbance
/// between the bins could put it (`Layout::leak_ratio`), so the record
/// is not rescued (it was, 1.14 % off).
#[test]
fn an_alias_between_the_lowest_tones_is_never_rescued() {
    interfered_for(
        &Interfered {
            hz: 24595.617,
            log_counts: 1.4140357,
            phase: 0.046236068,
            start: 0.0,
            r_scale: 1.336_518_655_006_492,
            seed: 796_531_775_277_614_506,
        },
        0.06,
    )
    .unwrap();
}
