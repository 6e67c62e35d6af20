//! `cargo xtask test [--full]`: every check CI runs, in the order that
//! fails cheapest first, at two speeds ([`Pass`]).

use crate::cargo;
use anyhow::Result;
use std::path::Path;
use std::thread::JoinHandle;

/// The host crates rustdoc checks.
const DOC_CRATES: [&str; 10] = [
    "dsp-core",
    "skin-spec",
    "link",
    "live",
    "instrument",
    "skin-sim",
    "host-sim",
    "rig-sim",
    "qemu-tests",
    "figures",
];

/// The seed of the test command's fuzz targets.
pub const PROPTEST_SEED: &str = "26";

/// How much a run of the checks covers.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Pass {
    /// The test command (`cargo xtask test`): every check, each long
    /// sweep and QEMU scenario at its smoke size, each fuzz target at
    /// [`FAST_CASES`] cases.
    Fast,
    /// `cargo xtask test --full`: the fast pass, then [`Pass::Long`].
    Full,
    /// `cargo xtask test --long`: what the full pass adds to the fast
    /// one, alone (CI runs it after the test command, so that no check
    /// runs twice): the lints of the firmware's library tests, the link
    /// with the table-less CRC, the long tests (`#[ignore = "long: …"]`)
    /// and every fuzz target at its full count (10⁵ cases).
    Long,
}

/// Cases per fuzz target in the fast pass (fixed seed [`PROPTEST_SEED`]).
pub const FAST_CASES: &str = "1000";

/// The cargo profile of every host test: release code without fat LTO
/// (the workspace's `Cargo.toml`), xtask's own.
pub const TEST_PROFILE: &str = "quick";

/// Everything of `pass`: formatting, lints, docs, host tests, cross
/// builds, the board images and the QEMU tests (which run with the host
/// tests, once `packages`, the system packages being installed, are).
pub fn all(root: &Path, pass: Pass, packages: JoinHandle<Result<()>>) -> Result<()> {
    match pass {
        Pass::Fast => fast(root, packages),
        Pass::Full => fast(root, packages).and_then(|()| long(root)),
        Pass::Long => installed(packages).and_then(|()| long(root)),
    }
}

/// Once the set-up's system packages are installed.
fn installed(packages: JoinHandle<Result<()>>) -> Result<()> {
    packages
        .join()
        .map_err(|_| anyhow::anyhow!("the set-up panicked"))?
}

/// The fast pass: every check, the tests at their smoke sizes, a minute
/// of the soak.
fn fast(root: &Path, packages: JoinHandle<Result<()>>) -> Result<()> {
    format(root)?;
    // The firmware's workspace (its own target folder) is linted, documented
    // and built beside the host's lints and docs: its fat-LTO links leave
    // a core idle that the host's builds take. The QEMU tests run the
    // images it builds, so the host tests wait for it.
    let (firmware, host) = std::thread::scope(|s| {
        let fw = s.spawn(|| firmware(root));
        let host = lint(root)
            .and_then(|()| docs(root))
            .and_then(|()| host_extras(root));
        (fw.join(), host)
    });
    host?;
    firmware.map_err(|_| anyhow::anyhow!("the firmware's checks panicked"))??;
    installed(packages)?;
    host_tests(root)?;
    // A minute of `cargo xtask soak`.
    print!("{}", crate::soak::run(root, &crate::soak::Soak::minute())?);
    Ok(())
}

/// What the full pass adds: the firmware library's lints with its
/// tests for each feature set, the link's encoder with the table-less
/// CRC (the single-channel board's store image's, held to the crates'
/// CRC and COBS at every length), the long tests, every fuzz target at
/// its full count.
fn long(root: &Path) -> Result<()> {
    // The firmware's workspace beside the host's, as in the fast pass.
    let (firmware, host) = std::thread::scope(|s| {
        let fw = s.spawn(|| {
            let fw = root.join("firmware");
            ["qemu", "board", "board,store"]
                .into_iter()
                .try_for_each(|f| clippy(&fw, &["--lib", "--tests", "--features", f]))
        });
        let link = ["test", "--profile", TEST_PROFILE, "-p", "link", "--lib"];
        let host = cargo::run(root, &[&link[..], &["--features", "small-crc"]].concat());
        (fw.join(), host)
    });
    host?;
    firmware.map_err(|_| anyhow::anyhow!("the firmware's lints panicked"))??;
    long_tests(root)
}

/// The long tests (the surveys are `cargo xtask survey`'s), then every
/// fuzz target at its full count: side by side across test binaries with
/// cargo-nextest where the machine has it (a binary of one long QEMU
/// test would leave a core idle; `.config/nextest.toml` starts the
/// slowest first), else with `cargo test`, binary after binary.
fn long_tests(root: &Path) -> Result<()> {
    let env = [("PROPTEST_RNG_SEED", PROPTEST_SEED)];
    if !cargo::has_subcommand("nextest") {
        let mut args = vec!["test", "--profile", TEST_PROFILE, "--workspace"];
        args.extend(["--", "--ignored", "--exact", "--skip", "survey"]);
        cargo::run_env(root, &args, &env)?;
        return crate::fuzz::run_all(root, None, &env);
    }
    let nextest = |selection: &[&str]| {
        let mut args = vec!["nextest", "run", "--cargo-profile", TEST_PROFILE];
        args.extend(["--workspace", "--no-fail-fast"]);
        args.extend_from_slice(selection);
        cargo::run_env(root, &args, &env)
    };
    nextest(&["--run-ignored", "only", "-E", "not test(=survey)"])?;
    nextest(&["-E", &crate::fuzz::filterset()])
}

/// The host's checks beside the workspace's tests, and those tests
/// built: the feature sets the workspace run does not build (dsp-core
/// without its ladder kernels, the boards'); dsp-core built for every
/// core we support, M4F (DSP + FPU) and M3.
fn host_extras(root: &Path) -> Result<()> {
    clippy(root, &["-p", "dsp-core", "--no-default-features"])?;
    for t in [qemu_tests::TARGET, "thumbv7m-none-eabi"] {
        cargo::run(root, &["build", "--release", "-p", "dsp-core", "--target", t])?;
    }
    // The workspace's tests built while the firmware's images still are.
    cargo::run(
        root,
        &["test", "--profile", TEST_PROFILE, "--workspace", "--no-run"],
    )
}

/// The firmware's workspace: clippy and rustdoc on its images and
/// library, its images built once, the board's register tests on the
/// host.
fn firmware(root: &Path) -> Result<()> {
    firmware_lint(root)?;
    firmware_docs(root)?;
    images(root)?;
    cargo::run(&root.join("firmware"), &["test", "--lib", "--features", "board"])
}

/// Every host test (the QEMU tests among them) in [`TEST_PROFILE`]. The
/// fuzz targets (proptest) draw from one fixed seed, so that a run is
/// reproducible and a red one is the code's, not the draw's: `cargo
/// xtask fuzz` draws fresh seeds, 10⁶ cases each. dsp-core runs with
/// overflow checks and debug assertions on (the profile's override).
fn host_tests(root: &Path) -> Result<()> {
    let args = ["test", "--profile", TEST_PROFILE, "--workspace"];
    let mut env = vec![("PROPTEST_RNG_SEED", PROPTEST_SEED)];
    env.extend(FAST_COUNTS.map(|var| (var, FAST_CASES)));
    cargo::run_env(root, &args, &env)?;
    python_tests(root)
}

/// The Python reader's own tests (`python/`, pytest), on the Python that
/// has numpy, pandas and pytest (the system's, where PATH leads to
/// pyenv's without them); its agreement with `live` on a firmware stream
/// is a QEMU test (`the_python_reader_agrees_with_live_record_for_record`).
fn python_tests(root: &Path) -> Result<()> {
    let py = qemu_tests::python_with("numpy, pandas, pytest");
    cargo::system(
        root,
        py,
        &["-m", "pytest", "-q", "-p", "no:cacheprovider", "python/tests"],
        &[("PYTHONPATH", "python"), ("PYTHONDONTWRITEBYTECODE", "1")],
    )
}

/// The variables that set a fuzz target's count of cases (each test's
/// default is the full pass's).
pub const FAST_COUNTS: [&str; 3] = ["FUZZ_CASES", "LINK_CASES", "COMMAND_CASES"];

/// `cargo fmt --check` on both workspaces.
fn format(root: &Path) -> Result<()> {
    cargo::run(root, &["fmt", "--all", "--check"])?;
    cargo::run(&root.join("firmware"), &["fmt", "--all", "--check"])
}

/// clippy with warnings as errors on the host crates with all their
/// targets.
fn lint(root: &Path) -> Result<()> {
    clippy(root, &["--all-targets"])
}

/// clippy with warnings as errors on the firmware's images for the
/// target, for each feature set (`bench` holds the QEMU images, `qemu`
/// with the benchmarks). The long pass lints its library with its tests
/// on the host (the board's register tests) for each feature set; the
/// fast pass builds those tests, with `board`.
fn firmware_lint(root: &Path) -> Result<()> {
    let fw = root.join("firmware");
    let t = qemu_tests::TARGET;
    for feature in FIRMWARE_FEATURES {
        let args = ["--release", "--target", t, "--bins", "--features", feature];
        clippy(&fw, &args)?;
    }
    Ok(())
}

/// The firmware's feature sets, one for each set of images (and the
/// array's for 60 Hz mains).
const FIRMWARE_FEATURES: [&str; 4] = ["bench", "board", "board,store", "board,mains-60hz"];

/// `cargo clippy ARGS -- -D warnings` in `dir`.
fn clippy(dir: &Path, args: &[&str]) -> Result<()> {
    let mut all = vec!["clippy"];
    all.extend_from_slice(args);
    all.extend(["--", "-D", "warnings"]);
    cargo::run(dir, &all)
}

/// rustdoc on every host crate, no warnings, no broken links.
fn docs(root: &Path) -> Result<()> {
    let mut args = vec!["doc", "--no-deps"];
    for c in DOC_CRATES {
        args.extend(["-p", c]);
    }
    cargo::run_env(root, &args, &[DENY_DOC_WARNINGS])
}

/// rustdoc on the firmware (library and apps) for each set of images.
fn firmware_docs(root: &Path) -> Result<()> {
    for feature in FIRMWARE_FEATURES {
        cargo::run_env(
            &root.join("firmware"),
            &[
                "doc",
                "--no-deps",
                "--release",
                "--target",
                qemu_tests::TARGET,
                "--features",
                feature,
            ],
            &[DENY_DOC_WARNINGS],
        )?;
    }
    Ok(())
}

/// rustdoc's warnings (broken links among them) as errors.
const DENY_DOC_WARNINGS: (&str, &str) = ("RUSTDOCFLAGS", "-D warnings");

/// Every firmware image the pass runs or measures, built once: the QEMU
/// ones with the tests' flags and profile (what `qemu_tests::build_firmware`
/// builds), and the board images through the aliases users flash with
/// (`flash-board` takes the same arguments), which must build and link
/// even with no board here. Their variants (the board without its store,
/// the array in 1 ms blocks) are the full pass's: its budget tests build
/// them.
fn images(root: &Path) -> Result<()> {
    let fw = root.join("firmware");
    // With the tests' flags, so the images the budgets measure are not
    // built twice.
    let flags = qemu_tests::firmware_rustflags();
    let env = [("CARGO_ENCODED_RUSTFLAGS", flags.as_str())];
    let t = qemu_tests::TARGET;
    let release = ["build", "--release", "--target", t];
    for (bins, feature) in [
        (&["skin-qemu", "skin-array"][..], "qemu"),
        (&["dsp-bench"], "bench"),
    ] {
        let mut args = release.to_vec();
        args.extend(["--features", feature]);
        for b in bins {
            args.extend(["--bin", b]);
        }
        cargo::run_env(&fw, &args, &env)?;
    }
    cargo::run_env(&fw, &["build-board"], &env)?;
    cargo::run_env(&fw, &["build-array-board"], &env)
}
