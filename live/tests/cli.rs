//! `live --replay`: a complete stream, a cut one, a newer wire version,
//! junk: exit status, files and messages.

mod common;

use common::stream;
use link::VERSION;
use std::path::Path;
use std::process::Command;

fn live(stream: &[u8], dir: &Path) -> (Option<i32>, String, String) {
    let file = dir.join("stream.bin");
    std::fs::write(&file, stream).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_live"))
        .arg("--replay")
        .arg(&file)
        .arg("--dataset")
        .arg(dir.join("ds"))
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn rows(path: &Path) -> usize {
    std::fs::read_to_string(path).unwrap().lines().count() - 1
}

#[test]
fn a_complete_stream_is_written_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, out, err) = live(&stream(40, true, VERSION), tmp.path());
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("40 records from 2 sensors"), "{out}");
    assert_eq!(rows(&tmp.path().join("ds/records.csv")), 40);
    assert!(!tmp.path().join("ds").join(live::INCOMPLETE).exists());
    assert!(tmp.path().join("ds/faults.csv").is_file());
}

#[test]
fn a_cut_stream_keeps_what_arrived_marks_it_and_fails() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, _, err) = live(&stream(12, false, VERSION), tmp.path());
    assert_eq!(code, Some(3), "{err}");
    assert!(
        err.contains("incomplete") && err.contains("without its end frame"),
        "{err}"
    );
    assert_eq!(rows(&tmp.path().join("ds/records.csv")), 12);
    let marker = std::fs::read_to_string(tmp.path().join("ds").join(live::INCOMPLETE)).unwrap();
    assert!(marker.contains("12 records"), "{marker}");
    // A complete run into the same folder takes the marker away.
    let (code, _, _) = live(&stream(4, true, VERSION), tmp.path());
    assert_eq!(code, Some(0));
    assert!(!tmp.path().join("ds").join(live::INCOMPLETE).exists());
}

#[test]
fn a_newer_wire_version_is_refused_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, _, err) = live(&stream(3, true, VERSION + 1), tmp.path());
    assert_eq!(code, Some(1));
    assert!(err.contains(&format!("wire version {}", VERSION + 1)), "{err}");
}

#[test]
fn junk_and_no_source_are_clear() {
    let tmp = tempfile::tempdir().unwrap();
    let junk: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    let (code, _, err) = live(&junk, tmp.path());
    assert_eq!(code, Some(3), "{err}");
    assert!(err.contains("no start frame"), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_live")).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--replay FILE, --serial PORT or --tcp"));
    let out = Command::new(env!("CARGO_BIN_EXE_live"))
        .args(["--serial", "/dev/no-such-port", "--dataset"])
        .arg(tmp.path().join("s"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/dev/no-such-port"));
}

#[test]
fn a_replay_rebuilds_the_same_data_set() {
    let tmp = tempfile::tempdir().unwrap();
    let bytes = stream(200, true, VERSION);
    let first = tmp.path().join("first");
    live::replay(&bytes, &first).unwrap();
    let (code, _, err) = live(&bytes, tmp.path());
    assert_eq!(code, Some(0), "{err}");
    let mut names: Vec<_> = std::fs::read_dir(&first)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= 4, "{names:?}");
    for n in names {
        let (a, b) = (first.join(&n), tmp.path().join("ds").join(&n));
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{}",
            n.to_string_lossy()
        );
    }
}

#[test]
fn a_refused_frame_is_named_with_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bytes = stream(10, true, VERSION);
    // Flip a bit in the third frame.
    let third = bytes
        .iter()
        .enumerate()
        .filter(|(_, &b)| b == 0)
        .nth(1)
        .unwrap()
        .0
        + 3;
    bytes[third] ^= 0x10;
    let (code, out, err) = live(&bytes, tmp.path());
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("refused: the CRC does not match"), "{err}");
    assert!(err.contains("a frame ending at byte"), "{err}");
    assert!(out.contains("9 records") && out.contains("1 refused"), "{out}");
}
