//! A skin of four array boards in one `live` session: their clocks
//! started seconds apart and drifting by tens of ppm each way, each
//! board's stream sent down its own socket in real time
//! (`qemu_tests::skin_run`). Every record must come out keyed by board
//! and sensor, and the records of all boards must sit on one time axis
//! within 1 ms of each other.

use qemu_tests::skin_run::{self, FOUR};

/// Seconds of each board's run: past `live::clock::DRIFT_SPAN_S`, so
/// that each board's drift is fitted.
const SECONDS: u32 = 12;

#[test]
#[ignore = "long: four array images in QEMU, then 12 s in real time (the full pass)"]
fn four_boards_with_drifting_clocks_are_aligned_within_a_millisecond() {
    let streams = skin_run::streams(&FOUR, SECONDS, 250).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let run = skin_run::session(&tmp.path().join("skin"), &FOUR, streams, 4000, None).unwrap();
    // Every board complete, its device the one the skin names.
    for (b, spec) in run.boards.iter().zip(&FOUR) {
        assert!(
            matches!(b.outcome, live::Outcome::Complete),
            "{}: {:?}",
            b.board,
            b.outcome
        );
        assert_eq!(b.devices, [spec.device_id], "{}", b.board);
        assert_eq!(b.records, 16 * 250 * SECONDS as u64, "{}", b.board);
        assert!(
            b.clocks[0].is_some_and(|l| l.rate_fitted),
            "{}: no drift fitted",
            b.board
        );
    }
    // Each clock's drift against the others' found within 10 ppm (0.12
    // ms over the run; the host's UTC clock, which stamps arrivals, may
    // run a few ppm off the monotonic clock that paced the streams, a
    // term common to all, and a loaded host's late sends bend a 12 s
    // line by a few ppm more).
    let fitted: Vec<f64> = run
        .boards
        .iter()
        .map(|b| (1.0 / b.clocks[0].unwrap().rate - 1.0) * 1e6)
        .collect();
    let set: Vec<f64> = FOUR.iter().map(|b| b.drift_ppm as f64).collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    for k in 0..FOUR.len() {
        let (f, s) = (fitted[k] - mean(&fitted), set[k] - mean(&set));
        assert!(
            (f - s).abs() < 10.0,
            "{}: {f} ppm against the others, set {s}",
            FOUR[k].name
        );
    }
    let placed = skin_run::placement(&run, &FOUR).unwrap();
    for p in &placed {
        eprintln!("{p:?}");
        assert_eq!(p.records, 16 * 250 * SECONDS as u64);
        assert!(
            p.worst_ms < 1.0,
            "board {} placed {} ms off the others",
            p.board,
            p.worst_ms
        );
    }
    // The skin's table: keyed, named, in order on the axis.
    let text = std::fs::read_to_string(run.dir.join(live::RECORDS_CSV)).unwrap();
    let mut last = i64::MIN;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert!(f[1].starts_with(&format!("{}-", f[0])), "{line}");
        let t: i64 = f[2].parse().unwrap();
        assert!(t >= last, "{line}");
        last = t;
    }
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.dir.join(live::boards::SKIN_JSON)).unwrap())
            .unwrap();
    assert_eq!(manifest["boards"].as_array().unwrap().len(), 4);
    assert_eq!(manifest["boards"][3]["devices"][0], "0x0a110004");
}
