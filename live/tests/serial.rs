//! `live --serial` on a real serial device: a pseudo-terminal pair
//! stands in for the ST-LINK's virtual COM port (the same termios calls,
//! the baud rate set as for the board). A stream with its end frame ends
//! the run cleanly; a board's endless stream ends with Ctrl-C, its data
//! set written and marked incomplete; a port that vanishes mid-stream is
//! named and what arrived is kept; a port in use is refused by name.

mod common;

use common::stream;
use serialport::{SerialPort, TTYPort};
use std::io::Write;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A pseudo-terminal pair whose master is closed on exec: the `live`
/// child must not hold it, or closing it here would not hang the port up
/// (serialport opens it without `O_CLOEXEC`; `OwnedFd::try_clone` duplicates
/// with `F_DUPFD_CLOEXEC`).
fn pair() -> (TTYPort, TTYPort) {
    use std::os::fd::{FromRawFd, IntoRawFd, OwnedFd};
    let (master, slave) = TTYPort::pair().unwrap();
    // SAFETY: the descriptor is the master's, given up by `into_raw_fd`;
    // its clone is a fresh descriptor owned by the new port.
    let owned = unsafe { OwnedFd::from_raw_fd(master.into_raw_fd()) };
    let cloexec = owned.try_clone().unwrap();
    drop(owned);
    // SAFETY: a pty master descriptor nobody else owns.
    let master = unsafe { TTYPort::from_raw_fd(cloexec.into_raw_fd()) };
    (master, slave)
}

/// `live --serial` on the pty's slave, writing into `dir`.
fn live_on(slave: &TTYPort, dir: &std::path::Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_live"))
        .args(["--serial", &slave.name().unwrap(), "--dataset"])
        .arg(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Wait for `child`, at most `secs`; its exit code and output.
fn wait(mut child: Child, secs: u64) -> (Option<i32>, String, String) {
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(t0.elapsed() < Duration::from_secs(secs), "live did not stop");
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Rows of records.csv (without its header).
fn rows(dir: &std::path::Path) -> usize {
    std::fs::read_to_string(dir.join("records.csv"))
        .unwrap()
        .lines()
        .count()
        - 1
}

#[test]
fn a_stream_read_from_a_serial_port_ends_with_its_end_frame() {
    let (mut master, slave) = pair();
    let tmp = tempfile::tempdir().unwrap();
    let child = live_on(&slave, tmp.path());
    // Give live time to open the port, then send in pieces as a UART does.
    std::thread::sleep(Duration::from_millis(300));
    let bytes = stream(40, true, link::VERSION);
    for piece in bytes.chunks(37) {
        master.write_all(piece).unwrap();
        std::thread::sleep(Duration::from_millis(2));
    }
    master.flush().unwrap();
    let (code, stdout, stderr) = wait(child, 20);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert_eq!(rows(tmp.path()), 40);
    assert!(!tmp.path().join("INCOMPLETE").exists());
    assert_eq!(
        std::fs::read(tmp.path().join("stream.bin")).unwrap(),
        bytes,
        "the raw bytes kept"
    );
    drop(slave);
}

#[test]
/// Ctrl-C is the normal stop of a board's endless stream: the set is
/// complete (no marker, `complete` in the manifest), exit status 0.
fn ctrl_c_ends_an_endless_stream_with_its_data_set_complete() {
    let (mut master, slave) = pair();
    master.set_timeout(Duration::from_secs(1)).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let child = live_on(&slave, tmp.path());
    std::thread::sleep(Duration::from_millis(300));
    // A board's stream: a start and records, no end.
    master.write_all(&stream(25, false, link::VERSION)).unwrap();
    master.flush().unwrap();
    // Wait until live has written them, then interrupt it.
    let t0 = Instant::now();
    while std::fs::read_to_string(tmp.path().join("records.csv")).map_or(0, |s| s.lines().count()) < 26 {
        assert!(t0.elapsed() < Duration::from_secs(20), "records.csv never filled");
        std::thread::sleep(Duration::from_millis(100));
    }
    let st = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let (code, stdout, stderr) = wait(child, 20);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stderr.contains("stopped (Ctrl-C"), "{stderr}");
    assert_eq!(rows(tmp.path()), 25);
    assert!(!tmp.path().join("INCOMPLETE").exists(), "a stop is no cut");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("session.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], true);
    let outcome = manifest["outcome"].as_str().unwrap();
    assert!(
        outcome.contains("stopped by the user after 25 records"),
        "{outcome}"
    );
    drop(slave);
}

#[test]
fn a_port_that_vanishes_mid_stream_is_named_and_its_records_kept() {
    let (mut master, slave) = pair();
    let name = slave.name().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let child = live_on(&slave, tmp.path());
    std::thread::sleep(Duration::from_millis(300));
    master.write_all(&stream(12, false, link::VERSION)).unwrap();
    master.flush().unwrap();
    std::thread::sleep(Duration::from_millis(500));
    // Unplugged: both ends of the pseudo-terminal go away.
    drop(master);
    drop(slave);
    let (code, stdout, stderr) = wait(child, 20);
    assert_eq!(code, Some(3), "{stdout}\n{stderr}");
    assert!(
        stderr.contains(&format!("the serial port {name} stopped")),
        "{stderr}"
    );
    assert_eq!(rows(tmp.path()), 12);
    assert!(tmp.path().join("INCOMPLETE").exists());
}

#[test]
fn a_port_already_in_use_is_refused_by_name() {
    let (_master, slave) = pair();
    let name = slave.name().unwrap();
    // Another program holds the port (opened exclusively, as serialport
    // does by default).
    let _held = serialport::new(&name, 115_200).open_native().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = wait(live_on(&slave, tmp.path()), 20);
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(
        stderr.contains(&format!("opening the serial port {name} (in use, or not there?)")),
        "{stderr}"
    );
}
