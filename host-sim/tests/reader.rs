//! The data-set reader: the repository's example data set
//! (`data/example`, written by rig-sim), our own writer's output, and
//! every rejection the format requires, with file:line:column.

use host_sim::dataset::{read_dir, read_table, Kind};
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example")
}

#[test]
fn reads_the_example_data_set_completely() {
    let ds = read_dir(&example()).unwrap();
    assert_eq!(ds.calibration.rows.len(), 11);
    assert_eq!(ds.sweep.as_ref().unwrap().rows.len(), 36);
    assert_eq!(ds.traces.len(), 6);
    for t in &ds.traces {
        let rows = if t.path.to_string_lossy().contains("10mmps") {
            1263
        } else {
            1083
        };
        assert_eq!(t.rows.len(), rows, "{}", t.path.display());
        assert!(t.rows.iter().all(|r| r.rs_ohm() > 0.0 && r.cs_pf() > 0.0));
    }
    let r = &ds.traces[0].rows[0];
    assert_eq!((r.time_s(), r.stretch_mm(), r.freq_hz()), (0.0, 0.0, 2000.0));
}

#[test]
fn reads_what_host_sim_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("set");
    host_sim::experiments::dataset(
        &d,
        host_sim::experiments::with_effects(Default::default()),
        host_sim::chain::Meter::LCR,
        3,
        indicatif::ProgressBar::hidden(),
    )
    .unwrap();
    let ds = read_dir(&d).unwrap();
    assert_eq!(ds.traces.len(), 6);
    assert!(ds.traces.iter().all(|t| t.rows.len() > 1000));
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// One table of bad files, each with the pieces its message must name:
/// long because the format has that many rules, and one table so that a
/// rule without a case stands out.
#[test]
fn rejections_name_file_line_column_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let head = "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf\n";
    let cases = [
        // (body, expected pieces of the message)
        (
            format!("{head}0,0,1,1,500,200\n# a comment\n0.1,abc,1,1,500,200\n"),
            vec![":4:2:", "stretch_mm", "'abc'"],
        ),
        (
            format!("{head}0,0,1,1,500,inf\n"),
            vec![":2:6:", "cs_pf", "not a finite number"],
        ),
        (
            format!("{head}0,0,-5,1,500,200\n"),
            vec![":2:3:", "r_top_ohm", "negative"],
        ),
        (
            format!("{head}0,0,1,1,500,200\n0,0,1,1,500,200\n"),
            vec![":3:1:", "time_s", "does not increase"],
        ),
        (
            format!("{head}0,0,1,1,500,200\n0.1,0,1,1,600,200\n"),
            vec![":3:5:", "freq_hz", "one frequency"],
        ),
        (
            "time_s,stretch_mm,freq_hz,cs_pf\n0,0,500,200\n".to_string(),
            vec![":1:", "missing required columns 'r_top_ohm' and 'r_bottom_ohm'"],
        ),
        // A missing or an extra field shifts nothing: the row is rejected.
        (format!("{head}0,0,1,1,500\n"), vec![":2:", "5 fields", "has 6"]),
        (
            format!("{head}0,0,1,1,500,200,7\n"),
            vec![":2:", "7 fields", "has 6"],
        ),
        (
            format!("{head}# note\n0,0,1,1,500,200\n0.1,0,1,1,500,200,x\n"),
            vec![":4:", "7 fields"],
        ),
        // A huge field is quoted in part.
        (
            format!("{head}0,{},1,1,500,200\n", "9".repeat(100_000) + "x"),
            vec![":2:2:", "(100001 characters)"],
        ),
    ];
    for (k, (body, want)) in cases.iter().enumerate() {
        let p = write(d, &format!("trace_{k}.csv"), body);
        let err = read_table(&p, Kind::Trace).unwrap_err().to_string();
        assert!(err.contains(&format!("trace_{k}.csv")), "{err}");
        for w in want {
            assert!(err.contains(w), "case {k}: '{w}' not in: {err}");
        }
    }
    // Unknown columns are ignored; extra rs_ohm is read.
    let p = write(
        d,
        "ok.csv",
        &format!(
            "note,{}",
            "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf,rs_ohm\nx,0,0,1,1,500,200,3\n"
        ),
    );
    let t = read_table(&p, Kind::Trace).unwrap();
    assert_eq!(t.rows[0].rs_ohm(), 3.0);
    // A two-tab instrument's recording: its line estimate stands in for
    // the four-terminal resistances, and the table says so.
    let p = write(
        d,
        "line.csv",
        "time_s,stretch_mm,r_line_ohm,freq_hz,cs_pf\n0,0,700000,500,200\n",
    );
    let t = read_table(&p, Kind::Trace).unwrap();
    assert_eq!(t.resistance, host_sim::dataset::Resistance::InstrumentLine);
    assert_eq!(t.rows[0].r_rec(), 700000.0);
    let t = read_table(&d.join("ok.csv"), Kind::Trace).unwrap();
    assert_eq!(t.resistance, host_sim::dataset::Resistance::FourTerminal);
    assert_eq!(t.rows[0].r_rec(), 2.0);
    // Only regular files: a FIFO or a link to a device is refused at once
    // (it would hang or exhaust memory), and bytes that are not UTF-8 are
    // located.
    let fifo = d.join("trace_fifo.csv");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.map(|s| s.success()).unwrap_or(false) {
        let err = read_table(&fifo, Kind::Trace).unwrap_err().to_string();
        assert!(err.contains("not a regular file"), "{err}");
    }
    let zero = d.join("zero.csv");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let err = read_table(&zero, Kind::Trace).unwrap_err().to_string();
    assert!(err.contains("not a regular file"), "{err}");
    let bin = d.join("bin.csv");
    std::fs::write(&bin, [head.as_bytes(), b"0,0,1,1,5\xff0,200\n"].concat()).unwrap();
    let err = read_table(&bin, Kind::Trace).unwrap_err().to_string();
    assert!(err.contains("bin.csv:2:10: not UTF-8"), "{err}");
    for p in [fifo, zero, bin] {
        let _ = std::fs::remove_file(p);
    }
    // A data set without a calibration says so.
    let err = read_dir(d).unwrap_err().to_string();
    assert!(err.contains("missing calibration.csv"), "{err}");
    assert!(read_table(&d.join("nope.csv"), Kind::Sweep)
        .unwrap_err()
        .to_string()
        .contains("nope.csv: cannot open"));
}

/// A minimal data set in `d`: a calibration and one trace.
fn minimal(d: &Path) {
    write(
        d,
        "calibration.csv",
        "stretch_mm,freq_hz,cs_pf,r_top_ohm,r_bottom_ohm\n0,1000,200,3e5,3e5\n10,1000,220,3.3e5,3.3e5\n20,1000,240,3.6e5,3.6e5\n",
    );
    write(
        d,
        "trace_a.csv",
        "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf\n0,0,3e5,3e5,1000,200\n0.1,1,3e5,3e5,1000,202\n",
    );
}

#[test]
fn values_no_sensor_gives_are_refused_with_their_place() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let head = "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf\n";
    for (k, (row, col, what)) in [
        ("0,0,1,1,500,1e308", ":2:6:", "cs_pf"),
        ("0,0,1,1,500,1e-320", ":2:6:", "cs_pf"),
        ("1e300,0,1,1,500,200", ":2:1:", "time_s"),
        ("0,0,1e15,1,500,200", ":2:3:", "r_top_ohm"),
        ("0,0,1,1,1e30,200", ":2:5:", "freq_hz"),
        ("0,-2e4,1,1,500,200", ":2:2:", "stretch_mm"),
    ]
    .iter()
    .enumerate()
    {
        let p = write(d, &format!("trace_{k}.csv"), &format!("{head}{row}\n"));
        let err = read_table(&p, Kind::Trace).unwrap_err().to_string();
        assert!(
            err.contains(col) && err.contains(what) && err.contains("is outside"),
            "{err}"
        );
    }
}

#[test]
fn a_data_set_folder_hides_nothing_and_reads_no_device() {
    // A sweep.csv that is not a regular file is an error, not "no sweep".
    for kind in ["dir", "fifo", "device"] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        minimal(d);
        let sweep = d.join("sweep.csv");
        match kind {
            "dir" => std::fs::create_dir(&sweep).unwrap(),
            "fifo" => assert!(std::process::Command::new("mkfifo")
                .arg(&sweep)
                .status()
                .unwrap()
                .success()),
            _ => std::os::unix::fs::symlink("/dev/zero", &sweep).unwrap(),
        }
        let err = read_dir(d).unwrap_err().to_string();
        assert!(
            err.contains("sweep.csv") && err.contains("not a regular file"),
            "{kind}: {err}"
        );
    }
    // A trace named in upper case is not left out without a word.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    minimal(d);
    write(
        d,
        "trace_b.CSV",
        "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf\n0,0,1,1,500,200\n",
    );
    let err = read_dir(d).unwrap_err().to_string();
    assert!(
        err.contains("'trace_b.CSV'") && err.contains("lower case"),
        "{err}"
    );
    // Nor one whose name is not UTF-8.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    minimal(d);
    use std::os::unix::ffi::OsStrExt;
    let odd = d.join(std::ffi::OsStr::from_bytes(b"trace_\xff.csv"));
    std::fs::write(odd, "x").unwrap();
    let err = read_dir(d).unwrap_err().to_string();
    assert!(err.contains("must be UTF-8"), "{err}");
    // A file of the kernel's (size 0, endless or blocking to read) is read
    // by its size: nothing, and an error, at once.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    minimal(d);
    std::os::unix::fs::symlink("/proc/self/pagemap", d.join("trace_b.csv")).unwrap();
    let err = read_dir(d).unwrap_err().to_string();
    assert!(err.contains("trace_b.csv"), "{err}");
    // The files of a data set together: at most 1 GiB, checked before any
    // is read (sparse files: nothing is written to disk).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    minimal(d);
    for k in 0..5 {
        let f = std::fs::File::create(d.join(format!("trace_big{k}.csv"))).unwrap();
        f.set_len(250 << 20).unwrap();
    }
    let err = read_dir(d).unwrap_err().to_string();
    assert!(
        err.contains("more than the 1073741824 a data set may have"),
        "{err}"
    );
    // And the minimal set itself reads.
    let dir = tempfile::tempdir().unwrap();
    minimal(dir.path());
    assert_eq!(read_dir(dir.path()).unwrap().traces.len(), 1);
}
