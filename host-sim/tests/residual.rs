//! The baseline model and its residual: the independent example data set
//! is explained down to its noise once the calibration's bias is taken
//! out; an undeclared effect leaves a residual far above the noise.

use dsp_core::tline::LineModel;
use host_sim::baseline::{residuals, Baseline};
use host_sim::dataset::read_dir;
use std::path::Path;

#[test]
fn example_data_set_is_explained_down_to_the_noise() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example");
    let ds = read_dir(&dir).unwrap();
    let b = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, true).unwrap();
    for r in residuals(&ds, &b) {
        println!("{}: rms {:.3} pF, noise {:.3} pF", r.file, r.rms_pf, r.noise_pf);
        assert!(r.rms_pf <= 1.5 * r.noise_pf, "{r:?}");
    }
    // The paper's shortcut (calibration Cs taken as the true C) is not.
    let raw = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, false).unwrap();
    let worst = residuals(&ds, &raw)
        .iter()
        .map(|r| r.rms_pf / r.noise_pf)
        .fold(0.0, f64::max);
    assert!(worst > 5.0, "{worst}");
}

#[test]
fn an_undeclared_effect_leaves_a_residual() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean");
    let fx = dir.path().join("parasitic");
    let hidden = || indicatif::ProgressBar::hidden();
    host_sim::experiments::dataset(
        &clean,
        host_sim::experiments::with_effects(instrument::effects::EffectSet::NONE),
        host_sim::chain::Meter::LCR,
        5,
        hidden(),
    )
    .unwrap();
    let effects =
        instrument::effects::EffectSet::NONE.with(instrument::effects::Effect::ParasiticCapacitance, 10e-12);
    host_sim::experiments::dataset(
        &fx,
        host_sim::experiments::with_effects(effects),
        host_sim::chain::Meter::LCR,
        5,
        hidden(),
    )
    .unwrap();
    let ratio = |d: &Path| {
        let ds = read_dir(d).unwrap();
        let b = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, true).unwrap();
        residuals(&ds, &b)
            .iter()
            .map(|r| r.rms_pf / r.noise_pf)
            .fold(0.0, f64::max)
    };
    let (c, p) = (ratio(&clean), ratio(&fx));
    println!("residual / noise: clean {c:.2}, 10 pF parasitic {p:.2}");
    assert!(c < 1.5, "{c}");
    assert!(p > 5.0, "{p}");
}

/// `docs/identify.md` shows the example data set's residual per trace,
/// as `host-sim residual data/example` computes it.
#[test]
fn the_docs_show_the_example_data_sets_verdicts() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example");
    let ds = read_dir(&dir).unwrap();
    let b = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, true).unwrap();
    let raw = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, false).unwrap();
    let mut md = String::from(
        "| trace | residual RMS | noise floor | ratio | with the raw calibration (Cs taken as C) |\n\
         |---|---:|---:|---:|---:|\n",
    );
    for (r, w) in residuals(&ds, &b).iter().zip(residuals(&ds, &raw)) {
        md += &format!(
            "| `{}` | {:.3} pF | {:.3} pF | {:.2} | {:.1}× the noise |\n",
            r.file,
            r.rms_pf,
            r.noise_pf,
            r.rms_pf / r.noise_pf,
            w.rms_pf / w.noise_pf
        );
    }
    figures::check("docs/identify.md", "example-residual", &md).unwrap();
}

/// Rows the instrument flagged are left out of the analyses, and said so:
/// a trace whose disturbed rows read 5 pF off keeps the residual of its
/// clean rows, and rows whose only flag is the status UNCALIBRATED are
/// kept; a flags field that is not a number is refused by place.
#[test]
fn flagged_rows_are_left_out_and_counted() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example");
    let tmp = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir(&src).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "csv") {
            std::fs::copy(&p, tmp.path().join(p.file_name().unwrap())).unwrap();
        }
    }
    let name = "trace_20mmps_2000hz.csv";
    let text = std::fs::read_to_string(src.join(name)).unwrap();
    let mut out = String::new();
    let cs_col = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == "cs_pf")
        .unwrap();
    for (k, line) in text.lines().enumerate() {
        if k == 0 {
            out += &format!("{line},flags\n");
            continue;
        }
        let disturbed = k % 25 == 0;
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        if disturbed {
            let cs: f64 = f[cs_col].parse().unwrap();
            f[cs_col] = format!("{:.3}", cs + 5.0);
        }
        // DISTURBED (64) is a fault; UNCALIBRATED (512) a status the
        // rows keep.
        let flags = match (disturbed, k % 2) {
            (true, _) => 64 | 512,
            (false, 1) => 512,
            _ => 0,
        };
        out += &format!("{},{flags}\n", f.join(","));
    }
    std::fs::write(tmp.path().join(name), &out).unwrap();
    let ds = read_dir(tmp.path()).unwrap();
    let t = ds.traces.iter().find(|t| t.path.ends_with(name)).unwrap();
    let rows = text.lines().count() - 1;
    assert_eq!(t.flagged, rows / 25);
    assert_eq!(t.rows.len(), rows - rows / 25);
    let b = Baseline::from_calibration(&ds.calibration, LineModel::Continuous, true).unwrap();
    let r = residuals(&ds, &b)
        .into_iter()
        .find(|r| r.file.contains("20mmps_2000"))
        .unwrap();
    assert!(r.rms_pf <= 1.5 * r.noise_pf, "{r:?}");
    let cli = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("residual")
        .arg(tmp.path())
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&cli.stdout);
    assert!(
        said.contains(&format!("{} rows the instrument flagged, left out", rows / 25)),
        "{said}"
    );
    // A flags field that is not the instrument's flags.
    std::fs::write(tmp.path().join(name), out.replacen(",576\n", ",x\n", 1)).unwrap();
    let e = read_dir(tmp.path()).unwrap_err().to_string();
    assert!(
        e.contains(name) && e.contains("column 'flags'") && e.contains("'x'"),
        "{e}"
    );
}
