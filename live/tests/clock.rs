//! The host's time: each record's arrival (UTC) beside the device's
//! own, the device's clock fitted to the host's in the manifest, markers
//! from `live`'s standard input with both times, `stop` as a normal end,
//! and a replay that gives every record its arrival time again.

mod common;

use common::stream;
use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Microseconds since the Unix epoch, now.
fn now_us() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_micros() as i64
}

/// The frames of `bytes` (each with its closing 0).
fn frames(bytes: &[u8]) -> Vec<&[u8]> {
    bytes.split_inclusive(|&b| b == 0).collect()
}

#[test]
fn records_carry_their_arrival_and_the_device_clock_is_fitted_to_the_hosts() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("live");
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let mut child = Command::new(env!("CARGO_BIN_EXE_live"))
        .args(["--tcp", &addr, "--dataset"])
        .arg(&dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (mut sock, _) = listener.accept().unwrap();
    // A board's endless stream, each record sent when the device's clock
    // (5.44 ms a record, from 2.56 ms) says, in real time.
    let n = 240;
    let bytes = stream(n, false, link::VERSION);
    let frames = frames(&bytes);
    let t0 = Instant::now();
    let sent_us = now_us();
    let mut stdin = child.stdin.take().unwrap();
    let mut marked = (0, 0);
    for (k, f) in frames.iter().enumerate() {
        let due = Duration::from_micros(2560 + 5440 * k.saturating_sub(1) as u64);
        if let Some(wait) = due.checked_sub(t0.elapsed()) {
            std::thread::sleep(wait);
        }
        sock.write_all(f).unwrap();
        if k == n as usize / 2 {
            // A note between the records, as a user types it.
            let before = now_us();
            writeln!(stdin, "grasp, \"firm\"").unwrap();
            stdin.flush().unwrap();
            marked = (before, now_us());
        }
    }
    // Let the last records arrive and be taken, then stop.
    std::thread::sleep(Duration::from_millis(400));
    writeln!(stdin, "quit").unwrap();
    stdin.flush().unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    let said = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{said}\n{err}");
    assert!(err.contains("stopped (Ctrl-C or `quit`)"), "{err}");
    assert!(said.contains("device clock, segment 1"), "{said}");

    // Every record has its arrival, in order, after it was sent.
    let csv = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    let mut last = 0;
    let rows: Vec<(i64, i64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[2].parse().unwrap(), f[17].parse().unwrap())
        })
        .collect();
    assert_eq!(rows.len(), n as usize);
    for &(t_us, host) in &rows {
        assert!(host >= last, "arrivals out of order");
        last = host;
        assert!(host >= sent_us + t_us - 2560 - 1000, "arrived before it was sent");
    }

    // The fit: the device started (its time 0) about when the first
    // frame was sent, its clock runs at the host's rate (the test's
    // sleeps keep to a few per cent), and its 1σ is stated.
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("session.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], true);
    assert_eq!(manifest["markers"], 1);
    let clock = &manifest["segments"][0]["clock"];
    let offset = clock["offset_unix_s"].as_f64().unwrap();
    let started = sent_us as f64 * 1e-6 - 2560e-6;
    assert!((offset - started).abs() < 0.25, "{clock}");
    // A second and a half: too short to fit the drift, and said so.
    assert!(clock["drift_ppm"].is_null(), "{clock}");
    assert!(clock["sigma_offset_ms"].as_f64().unwrap() > 0.0, "{clock}");
    assert!(clock["points"].as_u64().unwrap() > 20, "{clock}");
    assert!(clock["offset_utc"].as_str().unwrap().ends_with('Z'), "{clock}");

    // The marker: its text whole, made when it was typed, the device's
    // time there near the record sent then.
    let mut markers = csv::Reader::from_path(dir.join("markers.csv")).unwrap();
    let m: Vec<csv::StringRecord> = markers.records().map(Result::unwrap).collect();
    assert_eq!(m.len(), 1);
    assert_eq!((&m[0][3], &m[0][4]), ("stdin", "grasp, \"firm\""));
    let host: i64 = m[0][0].parse().unwrap();
    assert!(
        host >= marked.0 && host <= marked.1 + 300_000,
        "{:?} vs {marked:?}",
        &m[0]
    );
    let device: i64 = m[0][2].parse().unwrap();
    let typed_at = 2560 + 5440 * (i64::from(n) / 2 - 1);
    assert!(
        (device - typed_at).abs() < 250_000,
        "device {device} µs, typed at {typed_at}"
    );

    // A replay of the stream kept, with the arrivals kept beside it:
    // every record with its arrival again, and the same clock fit.
    let again = tmp.path().join("again");
    let (code, _, err) = common::live(&[
        "--replay",
        dir.join("stream.bin").to_str().unwrap(),
        "--dataset",
        again.to_str().unwrap(),
    ]);
    // (A stream without its end frame, read to its end: incomplete.)
    assert_eq!(code, Some(3), "{err}");
    assert_eq!(std::fs::read_to_string(again.join("records.csv")).unwrap(), csv);
    let replayed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(again.join("session.json")).unwrap()).unwrap();
    assert_eq!(replayed["segments"][0]["clock"], *clock);
}

#[test]
fn a_malformed_arrivals_file_is_named_with_its_line_and_column() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("s.bin");
    std::fs::write(&file, stream(4, true, link::VERSION)).unwrap();
    let arrivals = tmp.path().join("a.csv");
    std::fs::write(
        &arrivals,
        "stream_bytes,host_utc_us\n40,1796292000000000\n80,12:00\n",
    )
    .unwrap();
    let (code, _, err) = common::live(&[
        "--replay",
        file.to_str().unwrap(),
        "--arrivals",
        arrivals.to_str().unwrap(),
        "--dataset",
        tmp.path().join("ds").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("a.csv:3:4: '12:00' is not a time in µs"), "{err}");
}

#[test]
fn a_marker_from_the_dashboard_is_written_and_a_form_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("live");
    let mut live = common::serve_tcp(&["--dataset", dir.to_str().unwrap()], Stdio::null());
    let page = live.page.clone();
    let post = |content_type: &str, body: &str| common::post(&page, "/marker", content_type, body);
    let bytes = stream(40, true, link::VERSION);
    let frames = frames(&bytes);
    // Before the start frame: nothing to mark yet, and said so.
    let (code, body) = post("application/json", r#"{"text": "too early"}"#);
    assert_eq!(code, 409, "{body}");
    assert!(body.contains("no start frame yet"), "{body}");
    for f in &frames[..20] {
        live.sock.write_all(f).unwrap();
    }
    live.sock.flush().unwrap();
    std::thread::sleep(Duration::from_millis(500));
    let before = now_us();
    let (code, body) = post("application/json", r#"{"text": "grasp, \"firm\""}"#);
    assert_eq!(code, 200, "{body}");
    let m: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(
        (m["text"].as_str(), m["source"].as_str()),
        (Some("grasp, \"firm\""), Some("dashboard"))
    );
    assert!(m["host_utc_us"].as_i64().unwrap() >= before);
    // A form (which another site's page could send without asking) is
    // not taken.
    let (code, _) = post("application/x-www-form-urlencoded", "text=spoof");
    assert_eq!(code, 415);
    for f in &frames[20..] {
        live.sock.write_all(f).unwrap();
    }
    let (status, _, err) = live.wait();
    assert!(status.success(), "{status}: {err}");
    let markers = std::fs::read_to_string(dir.join("markers.csv")).unwrap();
    let lines: Vec<&str> = markers.lines().collect();
    assert_eq!(lines.len(), 2, "{markers}");
    assert!(
        lines[1].ends_with(",dashboard,\"grasp, \"\"firm\"\"\""),
        "{markers}"
    );
}
