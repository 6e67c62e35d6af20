//! The repository's example data set (`data/example`) is what rig-sim
//! writes at its fixed seed (`cargo xtask example-data`): every file,
//! every row, every value.

use std::path::Path;

/// The rows of a CSV file, each split into its fields.
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn the_example_data_set_is_what_rig_sim_writes() {
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/example");
    let tmp = tempfile::tempdir().unwrap();
    rig_sim::Bench::example().write(tmp.path()).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut in_repo: Vec<String> = std::fs::read_dir(&committed)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".csv"))
        .collect();
    in_repo.sort();
    assert_eq!(names, in_repo, "run `cargo xtask example-data`");
    for name in &names {
        let (fresh, kept) = (rows(&tmp.path().join(name)), rows(&committed.join(name)));
        assert_eq!(
            fresh.len(),
            kept.len(),
            "{name}: rows; run `cargo xtask example-data`"
        );
        for (line, (a, b)) in fresh.iter().zip(&kept).enumerate() {
            assert_eq!(a.len(), b.len(), "{name}:{}", line + 1);
            for (col, (x, y)) in a.iter().zip(b).enumerate() {
                // Numbers within a part in 10⁹ (a libm's last bit on
                // another machine), headers to the letter.
                let same = match (x.parse::<f64>(), y.parse::<f64>()) {
                    (Ok(u), Ok(v)) => (u - v).abs() <= 1e-9 * u.abs().max(v.abs()),
                    _ => x == y,
                };
                assert!(
                    same,
                    "{name}:{}:{}: generated {x}, committed {y}; run `cargo xtask example-data`",
                    line + 1,
                    col + 1
                );
            }
        }
    }
}
