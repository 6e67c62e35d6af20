//! Recordings started and stopped while the device runs on and `live`
//! reads on: from standard input and from the dashboard, each a set of
//! its own that reads alone (its start frame written again before its
//! first frame, nothing counted lost), nothing recorded between them.

mod common;

use common::stream;
use std::io::Write;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// Wait until `path` exists (at most 20 s).
fn wait_for(path: &Path) {
    let t0 = Instant::now();
    while !path.exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "{} never came",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The `seq` column of a recording's records.csv.
fn seqs(dir: &Path) -> Vec<u32> {
    std::fs::read_to_string(dir.join("records.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect()
}

fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("session.json")).unwrap()).unwrap()
}

#[test]
fn recordings_start_and_stop_while_the_device_runs_on() {
    let tmp = tempfile::tempdir().unwrap();
    let first = tmp.path().join("trial");
    let mut live = common::serve_tcp(&["--idle", "--dataset", first.to_str().unwrap()], Stdio::piped());
    let page = live.page.clone();
    let post = |path: &str, body: &str| common::post(&page, path, "application/json", body);
    let mut sock = live.sock.try_clone().unwrap();
    let mut stdin = live.child.stdin.take().unwrap();
    // A run of 140 records: the start frame (seq 0), then record k as
    // frame k + 1.
    let bytes = stream(140, true, link::VERSION);
    let frames: Vec<&[u8]> = bytes.split_inclusive(|&b| b == 0).collect();
    let send = |sock: &mut std::net::TcpStream, range: std::ops::Range<usize>| {
        for f in &frames[range] {
            sock.write_all(f).unwrap();
        }
        sock.flush().unwrap();
    };
    // Idle: 30 records read, none recorded.
    send(&mut sock, 0..31);
    std::thread::sleep(Duration::from_millis(500));
    assert!(!first.exists(), "idle, yet a folder");
    // A marker while nothing records is refused, and said so.
    let (code, why) = post("/marker", r#"{"text": "too soon"}"#);
    assert_eq!(code, 409, "{why}");
    assert!(why.contains("no recording runs"), "{why}");
    // `start` on standard input: the next 40 records are the first
    // recording's.
    writeln!(stdin, "start").unwrap();
    wait_for(&first.join("records.csv"));
    send(&mut sock, 31..71);
    std::thread::sleep(Duration::from_millis(500));
    writeln!(stdin, "stop").unwrap();
    wait_for(&first.join("session.json"));
    // 20 more while nothing records.
    send(&mut sock, 71..91);
    std::thread::sleep(Duration::from_millis(500));
    // The dashboard's Record: the second recording, beside the first.
    let (code, body) = post("/recording", r#"{"action": "start"}"#);
    assert_eq!(code, 200, "{body}");
    let second = tmp.path().join("trial-2");
    assert!(body.contains("trial-2"), "{body}");
    let (code, why) = post("/recording", r#"{"action": "start"}"#);
    assert_eq!(code, 409, "{why}");
    assert!(why.contains("runs already"), "{why}");
    // The rest, and the device's end frame: the run is over.
    send(&mut sock, 91..frames.len());
    drop(sock);
    let (status, _, err) = live.wait();
    assert!(status.success(), "{status}\n{err}");

    // The first: records 31 to 70 (frames 31…70), stopped when asked,
    // complete, joined the run with nothing counted lost.
    assert_eq!(seqs(&first), (31..71).collect::<Vec<_>>());
    let m = manifest(&first);
    assert_eq!(m["complete"], true, "{m}");
    let seg = &m["segments"][0];
    assert_eq!(
        (seg["joined"].as_bool(), seg["first_seq"].as_u64()),
        (Some(true), Some(30)),
        "{seg}"
    );
    assert_eq!(seg["frames_lost"], 0, "{seg}");
    assert!(!first.join(live::INCOMPLETE).exists());
    // The second: from frame 91 to the end frame, whose count of the
    // run's records is not checked against a part of it.
    assert_eq!(seqs(&second), (91..141).collect::<Vec<_>>());
    let m = manifest(&second);
    assert_eq!(m["complete"], true, "{m}");
    assert_eq!(m["segments"][0]["frames_lost"], 0);
    assert_eq!(m["segments"][0]["end"]["agrees"], true, "{m}");

    // Each set's stream reads alone: a replay gives its records again,
    // nothing lost.
    let again = tmp.path().join("again");
    let (code, out, err) = common::live(&[
        "--replay",
        first.join("stream.bin").to_str().unwrap(),
        "--dataset",
        again.to_str().unwrap(),
    ]);
    // (No end frame: a replay of it is incomplete, as a cut stream is.)
    assert_eq!(code, Some(3), "{out}{err}");
    assert_eq!(seqs(&again), (31..71).collect::<Vec<_>>());
    assert_eq!(manifest(&again)["segments"][0]["frames_lost"], 0);
}
