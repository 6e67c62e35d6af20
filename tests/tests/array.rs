//! The array firmware (`skin-array`) in QEMU: sixteen sensors read at
//! once, every one 250 times a second, under the paper's stretching; the
//! model check on undeclared wiring; mains hum.

use instrument::faults::Flags;
use qemu_tests::records::{run_array, ToneRec};

/// (valid records, RMS and max relative error of C over them).
fn stats(recs: &[&ToneRec]) -> (usize, f64, f64) {
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
        let mine: Vec<&ToneRec> = recs.iter().filter(|r| r.rec.channel == s).collect();
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
}

#[test]
fn the_model_check_tells_undeclared_wiring_from_clean_sensors() {
    let (run, recs) = run_array("check").unwrap();
    run.ok().unwrap();
    for s in 0..16u8 {
        let mine: Vec<&ToneRec> = recs
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
        let during: Vec<&ToneRec> = recs
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
