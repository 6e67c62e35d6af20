//! The data-set writer and the trace command: the interchange format, and
//! clear errors for bad arguments and unreadable files.

mod common;
use common::run;

/// Parse a CSV file of numbers, skipping `#` comments.
fn table(path: &std::path::Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    (head, rows)
}

#[test]
fn dataset_is_in_the_interchange_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("set");
    let (ok, _, err) = run(&[
        "dataset",
        "--out",
        d.to_str().unwrap(),
        "--contact-resistance",
        "5k",
    ]);
    assert!(ok, "{err}");
    let (head, rows) = table(&d.join("calibration.csv"));
    assert_eq!(
        head,
        [
            "stretch_mm",
            "freq_hz",
            "cs_pf",
            "rs_ohm",
            "r_top_ohm",
            "r_bottom_ohm"
        ]
    );
    assert_eq!(rows.len(), 11);
    // Contacts are inside the recorded electrode resistance (two per electrode).
    assert!(rows[0][4] > 355e3, "{:?}", rows[0]);
    let (head, _) = table(&d.join("sweep.csv"));
    assert_eq!(head.len(), 6);
    for rate in [10, 20] {
        for f in [500, 2000, 6000] {
            let (head, rows) = table(&d.join(format!("trace_{rate}mmps_{f}hz.csv")));
            assert_eq!(
                head,
                [
                    "time_s",
                    "stretch_mm",
                    "r_top_ohm",
                    "r_bottom_ohm",
                    "freq_hz",
                    "cs_pf",
                    "rs_ohm"
                ]
            );
            assert!(rows.len() > 1000);
            assert!(rows.windows(2).all(|w| w[1][0] > w[0][0]), "time increases");
            assert!(rows.iter().all(|r| r[4] == f as f64), "constant frequency");
            assert!(rows
                .iter()
                .all(|r| r.iter().all(|v| v.is_finite()) && r[2] > 0.0 && r[5] > 0.0 && r[6] > 0.0));
        }
    }
}

#[test]
fn trace_follows_a_csv_profile() {
    let dir = tempfile::tempdir().unwrap();
    let prof = dir.path().join("p.csv");
    std::fs::write(&prof, "# a ramp and hold\ntime_s,stretch_mm\n0,0\n1,10\n2,10\n").unwrap();
    let out = dir.path().join("t.csv");
    let (ok, _, err) = run(&[
        "trace",
        "--profile",
        prof.to_str().unwrap(),
        "--duration",
        "2",
        "--f",
        "2k",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let last = text.lines().last().unwrap();
    let stretch: f64 = last.split(',').nth(1).unwrap().parse().unwrap();
    assert!((stretch - 10.0).abs() < 1e-9, "{last}");
    // And a built-in profile to stdout, with the LCR meter.
    let (ok, out, err) = run(&[
        "trace",
        "--profile",
        "ramp:10:5",
        "--duration",
        "1",
        "--meter",
        "lcr",
    ]);
    assert!(ok, "{err}");
    assert!(out.starts_with("time_s,stretch_mm"));
}

#[test]
fn bad_arguments_and_files_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "time_s,stretch_mm\n0,0\n1,abc\n").unwrap();
    let (ok, _, err) = run(&["trace", "--profile", bad.to_str().unwrap()]);
    assert!(
        !ok && err.contains("bad.csv:3") && err.contains("stretch_mm") && err.contains("abc"),
        "{err}"
    );
    std::fs::write(&bad, "time_s,stretch_mm\n0,0\n0,1\n").unwrap();
    let (ok, _, err) = run(&["trace", "--profile", bad.to_str().unwrap()]);
    assert!(
        !ok && err.contains("bad.csv:3") && err.contains("does not increase"),
        "{err}"
    );
    std::fs::write(&bad, "time,stretch_mm\n0,0\n").unwrap();
    let (ok, _, err) = run(&["trace", "--profile", bad.to_str().unwrap()]);
    assert!(!ok && err.contains("missing column time_s"), "{err}");
    let (ok, _, err) = run(&["trace", "--profile", "/nonexistent/p.csv"]);
    assert!(
        !ok && err.contains("/nonexistent/p.csv") && err.contains("cannot open"),
        "{err}"
    );
    let (ok, _, err) = run(&["trace", "--profile", "trapezoid:-5"]);
    assert!(!ok && err.contains("rate must be > 0"), "{err}");
    // An endless trace is refused at once.
    let (ok, _, err) = run(&["trace", "--profile", "const:3", "--duration", "1e9"]);
    assert!(
        !ok && err.contains("--duration must be within 0..3600 s"),
        "{err}"
    );
    let (ok, _, err) = run(&["trace", "--profile", "const:3", "--meter", "scope"]);
    assert!(!ok && err.contains("expected 'adc' or 'lcr'"), "{err}");
    let (ok, _, err) = run(&[
        "dataset",
        "--out",
        dir.path().join("x").to_str().unwrap(),
        "--resistance-gradient",
        "1.5",
    ]);
    assert!(!ok && err.contains("(-1, 1)"), "{err}");
}
