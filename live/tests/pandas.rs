//! Every CSV file the tools write (a session's, a decoded recording's,
//! the paper's experiments') reads as a lab reads it: with
//! `pandas.read_csv`'s defaults and with Python's `csv` module (RFC 4180),
//! each column numeric but `reason`, a value the record lacks an empty
//! field (never `NaN` text, never a 0 that reads as a measurement), and a
//! flagged record's flag in every row it gives.

mod common;

use host_sim::recording::{self, BlockTruth, LoggedRecord, Roles};
use instrument::faults::Flags;
use link::{Body, Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::path::{Path, PathBuf};

/// The check, in Python: each file's rows and columns as pandas and csv
/// read them.
const CHECK: &str = r#"
import csv, sys
import pandas as pd
for p in sys.argv[1:]:
    with open(p, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    assert all(len(r) == len(head) for r in rows), (p, "ragged rows")
    df = pd.read_csv(p)
    assert list(df.columns) == head, (p, list(df.columns), head)
    assert len(df) == len(rows) - 1, (p, len(df), len(rows))
    for c in head:
        # (A file of no rows has no types to judge.)
        if c != "reason" and len(df) > 0:
            assert df[c].dtype.kind in "fiu", (p, c, str(df[c].dtype))
    for i, r in enumerate(rows[1:]):
        for j, v in enumerate(r):
            assert v.lower() not in ("nan", "inf", "-inf"), (p, i, head[j], v)
            assert (v == "") == bool(pd.isna(df.iat[i, j])), (p, i, head[j], v)
print("read", len(sys.argv) - 1, "files")
"#;

/// A stream: two sensors moving, an array's two tones each; sensor 1's
/// records every fifth failed the model check, one record has no values,
/// one is open.
fn stream() -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let start = Start {
        version: VERSION,
        firmware: Start::firmware_field("pandas test"),
        sensors: 2,
        ..Start::default()
    };
    let mut bytes = enc.frame(Body::Start(start), &mut out).unwrap().to_vec();
    let n = 60u32;
    for k in 0..n {
        for sensor in 0..2u8 {
            let s = 0.2 * k as f32;
            let tone = |f_hz: f32, re: f32| Tone {
                f_hz,
                z_re_ohm: re,
                z_im_ohm: -1.0 / (std::f32::consts::TAU * f_hz * 205e-12),
            };
            let model = sensor == 1 && k % 5 == 0;
            let mut rec = Record {
                t_us: 4000 * u64::from(k) + 2000,
                sensor,
                tones: [tone(500.0, 4e5), tone(2000.0, 2e5)],
                c_farad: 205e-12 * (1.0 + s / 100.0),
                r_ohm: 7e5,
                stretch_mm: s,
                chosen_hz: 2000.0,
                flags: if model { Flags::MODEL } else { 0 },
                ..Record::default()
            };
            if sensor == 0 && k == 30 {
                (rec.c_farad, rec.r_ohm, rec.stretch_mm, rec.chi2) =
                    (f32::NAN, f32::NAN, f32::NAN, f32::INFINITY);
                rec.flags = Flags::RANGE;
            }
            if sensor == 0 && k == 31 {
                rec.tones = [Tone::default(); 2];
                rec.flags = Flags::OPEN;
            }
            bytes.extend_from_slice(enc.frame(Body::Record(rec), &mut out).unwrap());
        }
    }
    let end = End {
        records: 2 * n,
        dropped: 0,
    };
    bytes.extend_from_slice(enc.frame(Body::End(end), &mut out).unwrap());
    bytes
}

/// A recording with the rig's truth (as `decode` writes one): sensor 0
/// moving, every seventh record failed the model check; sensor 1 held.
fn with_truth() -> Vec<LoggedRecord> {
    (0..80)
        .map(|k| {
            let sensor = (k % 2) as u8;
            let s = if sensor == 0 { 0.3 * k as f64 } else { 10.0 };
            let model = sensor == 0 && k % 7 == 0;
            LoggedRecord {
                t_s: 0.004 * k as f64,
                sensor,
                freq_hz: 2000.0,
                cs_pf: 200.0 + s,
                rs_ohm: 9e4,
                c_pf: 205.0 + s,
                r_ohm: 7e5,
                stretch_mm: s,
                flags: Flags(if model { Flags::MODEL } else { 0 }),
                truth: Some(BlockTruth {
                    c_pf: 205.0 + s,
                    r_ohm: 7e5,
                    stretch_mm: s,
                    r_top_ohm: 3.5e5,
                    r_bottom_ohm: 3.6e5,
                }),
            }
            .as_row()
        })
        .collect()
}

fn csv_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    files.sort();
    files
}

fn python_reads(files: &[PathBuf]) {
    let out = std::process::Command::new(common::python_with("pandas"))
        .arg("-c")
        .arg(CHECK)
        .args(files)
        .output()
        .expect("python3 with pandas (Debian's python3-pandas; `cargo xtask setup` installs it)");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn every_csv_a_session_writes_reads_with_pandas_and_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("session");
    live::replay(&stream(), &dir, live::Earlier::Refuse).unwrap();
    let files = csv_files(&dir);
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert!(names.len() >= 5, "{names:?}");
    python_reads(&files);
    // The record without values: empty fields in records.csv.
    let csv = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    let nan_row = csv
        .lines()
        .find(|l| l.ends_with(&format!(",{},", Flags::RANGE)))
        .unwrap();
    // C, R, stretch and chi² (infinite): four; and no arrival time (a
    // replay without its arrivals).
    assert_eq!(
        nan_row.split(',').filter(|f| f.is_empty()).count(),
        5,
        "{nan_row}"
    );
    // Every failed model check listed with its flag; its reason quoted.
    let faults = std::fs::read_to_string(dir.join("faults.csv")).unwrap();
    assert!(faults.lines().skip(1).all(|l| l.ends_with('"')), "{faults}");
    assert_eq!(
        faults.lines().filter(|l| l.contains(",256,")).count(),
        2 * 12,
        "{faults}"
    );
}

#[test]
fn every_csv_of_a_recording_with_truth_reads_with_pandas_and_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let w = recording::write_dataset(tmp.path(), &with_truth(), &Roles::default()).unwrap();
    assert_eq!((w.traces.len(), w.calibration_points), (1, 1));
    python_reads(&csv_files(tmp.path()));
    // The failed model checks are rows of the trace with their flag, the
    // line without a value; the data set's reader keeps their lumped
    // readings.
    let trace = std::fs::read_to_string(&w.traces[0]).unwrap();
    let model: Vec<&str> = trace
        .lines()
        .filter(|l| l.split(',').nth(9) == Some("256"))
        .collect();
    assert_eq!(model.len(), 6, "{trace}");
    assert!(model
        .iter()
        .all(|l| l.split(',').nth(7) == Some("") && l.split(',').nth(8) == Some("")));
    let ds = host_sim::dataset::read_dir(tmp.path()).unwrap();
    assert_eq!((ds.traces[0].rows.len(), ds.traces[0].flagged), (40, 0));
}

#[test]
fn the_experiments_traces_read_with_pandas_and_csv() {
    use host_sim::chain::Reading;
    let tmp = tempfile::tempdir().unwrap();
    // The second reading's ADC clipped: no lumped reading, no line.
    let rs: Vec<Reading> = (0..3)
        .map(|k| Reading {
            t: 0.01 * k as f64,
            stretch_mm: k as f64,
            c_true: 205e-12,
            r_line: 7e5,
            r_top: 3.5e5,
            r_bottom: 3.6e5,
            freq_hz: 2000.0,
            cs: if k == 1 { f64::NAN } else { 200e-12 },
            rs: if k == 1 { f64::NAN } else { 9e4 },
            c_corr: if k == 1 { f64::NAN } else { 205e-12 },
            r_corr: if k == 1 { f64::NAN } else { 7e5 },
            clipped: k == 1,
        })
        .collect();
    let path = tmp.path().join("adc_20mmps_2000hz.csv");
    host_sim::experiments::write_trace(&path, &rs, true).unwrap();
    python_reads(&[path]);
}
