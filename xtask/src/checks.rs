//! `cargo xtask test`: every check CI runs, in the order that fails
//! cheapest first.

use crate::cargo;
use anyhow::Result;
use std::path::Path;

/// The host crates rustdoc checks.
const DOC_CRATES: [&str; 9] = [
    "dsp-core",
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

/// Everything: formatting, lints, docs, host tests, cross builds, the
/// board images and the QEMU tests (which run with the host tests).
pub fn all(root: &Path) -> Result<()> {
    format(root)?;
    lint(root)?;
    docs(root)?;
    // Host tests in release: the Monte-Carlo and sweep tests are large;
    // overflow checks stay on through the dev-profile run of the
    // fixed-point unit tests below. The QEMU tests are in this run. The
    // fuzz targets (proptest, 10⁵ cases each) draw from one fixed seed,
    // so that a run is reproducible and a red one is the code's, not the
    // draw's: `cargo xtask fuzz` draws fresh seeds, 10⁶ cases each.
    cargo::run_env(
        root,
        &["test", "--release", "--workspace"],
        &[("PROPTEST_RNG_SEED", PROPTEST_SEED)],
    )?;
    cargo::run(root, &["test", "-p", "dsp-core", "--lib"])?;
    cargo::run(root, &["test", "--doc", "-p", "dsp-core"])?;
    // The feature sets the workspace run does not build: the link's
    // encoder with the table-less CRC (the single-channel board's store
    // image), held to the crates' CRC and COBS at every length; dsp-core
    // without its ladder kernels (the boards').
    cargo::run(
        root,
        &[
            "test",
            "--release",
            "-p",
            "link",
            "--lib",
            "--features",
            "small-crc",
        ],
    )?;
    cargo::run(
        root,
        &[
            "clippy",
            "-p",
            "dsp-core",
            "--no-default-features",
            "--",
            "-D",
            "warnings",
        ],
    )?;
    // dsp-core on every core we support: M4F (DSP + FPU) and M3.
    for t in [qemu_tests::TARGET, "thumbv7m-none-eabi"] {
        cargo::run(root, &["build", "--release", "-p", "dsp-core", "--target", t])?;
    }
    board(root)
}

/// `cargo fmt --check` on both workspaces.
fn format(root: &Path) -> Result<()> {
    cargo::run(root, &["fmt", "--all", "--check"])?;
    cargo::run(&root.join("firmware"), &["fmt", "--all", "--check"])
}

/// clippy with warnings as errors: the host crates with all their
/// targets; the firmware's images for the target, and its library with
/// its tests on the host (the board's register tests), for each feature.
fn lint(root: &Path) -> Result<()> {
    cargo::run(root, &["clippy", "--all-targets", "--", "-D", "warnings"])?;
    let fw = root.join("firmware");
    let t = qemu_tests::TARGET;
    cargo::run(
        &fw,
        &[
            "clippy",
            "--release",
            "--target",
            t,
            "--bins",
            "--",
            "-D",
            "warnings",
        ],
    )?;
    for feature in ["qemu", "board", "board,store"] {
        cargo::run(
            &fw,
            &[
                "clippy",
                "--release",
                "--target",
                t,
                "--bins",
                "--features",
                feature,
                "--",
                "-D",
                "warnings",
            ],
        )?;
        cargo::run(
            &fw,
            &[
                "clippy",
                "--lib",
                "--tests",
                "--features",
                feature,
                "--",
                "-D",
                "warnings",
            ],
        )?;
    }
    Ok(())
}

/// rustdoc on every crate, no warnings, no broken links: the host crates,
/// and the firmware (library and apps) for each of its images.
fn docs(root: &Path) -> Result<()> {
    let deny = [("RUSTDOCFLAGS", "-D warnings")];
    let mut args = vec!["doc", "--no-deps"];
    for c in DOC_CRATES {
        args.extend(["-p", c]);
    }
    cargo::run_env(root, &args, &deny)?;
    for feature in ["qemu", "board", "board,store"] {
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
            &deny,
        )?;
    }
    Ok(())
}

/// The board images, built through the aliases users flash with
/// (`flash-board` takes the same arguments): they must build and link
/// even with no board here; then the board's register tests on the host.
fn board(root: &Path) -> Result<()> {
    let fw = root.join("firmware");
    // With the tests' flags, so the images the budgets measure are not
    // built twice.
    let flags = qemu_tests::firmware_rustflags();
    let env = [("CARGO_ENCODED_RUSTFLAGS", flags.as_str())];
    // The variants first: the defaults' images are the ones left.
    cargo::run_env(&fw, &["build-board-plain"], &env)?;
    cargo::run_env(&fw, &["build-board"], &env)?;
    cargo::run_env(&fw, &["build-array-board-1ms"], &env)?;
    cargo::run_env(&fw, &["build-array-board"], &env)?;
    cargo::run(&fw, &["test", "--lib", "--features", "board"])
}
