//! Closing the loop on the device, end to end in QEMU: the simulated
//! sensors have an undeclared effect (12 pF of cable capacitance); the
//! firmware records a data set at fixed frequencies; it is decoded into the
//! interchange format; `identify` finds the effect; the firmware, given the
//! wiring calibration as arguments, reports the line capacitance again.
//! Before, the two tones' model check flags the records (none is vouched
//! for wrong); after, they are valid and right.

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options};
use host_sim::model::Effect;
use host_sim::recording::{write_dataset, Roles};
use instrument::faults::Flags;
use qemu_tests::records::{run_scenario_args, LoggedRecord};

/// RMS and max of the corrected C against the truth (pF) on the channels'
/// valid records.
fn error(recs: &[LoggedRecord], channels: &[u8]) -> (f64, f64, usize) {
    let e: Vec<f64> = recs
        .iter()
        .filter(|r| channels.contains(&r.sensor) && r.valid() && r.c_pf > 0.0)
        .filter_map(|r| r.truth.map(|t| r.c_pf - t.c_pf))
        .collect();
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    (rms, e.iter().fold(0.0f64, |m, v| m.max(v.abs())), e.len())
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn identified_wiring_calibrates_the_firmware() {
    let tmp = tempfile::tempdir().unwrap();
    // 1. Record a data set with the firmware.
    let (run, recs) = run_scenario_args(&["identify"]).unwrap();
    assert_eq!(run.code, Some(0), "{}", run.stdout);
    let roles = Roles {
        traces: Some(vec![0, 1, 2]),
        statics: Some(vec![3, 4, 5, 6, 7]),
    };
    let w = write_dataset(tmp.path(), &recs, &roles).unwrap();
    assert!(w.rows > 1000 && w.calibration_points == 5, "{w:?}");
    // 2. Identify the effect.
    let report = identify(&read_dir(tmp.path()).unwrap(), Options::default()).unwrap();
    println!("{}", report.markdown("firmware recording", None));
    let found = report.accepted.as_ref().expect("an effect found");
    assert_eq!(
        found.effects,
        [Effect::ParasiticCapacitance],
        "{}",
        report.verdict()
    );
    let cp = found.params.get(Effect::ParasiticCapacitance);
    assert!((cp - 12e-12).abs() < 0.5e-12, "{cp} F");
    // 3. The firmware without and with the wiring calibration.
    let (run, before) = run_scenario_args(&["hidden"]).unwrap();
    assert_eq!(run.code, Some(0), "{}", run.stdout);
    // The static effects found, as the firmware's id=value arguments.
    let wiring: Vec<String> = found
        .effects
        .iter()
        .filter(|e| e.is_static())
        .map(|&e| format!("{}={:e}", e.id(), found.params.get(e)))
        .collect();
    let mut args = vec!["hidden"];
    args.extend(wiring.iter().map(String::as_str));
    let (run, after) = run_scenario_args(&args).unwrap();
    assert_eq!(run.code, Some(0), "{}", run.stdout);
    let (b, a) = (error(&before, &[0, 1]), error(&after, &[0, 1]));
    // Before: the records the two tones measured (past settling), and
    // how many the model check flagged.
    let measured: Vec<&LoggedRecord> = before
        .iter()
        .filter(|r| [0, 1].contains(&r.sensor) && r.cs_pf > 0.0 && r.c_pf > 0.0)
        .collect();
    let model = measured.iter().filter(|r| r.flags.has(Flags::MODEL)).count();
    println!(
        "channels 0-1: before, {model} of {} records flagged MODEL, {} valid (RMS {:.3} pF, max {:.3} pF); after, {} valid, RMS {:.3} pF max {:.3} pF",
        measured.len(),
        b.2,
        b.0,
        b.1,
        a.2,
        a.0,
        a.1
    );
    assert!(
        measured.len() > 500 && model * 10 >= measured.len() * 9,
        "before: {model} of {} flagged",
        measured.len()
    );
    assert!(b.1 < 0.01 * 260.0, "before: a valid record {} pF off", b.1);
    assert!(a.2 > 500 && a.0 < 0.5, "after: {} valid, RMS {} pF", a.2, a.0);
}
