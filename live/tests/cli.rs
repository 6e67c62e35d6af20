//! `live --replay`: a complete stream, a cut one, a newer wire version,
//! junk: exit status, files and messages.

mod common;

use common::stream;
use link::VERSION;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

fn live(stream: &[u8], dir: &Path) -> (Option<i32>, String, String) {
    live_with(stream, dir, &[])
}

/// `live --replay` of `stream` (kept as `dir`/stream.bin) into `dir`/ds,
/// with `extra` arguments.
fn live_with(stream: &[u8], dir: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let file = dir.join("stream.bin");
    std::fs::write(&file, stream).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_live"))
        .arg("--replay")
        .arg(&file)
        .arg("--dataset")
        .arg(dir.join("ds"))
        .args(extra)
        .output()
        .unwrap();
    outcome(out)
}

fn outcome(out: std::process::Output) -> (Option<i32>, String, String) {
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Every file of `dir` and its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
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
    // A complete run asked to replace it takes the marker away.
    let (code, _, _) = live_with(&stream(4, true, VERSION), tmp.path(), &["--overwrite"]);
    assert_eq!(code, Some(0));
    assert!(!tmp.path().join("ds").join(live::INCOMPLETE).exists());
    assert_eq!(rows(&tmp.path().join("ds/records.csv")), 4);
}

#[test]
fn a_session_never_writes_over_an_earlier_one() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    let (code, _, err) = live(&stream(12, false, VERSION), tmp.path());
    assert_eq!(code, Some(3), "{err}");
    let earlier = snapshot(&ds);
    assert!(earlier.contains_key(live::INCOMPLETE) && earlier.contains_key("stream.bin"));
    // Another session into the same folder is refused, and says how.
    let (code, _, err) = live(&stream(4, true, VERSION), tmp.path());
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("holds files already") && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(snapshot(&ds), earlier);
    let follow = |source: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_live"))
            .args(source)
            .arg("--dataset")
            .arg(&ds)
            .arg("--overwrite")
            .output()
            .unwrap();
        outcome(out)
    };
    // Even asked to overwrite: nothing is touched before the source is
    // open and its start frame has arrived. A refused connection:
    let (code, _, err) = follow(&["--tcp", "127.0.0.1:1"]);
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(snapshot(&ds), earlier);
    // A socket that accepts and closes at once:
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let closer = std::thread::spawn(move || drop(listener.accept().unwrap()));
    let (code, out, err) = follow(&["--tcp", &addr]);
    closer.join().unwrap();
    assert_eq!(code, Some(3), "{err}");
    assert!(out.contains("nothing written"), "{out}");
    assert_eq!(snapshot(&ds), earlier);
    // Junk with no start frame:
    let (code, _, _) = live_with(&[0x55; 3000], tmp.path(), &["--overwrite"]);
    assert_eq!(code, Some(3));
    assert_eq!(snapshot(&ds), earlier);
}

#[test]
fn without_a_folder_each_session_gets_its_own() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("in.bin");
    std::fs::write(&file, stream(6, true, VERSION)).unwrap();
    for _ in 0..2 {
        let out = Command::new(env!("CARGO_BIN_EXE_live"))
            .arg("--replay")
            .arg(&file)
            .current_dir(tmp.path())
            .output()
            .unwrap();
        let (code, _, err) = outcome(out);
        assert_eq!(code, Some(0), "{err}");
    }
    let sessions = snapshot_dirs(&tmp.path().join("out/sessions"));
    assert_eq!(sessions.len(), 2, "{sessions:?}");
    for s in &sessions {
        assert_eq!(rows(&s.join("records.csv")), 6);
        assert_eq!(
            std::fs::read(s.join("stream.bin")).unwrap(),
            std::fs::read(&file).unwrap()
        );
    }
}

/// The folders in `dir`.
fn snapshot_dirs(dir: &Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect()
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
    live::replay(&bytes, &first, live::Earlier::Refuse).unwrap();
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
        if n == live::MANIFEST {
            // The same but for when each session ran.
            assert_eq!(untimed(&a), untimed(&b));
            continue;
        }
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{}",
            n.to_string_lossy()
        );
    }
}

/// A manifest without its times.
fn untimed(path: &std::path::Path) -> serde_json::Value {
    let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let obj = m.as_object_mut().unwrap();
    assert!(obj.remove("opened_utc").is_some() && obj.remove("ended_utc").is_some());
    m
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

/// A session that reaches the file size limit (`ulimit -f`) stops with
/// an error that says so, its files in whole lines, marked incomplete,
/// without a manifest or a temporary file left.
#[test]
fn a_file_size_limit_stops_the_session_with_whole_lines() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("in.bin");
    std::fs::write(&file, stream(20_000, true, VERSION)).unwrap();
    let ds = tmp.path().join("ds");
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -f 256; exec \"$0\" --replay \"$1\" --dataset \"$2\"")
        .arg(env!("CARGO_BIN_EXE_live"))
        .arg(&file)
        .arg(&ds)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.to_lowercase().contains("file too large"), "{err}");
    assert!(ds.join(live::INCOMPLETE).is_file());
    assert!(!ds.join(live::MANIFEST).exists());
    for entry in std::fs::read_dir(&ds).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "{name} left");
        if name.ends_with(".csv") {
            let bytes = std::fs::read(&path).unwrap();
            assert!(
                bytes.is_empty() || bytes.ends_with(b"\n"),
                "{name}: a line cut short"
            );
        }
    }
}

/// A skin's description: its names in the manifest, the sensors the
/// device lacks or adds said; a bad file refused by line and column
/// before anything is written.
#[test]
fn a_skin_names_the_sensors_and_what_the_device_lacks() {
    let tmp = tempfile::tempdir().unwrap();
    let skin = tmp.path().join("hand.toml");
    std::fs::write(
        &skin,
        "[skin]\nname = \"left hand\"\n\n[[sensor]]\nname = \"index-1\"\nindex = 0\ngroup = \"index finger\"\nplace = [12, 40]\n\n[[sensor]]\nname = \"palm\"\nindex = 3\nplace = [30, 10]\n",
    )
    .unwrap();
    let (code, _, err) = live_with(
        &stream(6, true, VERSION),
        tmp.path(),
        &["--skin", skin.to_str().unwrap()],
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("skin 'left hand': 'palm' (index 3) beyond the 2 sensors the device reports"),
        "{err}"
    );
    assert!(
        err.contains("the device's sensors 1 are not in the skin"),
        "{err}"
    );
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("ds/session.json")).unwrap()).unwrap();
    assert_eq!(m["skin"]["name"], "left hand");
    assert_eq!(m["skin"]["sensors"][0]["group"], "index finger");
    let per = m["records"]["per_sensor"].as_array().unwrap();
    assert_eq!(per[0]["name"], "index-1");
    assert!(per[1].get("name").is_none(), "{}", per[1]);
    assert_eq!(m["segments"][0]["skin_mismatch"].as_array().unwrap().len(), 2);
    // A file with an error: refused, by line and column, nothing written.
    std::fs::write(
        &skin,
        "[skin]\nname = \"left hand\"\n\n[[sensor]]\nname = \"palm\"\nindex = 3\nplace = [30]\n",
    )
    .unwrap();
    let again = tempfile::tempdir().unwrap();
    let (code, _, err) = live_with(
        &stream(6, true, VERSION),
        again.path(),
        &["--skin", skin.to_str().unwrap()],
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("hand.toml:7:9: place: [x, y], two finite numbers"),
        "{err}"
    );
    assert!(!again.path().join("ds").exists());
}
