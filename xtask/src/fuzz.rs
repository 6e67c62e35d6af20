//! The fuzz targets: which tests draw their cases from a variable, and
//! how they are run at a count (`cargo xtask fuzz`, the long pass).

use crate::{cargo, checks};
use anyhow::Result;
use std::path::Path;

/// A fuzz target: the tests of one file whose count of cases a variable
/// sets (each test's default, unset, is the long pass's: 10⁵ cases, or
/// what the test derives from it).
pub struct Target {
    /// The file that reads the variable, from the workspace's root.
    pub source: &'static str,
    /// The package.
    pub package: &'static str,
    /// Its test binary (`None`: the library's unit tests).
    pub test: Option<&'static str>,
    /// The tests of that binary it is (a name filter), or all of them.
    pub filter: Option<&'static str>,
    /// The variable that sets its count of cases (a test may take a
    /// share of it: its doc comment says).
    pub var: &'static str,
}

/// Every fuzz target of the workspace. A file that reads one of the
/// variables and is not here is caught by this module's test.
pub const TARGETS: [Target; 7] = [
    target(
        "dsp-core/tests/fuzz.rs",
        "dsp-core",
        Some("fuzz"),
        None,
        "FUZZ_CASES",
    ),
    target(
        "instrument/tests/fuzz.rs",
        "instrument",
        Some("fuzz"),
        None,
        "FUZZ_CASES",
    ),
    target(
        "host-sim/tests/fuzz.rs",
        "host-sim",
        Some("fuzz"),
        None,
        "FUZZ_CASES",
    ),
    // The array under interferers of any frequency and amplitude: from
    // the start, late, long enough for the channels to move off one, and
    // on sensors of drawn cable, leads and film (the four
    // `…never_leave_a_wrong_valid_record` tests; the last three take
    // FUZZ_CASES / 20).
    target(
        "instrument/tests/tones.rs",
        "instrument",
        Some("tones"),
        Some("never_leave_a_wrong_valid_record"),
        "FUZZ_CASES",
    ),
    // A clean skin anywhere in the documented range: a case is sixteen
    // sensors for 2.2 s, so FUZZ_CASES / 500 of them.
    target(
        "host-sim/tests/disturbances.rs",
        "host-sim",
        Some("disturbances"),
        Some("availability_fuzz"),
        "FUZZ_CASES",
    ),
    // The record link: corrupted streams.
    target("link/tests/frames.rs", "link", Some("frames"), None, "LINK_CASES"),
    // The device's requests: fuzzed command streams against a store
    // (each case a whole stream of uploads and damage).
    target(
        "instrument/src/commands/tests.rs",
        "instrument",
        None,
        Some("commands::"),
        "COMMAND_CASES",
    ),
];

/// Files whose tests read a count's variable inside a long test
/// (`#[ignore = "long: …"]`, at the count's default there) as well as a
/// fast one: the long pass runs them with the other long tests.
#[cfg(test)]
const IN_LONG_TESTS: [&str; 1] = ["tests/tests/array.rs"];

const fn target(
    source: &'static str,
    package: &'static str,
    test: Option<&'static str>,
    filter: Option<&'static str>,
    var: &'static str,
) -> Target {
    Target {
        source,
        package,
        test,
        filter,
        var,
    }
}

impl Target {
    /// `cargo test` arguments that select the target's tests, in
    /// [`checks::TEST_PROFILE`].
    pub fn args(&self) -> Vec<&'static str> {
        let mut args = vec!["test", "--profile", checks::TEST_PROFILE, "-p", self.package];
        match self.test {
            Some(t) => args.extend(["--test", t]),
            None => args.push("--lib"),
        }
        args.push("--");
        args.extend(self.filter);
        args
    }
}

/// The nextest filterset of every target (for a run of the workspace,
/// whose features are the fast pass's: nothing is built again).
pub fn filterset() -> String {
    let one = |t: &Target| {
        let id = match t.test {
            Some(test) => format!("binary_id(={}::{test})", t.package),
            None => format!("binary_id(={})", t.package),
        };
        match t.filter {
            Some(f) => format!("({id} & test(~{f}))"),
            None => id,
        }
    };
    TARGETS.iter().map(one).collect::<Vec<_>>().join(" | ")
}

/// Every target with `cases` cases (`None`: each test's default), the
/// variables `env` beside: `cargo xtask fuzz` draws fresh seeds, the
/// long pass sets [`checks::PROPTEST_SEED`].
pub fn run_all(root: &Path, cases: Option<u64>, env: &[(&str, &str)]) -> Result<()> {
    let n = cases.map(|c| c.to_string());
    for t in &TARGETS {
        let mut all = env.to_vec();
        if let Some(n) = &n {
            all.push((t.var, n));
        }
        eprintln!("fuzz target: {} ({})", t.source, t.var);
        let mut args = t.args();
        args.push("--nocapture");
        cargo::run_env(root, &args, &all)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every source file of the workspace that reads a count's variable
    /// is a target or a long test's, so that no fuzz target is left out
    /// of the long pass or of `cargo xtask fuzz`.
    #[test]
    fn every_file_that_reads_a_count_is_a_target() {
        let root = qemu_tests::root();
        // The variables the fast pass sets for every target.
        let vars = checks::FAST_COUNTS;
        let mut found = vec![];
        for dir in [
            "dsp-core",
            "instrument",
            "host-sim",
            "link",
            "live",
            "tests",
            "skin-sim",
        ] {
            walk(&root.join(dir), &mut |path, text| {
                if vars.iter().any(|v| text.contains(&format!("env::var(\"{v}\")"))) {
                    found.push(path.strip_prefix(&root).unwrap().display().to_string());
                }
            });
        }
        assert!(found.len() >= TARGETS.len(), "{found:?}");
        for f in &found {
            let known = TARGETS.iter().any(|t| t.source == f) || IN_LONG_TESTS.contains(&f.as_str());
            assert!(known, "{f} reads a count of cases and is no fuzz target");
        }
        for t in &TARGETS {
            assert!(found.iter().any(|f| f == t.source), "{} reads no count", t.source);
        }
    }

    /// The filterset names each target once, by its binary, with its
    /// name filter where it has one.
    #[test]
    fn the_filterset_names_every_target() {
        let fs = filterset();
        assert_eq!(fs.split(" | ").count(), TARGETS.len(), "{fs}");
        assert!(fs.contains("(binary_id(=instrument::tones) & test(~never_leave_a_wrong_valid_record))"));
        assert!(
            fs.contains("(binary_id(=instrument) & test(~commands::))"),
            "{fs}"
        );
    }

    fn walk(dir: &Path, f: &mut dyn FnMut(&Path, &str)) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() && p.file_name().is_some_and(|n| n != "target") {
                walk(&p, f);
            } else if p.extension().is_some_and(|x| x == "rs") {
                f(&p, &std::fs::read_to_string(&p).unwrap());
            }
        }
    }
}
