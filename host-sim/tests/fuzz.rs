//! Fuzzing the host's readers with proptest: the data-set reader (on the
//! bytes of a file, arbitrary or a mutated valid table), the recording
//! decoder (arbitrary log lines and mutated record lines), and the
//! data-set writer against the reader (a recording of any values written,
//! then read back: the same values, or a refusal).
//!
//! Properties: no panic; an error names the file (and, for a row, its line
//! and column); a table read is made of finite values with a positive
//! frequency and Cs, rows in increasing time, one frequency per trace; the
//! decoder's records have a finite, positive frequency and time in order
//! of the log.
//!
//! Cases per target: `FUZZ_CASES` (default 100 000); `cargo xtask fuzz`
//! runs 1 000 000.

use host_sim::dataset::{parse_table, read_table, Kind, COLUMNS};
use host_sim::recording::{self, unusable, write_dataset, LoggedRecord, Roles, INCOMPLETE};
use instrument::faults::Flags;
use proptest::prelude::*;
use std::path::Path;

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("FUZZ_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(100_000),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// A field: numbers of every kind, and what breaks parsers.
fn field() -> impl Strategy<Value = String> {
    prop_oneof![
        (-1e7f64..1e7).prop_map(|v| format!("{v}")),
        (1.0f64..1e6).prop_map(|v| format!("{v:.3}")),
        prop::sample::select(vec![
            "0", "-0", "1", "-1", "nan", "NaN", "inf", "-inf", "1e309", "1e-320", "", " ", "\"", "\"\"",
            "\"1,2\"", "0x10", "1.2.3", "é", "\u{0}", "#", "2000", "585.9375", "--1", "+5", "1e", ".",
        ])
        .prop_map(String::from),
        ".{0,8}",
    ]
}

/// A table: a header of known and unknown columns, rows of fields, comments
/// and blank lines anywhere, and the occasional missing or extra field.
fn table() -> impl Strategy<Value = Vec<u8>> {
    let header = prop::collection::vec(
        prop_oneof![
            prop::sample::select(COLUMNS.to_vec()).prop_map(String::from),
            "[a-z_]{1,8}"
        ],
        1..10,
    );
    (
        header,
        prop::collection::vec(prop::collection::vec(field(), 0..11), 0..12),
        any::<u64>(),
    )
        .prop_map(|(head, rows, noise)| {
            let mut text = head.join(",") + "\n";
            for (k, r) in rows.iter().enumerate() {
                if noise >> (k % 64) & 1 == 1 && k % 3 == 0 {
                    text += "# a comment\n";
                }
                text += &r.join(",");
                text += if noise >> ((k + 7) % 64) & 1 == 1 {
                    "\r\n"
                } else {
                    "\n"
                };
            }
            text.into_bytes()
        })
}

fn kind() -> impl Strategy<Value = Kind> {
    prop::sample::select(vec![Kind::Calibration, Kind::Sweep, Kind::Trace])
}

/// A valid trace, one field replaced by a fuzzed one.
fn mutated_trace() -> impl Strategy<Value = Vec<u8>> {
    (prop::collection::vec(0.001f64..1e3, 1..20), 0usize..200, field()).prop_map(|(dt, at, f)| {
        let mut t = 0.0;
        let mut rows: Vec<Vec<String>> = dt
            .iter()
            .map(|d| {
                t += d;
                vec![
                    format!("{t}"),
                    "5.0".into(),
                    "2000".into(),
                    "200.5".into(),
                    "3.5e5".into(),
                    "3.6e5".into(),
                ]
            })
            .collect();
        let n = rows.len() * 6;
        let k = at % n;
        rows[k / 6][k % 6] = f;
        let mut text = String::from("time_s,stretch_mm,freq_hz,cs_pf,r_top_ohm,r_bottom_ohm\n");
        for r in rows {
            text += &(r.join(",") + "\n");
        }
        text.into_bytes()
    })
}

fn check(bytes: Vec<u8>, kind: Kind) -> Result<(), TestCaseError> {
    let path = Path::new("fuzz.csv");
    match parse_table(path, bytes, kind) {
        Err(e) => prop_assert!(e.to_string().starts_with("fuzz.csv"), "{e}"),
        Ok(t) => {
            let mut f0 = None;
            for (k, r) in t.rows.iter().enumerate() {
                prop_assert!(r.freq_hz() > 0.0 && r.cs_pf() > 0.0, "{:?}", r.values);
                for v in r.values {
                    prop_assert!(v.is_nan() || v.is_finite());
                }
                if kind == Kind::Trace {
                    if k > 0 {
                        prop_assert!(r.time_s() > t.rows[k - 1].time_s());
                    }
                    prop_assert!(*f0.get_or_insert(r.freq_hz()) == r.freq_hz());
                }
            }
        }
    }
    Ok(())
}

/// A log line: noise, or a record line with fuzzed fields.
fn log_line() -> impl Strategy<Value = String> {
    prop_oneof![
        ".{0,60}",
        (
            prop::sample::select(vec!["rec", "truth", "12:00:01 INFO rec", "start"]),
            prop::collection::vec(field(), 0..12)
        )
            .prop_map(|(k, f)| format!("{k} {}", f.join(" "))),
        (
            0u64..1u64 << 40,
            0u8..8,
            prop::sample::select(vec![585.9375f32, 1953.125, -1.0, 0.0, f32::NAN]),
            0u8..=255
        )
            .prop_map(|(t, ch, f, flags)| format!(
                "rec {t} {ch} {f} 200.1 230000 214.25 712500 4.02 {flags}"
            )),
    ]
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn reader_on_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..300), kind in kind()) {
        check(bytes, kind)?;
    }

    #[test]
    fn reader_on_fuzzed_tables(bytes in table(), kind in kind()) {
        check(bytes, kind)?;
    }

    #[test]
    fn reader_on_mutated_traces(bytes in mutated_trace()) {
        check(bytes, Kind::Trace)?;
    }

    #[test]
    fn record_decoder(lines in prop::collection::vec(log_line(), 0..20)) {
        let numbered: Vec<(usize, String)> = lines.into_iter().enumerate().map(|(i, l)| (i + 1, l)).collect();
        match recording::parse("fuzz.log", &numbered) {
            Err(e) => prop_assert!(e.to_string().starts_with("fuzz.log"), "{e}"),
            Ok(recs) => {
                for r in &recs {
                    prop_assert!(r.freq_hz.is_finite() && r.freq_hz > 0.0, "{r:?}");
                    prop_assert!(r.t_s.is_finite() && r.cs_pf.is_finite() && r.c_pf.is_finite());
                }
            }
        }
    }
}

/// A value of a record's field: what a sensor gives, and what a corrupted
/// record or a unit error does.
fn reading(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => lo..hi,
        1 => prop::sample::select(vec![0.0, -1.0, f64::NAN, f64::INFINITY, 3e38, 1e-30, -0.0]),
    ]
}

/// A record of a recording: channel 0–3, one of the firmware's frequencies
/// (or an impossible one), flags mostly clean.
fn logged() -> impl Strategy<Value = (u8, f64, [f64; 5], u16)> {
    (
        0u8..4,
        prop_oneof![
            6 => prop::sample::select(vec![585.9375, 1953.125, 5859.375]),
            1 => prop::sample::select(vec![0.0, -5.0, f64::NAN, 1e30, 1953.3]),
        ],
        (
            reading(150.0, 300.0),
            reading(1e3, 5e6),
            reading(150.0, 300.0),
            reading(1e5, 5e6),
            reading(-1.0, 31.0),
        )
            .prop_map(|(a, b, c, d, e)| [a, b, c, d, e]),
        prop_oneof![6 => Just(0u16), 1 => any::<u16>(), 1 => Just(Flags::UNCALIBRATED)],
    )
}

/// The field as the writer prints it, read back: within half its last
/// printed digit.
fn same(written: f64, read: f64, step: f64) -> bool {
    (written - read).abs() <= 0.5 * step + 1e-9 * written.abs()
}

/// A scratch folder for the writer's cases, which write files (≈ 0.3 ms
/// each in memory, twice that on a disk): in memory where there is one
/// (`/dev/shm`), else in the temporary folder.
fn scratch() -> tempfile::TempDir {
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        if let Ok(d) = tempfile::tempdir_in(shm) {
            return d;
        }
    }
    tempfile::tempdir().unwrap()
}

proptest! {
    #![proptest_config(config())]

    /// Write a recording as a data set, then read it back: the writer
    /// refuses with a reason, or what the reader gets is the records'
    /// values (within the printed digits), every record that can be a row
    /// in its trace (the others in `faults.csv`), vouched for exactly when
    /// the record was valid (one that failed only the model check: its
    /// lumped reading, without a line); and no set left half written.
    #[test]
    fn dataset_writer_round_trip(
        recs in prop::collection::vec(logged(), 0..60),
        statics in prop_oneof![Just(None), Just(Some(vec![3u8]))],
    ) {
        let dir = scratch();
        let logged: Vec<LoggedRecord> = recs
            .iter()
            .enumerate()
            .map(|(k, &(channel, freq_hz, [cs_pf, rs_ohm, c_pf, r_ohm, stretch_mm], flags))| LoggedRecord {
                t_s: 0.01 * k as f64,
                sensor: channel,
                freq_hz,
                cs_pf,
                rs_ohm,
                c_pf,
                r_ohm,
                stretch_mm,
                flags: Flags(flags),
                truth: None,
            })
            .collect();
        let roles = Roles { traces: None, statics };
        let written = match write_dataset(dir.path(), &logged, &roles) {
            Ok(w) => w,
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                // A refusal leaves no data set behind.
                prop_assert!(!dir.path().join("calibration.csv").exists());
                return Ok(());
            }
        };
        prop_assert!(!dir.path().join(INCOMPLETE).exists());
        // As the data set holds them: a record that failed the model
        // check is a row of its lumped reading without a line.
        let rows: Vec<LoggedRecord> = logged.iter().map(LoggedRecord::as_row).collect();
        for path in &written.traces {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let table = match read_table(path, Kind::Trace) {
                Ok(t) => t,
                Err(e) => {
                    // Refused: only for a trace with nothing vouched for.
                    prop_assert!(e.to_string().contains("no data rows"), "{e:#}");
                    continue;
                }
            };
            // trace_ch{ch}_{f}hz.csv: the records it holds, in order (its
            // rows' frequency is the records').
            let ch = name
                .trim_start_matches("trace_ch")
                .split_once('_')
                .map(|(c, _)| c.parse::<u8>().unwrap())
                .unwrap();
            let f = table.rows.first().map_or(f64::NAN, |r| r.freq_hz());
            let mine: Vec<&LoggedRecord> = rows
                .iter()
                .filter(|r| r.sensor == ch && r.freq_hz == f && unusable(r, false).is_none())
                .collect();
            let vouched: Vec<&&LoggedRecord> = mine.iter().filter(|r| r.valid()).collect();
            prop_assert_eq!(table.rows.len(), vouched.len(), "{}", name);
            prop_assert_eq!(table.flagged, mine.len() - vouched.len(), "{}", name);
            for (row, r) in table.rows.iter().zip(&vouched) {
                prop_assert!(same(r.t_s, row.time_s(), 1e-6), "{} {row:?} {r:?}", name);
                prop_assert!(same(r.stretch_mm, row.stretch_mm(), 1e-4), "{} {row:?} {r:?}", name);
                prop_assert_eq!(r.freq_hz, row.freq_hz());
                prop_assert!(same(r.cs_pf, row.cs_pf(), 1e-4), "{} {row:?} {r:?}", name);
                prop_assert!(same(r.rs_ohm, row.rs_ohm(), 1.0), "{} {row:?} {r:?}", name);
                prop_assert!(same(r.r_ohm, row.r_line_ohm(), 1.0), "{} {row:?} {r:?}", name);
            }
        }
    }
}
