//! `live --replay`: a complete stream, a cut one, a newer wire version,
//! junk: exit status, files and messages.

use link::{Body, Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::path::Path;
use std::process::Command;

/// A stream of `n` single-tone records from two sensors, with its end
/// frame or not, of wire version `version`.
fn stream(n: u32, end: bool, version: u16) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = enc
        .frame(
            Body::Start(Start {
                version,
                firmware: Start::firmware_field("test"),
                sensors: 2,
                sample_rate_hz: 200_000,
                ..Start::default()
            }),
            &mut out,
        )
        .unwrap()
        .to_vec();
    for k in 0..n {
        let rec = Record {
            t_us: 2560 + 5440 * u64::from(k),
            sensor: (k % 2) as u8,
            tones: [
                Tone {
                    f_hz: 1953.125,
                    z_re_ohm: 2.3e5,
                    z_im_ohm: -4.0e5,
                },
                Tone::default(),
            ],
            c_farad: 205e-12,
            r_ohm: 7e5,
            stretch_mm: 0.1 * k as f32,
            chosen_hz: 1953.125,
            flags: u16::from(k == 3) * 16,
            ..Record::default()
        };
        bytes.extend_from_slice(enc.frame(Body::Record(rec), &mut out).unwrap());
    }
    if end {
        let e = End {
            records: n,
            dropped: 0,
        };
        bytes.extend_from_slice(enc.frame(Body::End(e), &mut out).unwrap());
    }
    bytes
}

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
