//! Closing the loop on the device, end to end in QEMU: the simulated
//! sensors have an undeclared effect (12 pF of cable capacitance); the
//! firmware records a data set at fixed frequencies; it is decoded into the
//! interchange format; `identify` finds the effect; the firmware, given the
//! wiring calibration as arguments, reports the line capacitance again, and
//! the error against the truth is compared before and after.

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options};
use host_sim::model::Effect;
use host_sim::recording::{write_dataset, Roles};
use qemu_tests::records::{run_scenario_args, LoggedRecord};

/// RMS and max of the corrected C against the truth (pF) on the channels'
/// valid records.
fn error(recs: &[LoggedRecord], channels: &[u8]) -> (f64, f64, usize) {
    let e: Vec<f64> = recs
        .iter()
        .filter(|r| channels.contains(&r.channel) && r.valid() && r.c_pf > 0.0)
        .filter_map(|r| r.truth.map(|t| r.c_pf - t.c_pf))
        .collect();
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
    (rms, e.iter().fold(0.0f64, |m, v| m.max(v.abs())), e.len())
}

#[test]
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
    println!(
        "corrected C vs truth, channels 0-1: before RMS {:.3} pF max {:.3} pF ({} records); after RMS {:.3} pF max {:.3} pF ({} records)",
        b.0, b.1, b.2, a.0, a.1, a.2
    );
    assert!(b.2 > 500 && a.2 > 500);
    assert!(b.0 > 5.0, "before: the cable shows ({} pF)", b.0);
    assert!(
        a.0 < 0.5 && a.0 * 10.0 < b.0,
        "after {} pF vs before {} pF",
        a.0,
        b.0
    );
}
