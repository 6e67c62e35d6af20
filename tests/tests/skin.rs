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
    let run = skin_run::session(&tmp.path().join("skin"), &FOUR, streams, 4000).unwrap();
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
        // Each clock's drift found, within 5 ppm.
        let line = b.clocks[0].expect("a clock fit");
        let drift = (1.0 / line.rate - 1.0) * 1e6;
        assert!(
            line.rate_fitted && (drift - spec.drift_ppm as f64).abs() < 5.0,
            "{}: {drift} ppm",
            b.board
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
