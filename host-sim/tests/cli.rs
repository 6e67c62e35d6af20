//! The command line: results, round trips and clear errors.

mod common;
use common::run;

#[test]
fn model_then_invert_round_trips() {
    let (ok, out, err) = run(&[
        "model",
        "--r",
        "700k",
        "--c",
        "200p",
        "--f",
        "6k",
        "--model",
        "continuous",
        "--csv",
    ]);
    assert!(ok, "{err}");
    let row: Vec<&str> = out.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[0], "continuous");
    let (cs, rs): (f64, f64) = (row[3].parse().unwrap(), row[4].parse().unwrap());
    assert!(cs < 140.0 && cs > 130.0, "{cs}");
    let (ok, out, err) = run(&[
        "invert",
        "--cs",
        &format!("{cs}p"),
        "--rs",
        &format!("{rs}"),
        "--f",
        "6k",
        "--c-hint",
        "200p",
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("C   = 200.0"), "{out}");
    assert!(
        out.contains("R   = 700.0") || out.contains("R   = 699.9"),
        "{out}"
    );
}

#[test]
fn lumped_meter_underreads_more_at_higher_frequency() {
    let (ok, out, _) = run(&[
        "model",
        "--r",
        "700k",
        "--c",
        "200p",
        "--f",
        "500,2k,6k",
        "--model",
        "30",
        "--csv",
    ]);
    assert!(ok);
    let errs: Vec<f64> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(6).unwrap().parse().unwrap())
        .collect();
    assert_eq!(errs.len(), 3);
    assert!(errs[0] > -1.0 && errs[1] < -5.0 && errs[2] < -30.0, "{errs:?}");
}

#[test]
fn clear_errors() {
    let (ok, _, err) = run(&["model", "--r", "700x", "--c", "200p", "--f", "6k"]);
    assert!(!ok && err.contains("unknown SI prefix"), "{err}");
    let (ok, _, err) = run(&[
        "model", "--r", "700k", "--c", "200p", "--f", "6k", "--model", "65",
    ]);
    assert!(!ok && err.contains("ladder size 1..=64"), "{err}");
    let (ok, _, err) = run(&["model", "--r", "700k", "--c", "200p", "--f", "80k"]);
    assert!(!ok && err.contains("supported"), "{err}");
    let (ok, _, err) = run(&["invert", "--cs", "150p", "--rs", "200k", "--f", "6k"]);
    assert!(!ok && err.contains("lower the frequency"), "{err}");
    assert!(!err.contains("backtrace"), "{err}");
}
