//! Data that no generator of ours writes: traces too short to model, and
//! time stamps packed far closer than the meter window needs.

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options};
use host_sim::model::{Effect, Line, Params, Prepared};
use std::path::Path;

fn dataset(dir: &Path) {
    host_sim::experiments::dataset(
        dir,
        host_sim::experiments::with_effects(Params::NONE),
        host_sim::chain::Meter::LCR,
        2,
        indicatif::ProgressBar::hidden(),
    )
    .unwrap();
}

/// The header and the data rows of a CSV file (comments left out).
fn table(file: &Path) -> (String, Vec<String>) {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#')).map(String::from);
    let head = lines.next().unwrap();
    (head, lines.collect())
}

/// Replace the rows of `file` (keeping its header) by `rows`.
fn rewrite(file: &Path, rows: impl Iterator<Item = String>) {
    let (head, _) = table(file);
    let body: Vec<String> = std::iter::once(head).chain(rows).collect();
    std::fs::write(file, body.join("\n") + "\n").unwrap();
}

fn first_trace(dir: &Path) -> std::path::PathBuf {
    let mut t: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("trace_"))
        .collect();
    t.sort();
    t.remove(0)
}

#[test]
fn a_two_row_trace_is_an_error_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    dataset(tmp.path());
    let trace = first_trace(tmp.path());
    let (_, rows) = table(&trace);
    rewrite(&trace, rows.into_iter().take(2));
    let err = identify(&read_dir(tmp.path()).unwrap(), Options::default())
        .unwrap_err()
        .to_string();
    let name = trace.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        err.contains(&name) && err.contains("2 rows") && err.contains("at least 8"),
        "{err}"
    );
}

#[test]
fn rows_a_nanosecond_apart_keep_the_window_grid_bounded() {
    let tmp = tempfile::tempdir().unwrap();
    dataset(tmp.path());
    let trace = first_trace(tmp.path());
    let (head, rows) = table(&trace);
    let head: Vec<&str> = head.split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (tc, fc) = (col("time_s"), col("freq_hz"));
    let row: Vec<String> = rows[0].split(',').map(String::from).collect();
    // 200 rows 1 ns apart, at the file's frequency.
    let rows = (0..200).map(|k| {
        let mut r = row.clone();
        r[tc] = format!("{:.9}", k as f64 * 1e-9);
        r[fc] = row[fc].clone();
        r.join(",")
    });
    rewrite(&trace, rows);
    let prep = Prepared::new(&read_dir(tmp.path()).unwrap(), false).unwrap();
    // A 50 ms window over a 0.2 µs trace: without a bound the grid would
    // hold 3·10⁹ points (48 GB).
    let pred = prep
        .predict(Line::Continuous, Params::NONE.with(Effect::MeterLag, 0.05))
        .unwrap();
    assert!(
        pred[0].len() == 200 && pred[0].iter().all(|v| v.is_finite()),
        "{:?}",
        &pred[0][..3]
    );
}

/// Rows the model cannot evaluate are errors with their place, not
/// `error: baseline` or NaN pF in a table: a frequency or a resistance of
/// zero; a whole trace at 1 MHz is modelled.
#[test]
fn rows_the_model_cannot_evaluate_are_located() {
    for (col, value, ok) in [
        ("freq_hz", "0", false),
        ("r_top_ohm", "0", false),
        ("freq_hz", "1000000", true),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        dataset(tmp.path());
        let trace = first_trace(tmp.path());
        let (head, rows) = table(&trace);
        let k = head.split(',').position(|c| c == col).unwrap();
        let bad: Vec<String> = rows
            .into_iter()
            .enumerate()
            .map(|(n, r)| {
                if n == 5 || ok {
                    let mut f: Vec<&str> = r.split(',').collect();
                    f[k] = value;
                    f.join(",")
                } else {
                    r
                }
            })
            .collect();
        rewrite(&trace, bad.into_iter());
        let name = trace.file_name().unwrap().to_string_lossy().into_owned();
        let got = read_dir(tmp.path()).and_then(|ds| identify(&ds, Options::default()));
        match (got, ok) {
            (Err(e), false) => {
                let e = e.to_string();
                // Line 7: the header, then the sixth row.
                assert!(
                    e.contains(&format!("{name}:7:{}", k + 1)) && e.contains(col),
                    "{e}"
                );
            }
            (Ok(report), true) => {
                let text = report.markdown("data", None);
                assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
            }
            (other, _) => panic!("{col} = {value}: {:?}", other.map(|_| ())),
        }
    }
}

/// A set of calibration and sweep points alone has no noise floor to judge
/// a fit against: a clear error, not a built-in 0.001 pF and "± inf".
#[test]
fn a_sweep_only_set_is_an_error_not_a_made_up_noise_floor() {
    let tmp = tempfile::tempdir().unwrap();
    dataset(tmp.path());
    for e in std::fs::read_dir(tmp.path()).unwrap() {
        let p = e.unwrap().path();
        if p.file_name().unwrap().to_string_lossy().starts_with("trace_") {
            std::fs::remove_file(p).unwrap();
        }
    }
    let err = identify(&read_dir(tmp.path()).unwrap(), Options::default())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(err.contains("no trace") && err.contains("noise floor"), "{err}");
}
