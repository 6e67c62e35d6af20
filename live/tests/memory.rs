//! A session's memory does not grow with its length: `live --replay` of
//! 100 s of a 16-sensor array at 1,000 records/s each (1.6 million
//! records, every one written as it arrives) peaks within 256 MiB
//! resident, and its files hold every record.

use link::{Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::io::{BufRead, Write};
use std::process::Command;

const SENSORS: u32 = 16;
const RATE: u32 = 1000;
const SECONDS: u32 = 100;
/// The bound: resident memory at any length of session.
const RESIDENT_MAX_KIB: i64 = 256 * 1024;

/// The array's stream of a skin stretching, written to `path`: every
/// sensor's line moving, one record in 97 flagged.
fn write_stream(path: &std::path::Path) -> u32 {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let start = Start {
        version: VERSION,
        firmware: Start::firmware_field("skin-array 0.1.0"),
        sensors: SENSORS as u8,
        sample_rate_hz: 25_000,
        ..Start::default()
    };
    w.write_all(enc.start(&start, &mut out).unwrap()).unwrap();
    let n = SENSORS * RATE * SECONDS;
    for k in 0..n {
        let (block, sensor) = (k / SENSORS, k % SENSORS);
        let phase = (block as f32 * 1e-3 + sensor as f32 * 0.6).sin();
        let c = 205e-12 * (1.0 + 0.3 * phase);
        let r = 7.1e5 * (1.0 + 0.5 * phase);
        let tone = |f_hz: f32, share: f32| Tone {
            f_hz,
            z_re_ohm: share * r,
            z_im_ohm: -1.0 / (std::f32::consts::TAU * f_hz * c),
        };
        let rec = Record {
            t_us: 500 + 1000 * u64::from(block),
            sensor: sensor as u8,
            tones: [tone(1000.0, 0.33), tone(4000.0, 0.3)],
            c_farad: c,
            r_ohm: r,
            stretch_mm: 100.0 * (c / 205e-12 - 1.0),
            chosen_hz: 4000.0,
            chi2: 3.9,
            sigma_ln_c: 4e-4,
            flags: if k % 97 == 0 { 128 } else { 0 },
        };
        w.write_all(enc.record(&rec, &mut out).unwrap()).unwrap();
    }
    let end = End {
        records: n,
        dropped: 0,
    };
    w.write_all(enc.end(&end, &mut out).unwrap()).unwrap();
    w.flush().unwrap();
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
