//! A session's memory does not grow with its length: `live --replay` of
//! 100 s of a 16-sensor array at 1,000 records/s each (1.6 million
//! records, every one written as it arrives) peaks within 256 MiB
//! resident, and its files hold every record.

use std::io::BufRead;
use std::process::Command;

const SENSORS: u32 = 16;
const RATE: u32 = 1000;
const SECONDS: u32 = 100;
/// The bound: resident memory at any length of session.
const RESIDENT_MAX_KIB: i64 = 256 * 1024;

/// The synthetic skin's stream ([`live::synthetic`]), written to
/// `path`; its records.
fn write_stream(path: &std::path::Path) -> u32 {
    let n = SENSORS * RATE * SECONDS;
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    live::synthetic::write_skin_stream(&mut w, SENSORS as u8, n).unwrap();
    n
}

/// Run `cmd` to its end: its exit code and its peak resident memory, KiB.
// Waited for by wait4, which std's Child cannot do.
#[allow(clippy::zombie_processes)]
fn peak_resident(cmd: &mut Command) -> (Option<i32>, i64) {
    let child = cmd.spawn().unwrap();
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value for wait4 to fill.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: the pid is our child's, not yet waited for; both pointers
    // are to live locals.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    (code, usage.ru_maxrss)
}

fn lines(path: &std::path::Path) -> usize {
    std::io::BufReader::new(std::fs::File::open(path).unwrap())
        .lines()
        .count()
}

#[test]
fn a_long_replay_stays_within_its_memory_and_keeps_every_record() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("in.bin");
    let n = write_stream(&file);
    let ds = tmp.path().join("ds");
    let (code, kib) = peak_resident(
        Command::new(env!("CARGO_BIN_EXE_live"))
            .arg("--replay")
            .arg(&file)
            .arg("--dataset")
            .arg(&ds)
            .stdout(std::process::Stdio::null()),
    );
    println!("replay of {n} records: peak resident {} MiB", kib / 1024);
    assert_eq!(code, Some(0));
    assert!(kib <= RESIDENT_MAX_KIB, "peak resident {kib} KiB");
    assert_eq!(lines(&ds.join(live::RECORDS_CSV)), n as usize + 1);
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ds.join(live::MANIFEST)).unwrap()).unwrap();
    assert_eq!(m["complete"], true);
    assert_eq!(m["records"]["kept"], n);
    assert_eq!(m["segments"][0]["end"]["agrees"], true);
    // Every sensor's two tones, a trace each: every record twice.
    let traces: Vec<_> = std::fs::read_dir(&ds)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("trace_"))
        .collect();
    assert_eq!(traces.len(), 2 * SENSORS as usize);
    // Each its header, then its rows.
    let rows: usize = traces.iter().map(|p| lines(p) - 1).sum();
    assert_eq!(rows, 2 * n as usize);
    assert!(!ds.join(live::INCOMPLETE).exists());
}
