//! Firmware records → CSV, without QEMU: parsing, pairing with the truth,
//! one trace per channel and frequency, clear errors.

use qemu_tests::records::{flags, parse, write_csv};

fn lines(s: &str) -> Vec<String> {
    s.lines().map(String::from).collect()
}

#[test]
fn parses_pairs_and_splits_by_channel_and_frequency() {
    let log = lines(
        "start 8 channels\n\
         truth 0 0 210.0 712000 0.0 350000 362000\n\
         rec 0 0 585.9375 0 0 0 0 0 16\n\
         truth 5 1 214.2 712000 2.0 350000 362000\n\
         rec 5 1 585.9375 213.3 240000 214.21 711000 2.01 0\n\
         rec 10 1 1953.125 200.1 230000 214.25 712500 2.02 32\n\
         rec 15 2 585.9375 0 0 0 0 0 2\n",
    );
    let recs = parse(&log).unwrap();
    assert_eq!(recs.len(), 4);
    assert_eq!(recs[1].truth.unwrap().c_pf, 214.2);
    assert!(recs[1].valid() && recs[2].valid() && !recs[3].valid() && !recs[0].valid());
    assert!(recs[2].flags & flags::HELD != 0);
    let dir = tempfile_dir();
    let files = write_csv(&dir, &recs).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["trace_ch1_586hz.csv", "trace_ch1_1953hz.csv"]);
    let text = std::fs::read_to_string(&files[0]).unwrap();
    let row: Vec<&str> = text.lines().nth(2).unwrap().split(',').collect();
    assert_eq!((row[2], row[3], row[5]), ("585.9375", "213.3000", "214.2100"));
    // Settling (ch 0) and open (ch 2) records are not traces, but faults.
    let faults = std::fs::read_to_string(dir.join("faults.csv")).unwrap();
    assert_eq!(faults.lines().count(), 3, "{faults}");
}

#[test]
fn malformed_records_are_errors_with_their_position() {
    let err = parse(&lines("rec 0 0 585.9 1 2 3\n")).unwrap_err().to_string();
    assert!(err.contains("record 1") && err.contains("10 fields"), "{err}");
    let err = parse(&lines("start\nrec 0 0 585.9 1 2 3 4 x 0\n"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("record 2") && err.contains("field 8"), "{err}");
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("records-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}
