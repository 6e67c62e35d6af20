//! The array firmware (`skin-array`) in QEMU: sixteen sensors read at
//! once, every one 250 times a second, under the paper's stretching; the
//! model check on undeclared wiring; mains hum.

use instrument::faults::Flags;
use qemu_tests::records::{run_array, LoggedToneRecord};

/// (valid records, RMS and max relative error of C over them).
fn stats(recs: &[&LoggedToneRecord]) -> (usize, f64, f64) {
    let e: Vec<f64> = recs
        .iter()
        .filter(|r| r.rec.flags.valid())
        .filter_map(|r| r.c_error())
        .collect();
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    (e.len(), rms, e.iter().fold(0.0f64, |m, v| m.max(v.abs())))
}

#[test]
fn sixteen_sensors_250_times_a_second_within_a_thousandth() {
    let (run, recs) = run_array("paper").unwrap();
    let run = run.ok().unwrap();
    assert!(run.stdout.contains("end"), "{}", run.stdout);
    assert!(!run.stdout.contains("overrun"));
    // The record queue (heapless SPSC, four blocks) never dropped one.
    assert!(!run.stdout.contains("drops"), "records dropped");
    let seconds = 10.0;
    for s in 0..16u8 {
        let mine: Vec<&LoggedToneRecord> = recs.iter().filter(|r| r.rec.channel == s).collect();
        let (valid, rms, max) = stats(&mine);
        let span = mine.last().unwrap().t_s() - mine[0].t_s();
        let rate = (mine.len() - 1) as f64 / span;
        println!(
            "sensor {s:2}: {} records ({rate:.1}/s), {valid} valid, C rms {:.3} % max {:.3} %",
            mine.len(),
            rms * 100.0,
            max * 100.0
        );
        assert!(
            mine.len() as f64 >= 0.99 * 250.0 * seconds,
            "sensor {s}: {}",
            mine.len()
        );
        assert!(rate >= 250.0 - 1e-6, "sensor {s}: {rate}/s");
        assert!(valid as f64 >= 0.98 * mine.len() as f64, "sensor {s}: {valid}");
        assert!(rms <= 1e-3, "sensor {s}: rms {rms}");
        // Every record has its truth.
        assert!(mine.iter().all(|r| r.truth.is_some()));
    }
    // The README's headline and the accuracy page show this run's figures.
    let sensors = qemu_tests::summary::sensors(&recs).unwrap();
    figures::check(
        "docs/figures.md",
        "headline-array",
        &qemu_tests::summary::sensor_headline(&sensors),
    )
    .unwrap();
    figures::check(
        "docs/accuracy.md",
        "array-sensors",
        &qemu_tests::summary::sensor_table(&sensors),
    )
    .unwrap();
}

#[test]
fn the_model_check_tells_undeclared_wiring_from_clean_sensors() {
    let (run, recs) = run_array("check").unwrap();
    run.ok().unwrap();
    for s in 0..16u8 {
        let mine: Vec<&LoggedToneRecord> = recs
            .iter()
            .filter(|r| r.rec.channel == s && r.rec.chi2 > 0.0)
            .collect();
        let model = mine.iter().filter(|r| r.rec.flags.has(Flags::MODEL)).count();
        println!("sensor {s:2}: model flags {model} of {}", mine.len());
        match s {
            0..=5 => assert!(model <= 1, "clean sensor {s}: {model}"),
            // The contact shows where the tone pair is 4× apart: most records.
            6..=10 => assert!(model as f64 >= 0.5 * mine.len() as f64, "contact {s}: {model}"),
            _ => assert!(model as f64 >= 0.99 * mine.len() as f64, "parasitic {s}: {model}"),
        }
    }
}

#[test]
fn hum_is_flagged_and_never_passes_as_valid() {
    let (run, recs) = run_array("hum").unwrap();
    run.ok().unwrap();
    for s in 0..16u8 {
        let during: Vec<&LoggedToneRecord> = recs
            .iter()
            .filter(|r| r.rec.channel == s && (1.0..2.0).contains(&r.t_s()))
            .collect();
        let flagged = during.iter().filter(|r| !r.rec.flags.valid()).count();
        let (_, rms, max) = stats(&during);
        println!(
            "sensor {s:2}: {flagged} of {} flagged during the hum, valid C rms {:.3} % max {:.3} %",
            during.len(),
            rms * 100.0,
            max * 100.0
        );
        // What passes as valid is right, hum or not.
        assert!(max < 5e-3, "sensor {s}: a valid record {max} off");
        if (6..=7).contains(&s) {
            // 300 and 1000 counts of hum: every record flagged.
            assert_eq!(flagged, during.len(), "sensor {s}");
        }
    }
}

#[test]
fn identify_reads_an_array_recording_and_finds_the_hidden_parasitic() {
    // Every sensor with 12 pF of cable capacitance the firmware was not
    // told of: the model check flags every record, and the recording,
    // decoded into a data set (a trace per sensor and tone, the held
    // sensors as calibration), tells `identify` what it is.
    let (run, recs) = run_array("identify").unwrap();
    let run = run.ok().unwrap();
    let flagged = recs.iter().filter(|r| r.rec.flags.has(Flags::MODEL)).count();
    assert!(
        flagged as f64 > 0.99 * recs.len() as f64,
        "{flagged} of {}",
        recs.len()
    );
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("array.log");
    std::fs::write(&log, &run.stdout).unwrap();
    let ds = tmp.path().join("ds");
    let text = qemu_tests::host_sim(&[
        "decode".as_ref(),
        log.as_os_str(),
        "--out".as_ref(),
        ds.as_os_str(),
    ]);
    assert!(text.contains("12 calibration points"), "{text}");
    let id = tmp.path().join("id");
    qemu_tests::host_sim(&[
        "identify".as_ref(),
        ds.as_os_str(),
        "--out".as_ref(),
        id.as_os_str(),
    ]);
    let report = std::fs::read_to_string(id.join("report.md")).unwrap();
    let verdict = report.lines().find(|l| l.starts_with("**")).unwrap_or_default();
    println!("{verdict}");
    assert!(
        verdict.contains("explained by parasitic_capacitance"),
        "{verdict}"
    );
    let pf: f64 = verdict
        .split("parasitic_capacitance_pf = ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN);
    assert!((pf - 12.0).abs() < 0.5, "{pf} pF");
}
