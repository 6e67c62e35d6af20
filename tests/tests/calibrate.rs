//! The calibration workflow in QEMU (`qemu_tests::calibration`): sixteen
//! hand-made sensors calibrated over the link, QEMU restarted, the
//! settings back, each sensor's stretch within 0.1 mm RMS over the whole
//! trapezoid (the goal; docs/live.md has the measured figures) and 0.05 mm where
//! the skin holds still, and no record marked valid more than 1 % off in
//! C.

use live::calibrate::Outcome;
use skin_sim::sensor::SensorParams;

#[test]
#[ignore = "long: cargo xtask test --full"]
fn a_skin_of_hand_made_sensors_is_calibrated_over_the_link() {
    let tmp = tempfile::tempdir().unwrap();
    let w = qemu_tests::calibration::run(tmp.path()).unwrap();
    println!("{}\n{}", w.report, w.table());
    assert!(
        w.came_back,
        "the restarted device names the set written (generation {})",
        w.generation
    );
    assert_eq!(w.generation, 1);
    // Each hold a calibration step: the device swept its tone pairs.
    assert_eq!(w.sweeps.len(), w.holds.len(), "{:?}", w.sweeps);
    assert!(w.sweeps.iter().all(|s| s == "swept"), "{:?}", w.sweeps);
    // Each sensor fitted, its wiring and leads where the simulation put
    // them (what the fit's C rests on): the sweep at each hold measures
    // every sensor at all five tones.
    for (s, o) in w.outcomes.iter().enumerate() {
        let Outcome::Fitted(f) = o else {
            panic!("sensor {s}: {o:?}");
        };
        let truth = SensorParams::hand_made(s);
        let lead = truth.effects.lead_ratio() as f64;
        let cp = truth
            .effects
            .get(instrument::effects::Effect::ParasiticCapacitance);
        assert!(
            (f.values[0] - lead).abs() < 0.003 + 3.0 * f.sigma[0].max(0.0),
            "sensor {s}: ℓ {:.4} ± {:.4}, truth {lead:.4}",
            f.values[0],
            f.sigma[0]
        );
        assert!(
            (f.values[2] - cp).abs() < 0.1e-12,
            "sensor {s}: C_p {:.2} pF, truth {:.2} pF",
            f.values[2] * 1e12,
            cp * 1e12
        );
        assert!(w.set.sensors[s].calibrated);
        // And its film, stored for the device to fit each record's line
        // on (`SensorSettings::loss_tangent`).
        let loss = truth.effects.get(instrument::effects::Effect::DielectricLoss);
        let stored = w.set.sensors[s].loss_tangent;
        assert!(
            stored.is_some_and(|t| (t as f64 - loss).abs() < 1e-4 + 3.0 * f.sigma[3]),
            "sensor {s}: tan δ {stored:?} (fit {:.2e} ± {:.1e}), truth {loss:.2e}",
            f.values[3],
            f.sigma[3]
        );
    }
    for s in &w.sensors {
        // What the calibration controls: the table and the line's C,
        // seen where the skin holds still.
        assert!(
            s.after_still_moving_mm.0 <= 0.05,
            "sensor {}: {:.3} mm RMS held still",
            s.sensor,
            s.after_still_moving_mm.0
        );
        // Moving, the slowest electrodes (read at the lowest tones, near
        // the line's peak of D) add the noise their records state: the
        // comb's 1/√f amplitudes keep it down (with a flat comb the
        // worst sensor was 0.107 mm).
        assert!(
            s.after_mm <= 0.1,
            "sensor {}: {:.3} mm RMS after",
            s.sensor,
            s.after_mm
        );
        assert_eq!(
            s.c_off.1, 0,
            "sensor {}: valid records > 1 % off in C after",
            s.sensor
        );
        // Every sensor keeps 95 % of its records while the skin moves
        // (the goal). The slowest electrodes, 3.3 MΩ at rest, sensors 5
        // and 11, kept 89.2 % and 91.0 % while each record's noise behind
        // the cable was taken as measured (sensor 11's 19.9 pF grow it
        // 1.3-fold) and every film was fitted on its material's tan δ
        // (sensor 5's is 1.4·10⁻³, 1.6σ from it): both read as misfit at
        // the resistance's peak.
        let moving = &s.moving;
        assert!(
            moving.valid * 100 >= moving.records * 95 && s.after_valid.0 * 100 >= s.after_valid.1 * 95,
            "sensor {}: {} of {} valid, moving {moving} ({})",
            s.sensor,
            s.after_valid.0,
            s.after_valid.1,
            moving.why()
        );
    }
    // Before, the reference sensor's constants read these sensors wrong.
    let worse = w.sensors.iter().filter(|s| s.before_all_mm > 1.0).count();
    assert!(worse >= 12, "{}", w.table());
}
