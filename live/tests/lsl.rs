//! The Lab Streaming Layer outlet (`python -m skinread.lsl`, the
//! bridge from `live`'s feed) received by `pylsl` as a lab's recorder
//! would: every record in its sample and channel, at its own time on the
//! host's clock, the description naming channels and flags, the
//! session's markers in the marker stream, and an LSL marker stream's
//! markers written into the session.

mod common;

use link::{Body, Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A Python with pylsl: the one `cargo xtask setup` makes
/// (`target/pyenv`), else one on PATH.
fn python() -> String {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/pyenv/bin/python");
    let ok = |py: &str| {
        Command::new(py)
            .args(["-c", "import pylsl, numpy, pandas"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let venv = venv.to_string_lossy().into_owned();
    let found = [venv.as_str(), "python3"]
        .into_iter()
        .find(|p| ok(p))
        .map(str::to_string);
    found.expect("a Python with pylsl: `cargo xtask setup` makes target/pyenv")
}

/// Frame `k`'s record of `sensor`: C = 200 + k/100 + 10·sensor pF.
fn record(k: u32, sensor: u8) -> Record {
    Record {
        t_us: 4000 * u64::from(k) + 2000,
        sensor,
        tones: [
            Tone {
                f_hz: 1000.0,
                z_re_ohm: 2e5,
                z_im_ohm: -7e5,
            },
            Tone::default(),
        ],
        c_farad: (200.0 + k as f32 / 100.0 + 10.0 * f32::from(sensor)) * 1e-12,
        r_ohm: 7e5,
        stretch_mm: k as f32 / 10.0,
        chosen_hz: 1000.0,
        flags: u16::from(k.is_multiple_of(10)) * 64,
        ..Record::default()
    }
}

fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

/// A block's frames: sensor 0's record, and sensor 1's every other
/// block (a sample per block, sensor 1's channels NaN where it was not
/// measured).
fn block(enc: &mut Encoder, k: u32) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = enc.frame(Body::Record(record(k, 0)), &mut out).unwrap().to_vec();
    if k.is_multiple_of(2) {
        bytes.extend_from_slice(enc.frame(Body::Record(record(k, 1)), &mut out).unwrap());
    }
    bytes
}

#[test]
fn an_lsl_inlet_gets_every_record_at_its_time_and_the_markers_both_ways() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("live");
    // The skin names sensor 0; sensor 1 keeps its index.
    let skin = tmp.path().join("skin.toml");
    std::fs::write(&skin, "[skin]\nname = \"test skin\"\n[[sensor]]\nname = \"index-1\"\nindex = 0\ngroup = \"index finger\"\nplace = [1, 2]\n").unwrap();
    let live = common::serve_tcp(
        &[
            "--linger",
            "3",
            "--skin",
            skin.to_str().unwrap(),
            "--dataset",
            dir.to_str().unwrap(),
        ],
        Stdio::null(),
    );
    let url = live.url();
    let mut sock = live.sock.try_clone().unwrap();
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let start = Start {
        version: VERSION,
        firmware: Start::firmware_field("lsl test"),
        sensors: 2,
        ..Start::default()
    };
    // Blocks sent in real time as a device does (one each 4 ms), from
    // before the receiver starts until `stop` says, at most 60 s.
    let sent = Arc::new(AtomicU32::new(0));
    let stop = Arc::new(AtomicU32::new(u32::MAX));
    let sent0 = now_s();
    sock.write_all(enc.frame(Body::Start(start), &mut out).unwrap())
        .unwrap();
    let sender = {
        let (sent, stop) = (Arc::clone(&sent), Arc::clone(&stop));
        std::thread::spawn(move || {
            let t0 = Instant::now();
            let mut k = 0;
            while k < stop.load(Ordering::Acquire).min(15_000) {
                let due = Duration::from_micros(4000 * u64::from(k) + 2000);
                if let Some(w) = due.checked_sub(t0.elapsed()) {
                    std::thread::sleep(w);
                }
                sock.write_all(&block(&mut enc, k)).unwrap();
                k += 1;
                sent.store(k, Ordering::Release);
            }
            let end = End {
                records: k + k.div_ceil(2),
                dropped: 0,
            };
            (sock, enc.frame(Body::End(end), &mut out).unwrap().to_vec(), k)
        })
    };
    // The receiver: the bridge, and an inlet on its outlets.
    let name = format!("de-skin-test-{}", std::process::id());
    let mut rx = Command::new(python())
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/lsl_receiver.py"))
        .args([&url, &name])
        .env(
            "PYTHONPATH",
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../python"),
        )
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut rx_out = BufReader::new(rx.stdout.take().unwrap());
    let mut ready = String::new();
    rx_out.read_line(&mut ready).unwrap();
    assert_eq!(ready.trim(), "ready");
    // The inlet is open: every block from here on reaches it.
    let k_ready = sent.load(Ordering::Acquire);
    stop.store(k_ready + 400, Ordering::Release);
    writeln!(rx.stdin.as_mut().unwrap(), "go").unwrap();
    let marked = now_s();
    let (code, answer) = common::post(
        &live.page,
        "/marker",
        "application/json",
        r#"{"text": "from the page"}"#,
    );
    assert_eq!(code, 200, "{answer}");
    let (mut sock, end, n) = sender.join().unwrap();
    // Time for the stimulus marker to come through before the end.
    std::thread::sleep(Duration::from_millis(2500));
    sock.write_all(&end).unwrap();
    let mut json = String::new();
    rx_out.read_line(&mut json).unwrap();
    let got: serde_json::Value = serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"));
    assert!(rx.wait().unwrap().success());
    drop(sock);
    let (status, _, err) = live.wait();
    assert!(status.success(), "{status}: {err}");

    // The description: 2 sensors × 4 quantities, labelled with units; the
    // flags by name, faults marked.
    assert_eq!(got["type"], "DESkin");
    assert_eq!(got["channels"], 8);
    // Sensor 0 by its name in the skin, sensor 1 by its index.
    assert_eq!(got["labels"][0], serde_json::json!(["index-1.c_pf", "pF"]));
    assert_eq!(got["labels"][7], serde_json::json!(["s1.flag_bits", ""]));
    assert!(
        got["flags"]
            .as_array()
            .unwrap()
            .contains(&serde_json::json!(["DISTURBED", "true"])),
        "{}",
        got["flags"]
    );
    assert_eq!(got["bridge"], 0);

    // Every block from the first the inlet got, in order, its values in
    // their channels, NaN (null) where sensor 1 was not measured.
    let samples = got["samples"].as_array().unwrap();
    let firsts: Vec<f64> = samples.iter().map(|s| s[0].as_f64().unwrap()).collect();
    let k0 = ((firsts[0] - 200.0) * 100.0).round() as u32;
    assert!(
        k0 <= k_ready,
        "the first sample is block {k0}, the inlet was open at {k_ready}"
    );
    assert_eq!(samples.len() as u32, n - k0, "a sample per block");
    for (i, s) in samples.iter().enumerate() {
        let k = k0 + i as u32;
        assert!(
            (s[0].as_f64().unwrap() - (200.0 + k as f64 / 100.0)).abs() < 1e-3,
            "block {k}: {s}"
        );
        assert_eq!(
            s[3].as_f64().unwrap() as u16,
            u16::from(k.is_multiple_of(10)) * 64,
            "block {k}: {s}"
        );
        match k % 2 {
            0 => assert!(
                (s[4].as_f64().unwrap() - (210.0 + k as f64 / 100.0)).abs() < 1e-3,
                "block {k}: {s}"
            ),
            _ => assert!(s[4].is_null(), "block {k}: {s}"),
        }
    }
    // At their own times: 4 ms apart as the device stamped them (not as
    // they arrived), and on the host's clock when they were sent.
    let t: Vec<f64> = got["utc"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let step = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    assert!((step - 0.004).abs() < 0.004 * 0.02, "{step}");
    let sent = sent0 + 0.002 + 0.004 * f64::from(k0);
    assert!(
        (t[0] - sent).abs() < 0.25,
        "the first sample at {}, sent at {sent}",
        t[0]
    );

    // The markers: the page's, through the session to the marker
    // stream; the stimulus program's, into the session's markers.csv
    // (source lsl) and back out.
    let markers = got["markers"].as_array().unwrap();
    let page_marker = markers
        .iter()
        .find(|m| m[0] == "from the page")
        .expect("the page's marker");
    assert!(
        (page_marker[1].as_f64().unwrap() - marked).abs() < 0.5,
        "{page_marker}"
    );
    assert!(markers.iter().any(|m| m[0] == "stimulus on"), "{markers:?}");
    let csv = std::fs::read_to_string(dir.join("markers.csv")).unwrap();
    assert!(csv.lines().any(|l| l.ends_with(",lsl,stimulus on")), "{csv}");
    assert!(
        csv.lines().any(|l| l.ends_with(",dashboard,from the page")),
        "{csv}"
    );
}
