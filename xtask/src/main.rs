//! `cargo xtask <command>`: the project's automation, one place for what
//! the README and CI run.
//!
//! * `setup`: install what a fresh Debian machine lacks (QEMU, ngspice)
//!   and the Rust targets of `rust-toolchain.toml`.
//! * `test`: set-up, then formatting, clippy, every host test, the board
//!   firmware build and the QEMU integration tests.
//! * `bench`: instruction counts on Cortex-M4 in QEMU (`-icount`), and with
//!   `--host` the criterion benchmarks.
//! * `run`: the main job (see the README).
//! * `survey`: `identify` over the physical ranges on both generators,
//!   many seeds (the README's figures).
//! * `fuzz`: the fuzz targets (proptest) with 1 000 000 cases each; the
//!   test command runs them with 2 000.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::path::Path;
use std::process::Command;

mod main_job;

#[derive(Parser)]
#[command(name = "xtask")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Install QEMU and ngspice when missing (apt-get), and the Rust targets.
    Setup,
    /// Everything CI runs: fmt, clippy, host tests, firmware build, QEMU tests.
    Test,
    /// Instruction counts on Cortex-M4 (QEMU -icount); --host adds criterion.
    Bench {
        /// Also run the criterion benchmarks on the host.
        #[arg(long)]
        host: bool,
    },
    /// The main job: the instrument at work, results under out/.
    Run,
    /// identify over the physical ranges on both generators (`rig-sim`:
    /// with clean sets and effects outside the library; `skin-sim`): one
    /// hidden effect per set, a row per set and the README's summaries
    /// (about a minute a set).
    Survey {
        /// Sets.
        #[arg(long, default_value_t = 50)]
        seeds: u64,
    },
    /// Write the repository's example data set (`data/example/`) with
    /// rig-sim, the independent bench generator, at its fixed seed.
    ExampleData {
        /// Folder to write (its CSV files are replaced).
        #[arg(long, default_value = "data/example")]
        out: std::path::PathBuf,
    },
    /// The fuzz targets (dsp-core's API, the channel logic, the wire
    /// format, the readers) with many cases (tens of minutes).
    Fuzz {
        /// Cases per target.
        #[arg(long, default_value_t = 1_000_000)]
        cases: u64,
    },
}

fn main() -> Result<()> {
    let root = qemu_tests::root();
    std::env::set_current_dir(&root)?;
    match Cli::parse().cmd {
        Cmd::Setup => setup(),
        Cmd::ExampleData { out } => {
            rig_sim::Bench::example()
                .write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Survey { seeds } => {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let args = [
                "test",
                "--release",
                "-p",
                "host-sim",
                "--test",
                "second_generator",
                "--test",
                "identify",
                "--",
                "--ignored",
                "--nocapture",
                "survey",
            ];
            eprintln!("$ SEEDS={seeds} cargo {}", args.join(" "));
            let st = Command::new(cargo)
                .args(args)
                .env("SEEDS", seeds.to_string())
                .status()
                .context("running cargo")?;
            if !st.success() {
                bail!("the survey failed");
            }
            Ok(())
        }
        Cmd::Fuzz { cases } => {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let args = [
                "test",
                "--release",
                "-p",
                "dsp-core",
                "-p",
                "instrument",
                "-p",
                "host-sim",
                "--test",
                "fuzz",
                "--",
                "--nocapture",
            ];
            eprintln!("$ FUZZ_CASES={cases} cargo {}", args.join(" "));
            let st = Command::new(cargo)
                .args(args)
                .env("FUZZ_CASES", cases.to_string())
                .status()
                .context("running cargo")?;
            if !st.success() {
                bail!("fuzzing found a failure (proptest prints the minimal input above)");
            }
            Ok(())
        }
        Cmd::Test => {
            setup()?;
            cargo(&root, &["fmt", "--all", "--check"])?;
            cargo(&root.join("firmware"), &["fmt", "--all", "--check"])?;
            cargo(&root, &["clippy", "--all-targets", "--", "-D", "warnings"])?;
            // rustdoc on every public item, no broken links.
            let st = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
                .args([
                    "doc",
                    "--no-deps",
                    "-p",
                    "dsp-core",
                    "-p",
                    "instrument",
                    "-p",
                    "skin-sim",
                    "-p",
                    "host-sim",
                    "-p",
                    "rig-sim",
                    "-p",
                    "qemu-tests",
                ])
                .env("RUSTDOCFLAGS", "-D warnings")
                .status()?;
            if !st.success() {
                bail!("cargo doc reported warnings");
            }
            for features in [None, Some("qemu")] {
                let mut a = vec!["clippy", "--release", "--target", qemu_tests::TARGET, "--bins"];
                if let Some(f) = features {
                    a.extend(["--features", f]);
                }
                a.extend(["--", "-D", "warnings"]);
                cargo(&root.join("firmware"), &a)?;
            }
            // Host tests in release: the Monte-Carlo and sweep tests are
            // large; overflow checks stay on through the dev-profile run of
            // the fixed-point unit tests below.
            cargo(&root, &["test", "--release", "--workspace"])?;
            cargo(&root, &["test", "-p", "dsp-core", "--lib"])?;
            cargo(&root, &["test", "--doc", "-p", "dsp-core"])?;
            // dsp-core on every core we support: M4F (DSP + FPU) and M3.
            for t in [qemu_tests::TARGET, "thumbv7m-none-eabi"] {
                cargo(&root, &["build", "--release", "-p", "dsp-core", "--target", t])?;
            }
            // The board image must build and link even with no board here.
            board_build(&root)?;
            Ok(())
        }
        Cmd::Bench { host } => {
            setup()?;
            bench()?;
            if host {
                cargo(&root, &["bench", "-p", "dsp-core", "--bench", "dsp"])?;
                cargo(&root, &["bench", "-p", "host-sim", "--bench", "paper"])?;
                cargo(&root, &["bench", "-p", "host-sim", "--bench", "identify"])?;
            }
            Ok(())
        }
        Cmd::Run => {
            setup()?;
            run_main(&root)
        }
    }
}

/// The main job: the firmware in QEMU on the simulated skin under the
/// paper's stretching (out/firmware: CSV, SVG, summary), the array's
/// sixteen sensors at once (out/array: the same), then host-sim's
/// run of the paper's experiments on the simulated skin (out/paper), then
/// the Cortex-M4 counts.
fn run_main(root: &Path) -> Result<()> {
    let md = main_job::run(&root.join("out/firmware"))?;
    println!("{md}");
    let md = main_job::run_array(&root.join("out/array"))?;
    println!("{md}");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let st = Command::new(&cargo)
        .args(["run", "--release", "-q", "-p", "host-sim", "--", "paper", "--out"])
        .arg(root.join("out/paper"))
        .status()?;
    if !st.success() {
        bail!("host-sim paper failed");
    }
    bench()
}

/// Build and lint the board image for the STM32G474: it must build and
/// link even with no board attached.
/// The board image, built through the `build-board` alias users flash
/// with (`flash-board` takes the same arguments), linted, and its register
/// writes tested on the host.
fn board_build(root: &Path) -> Result<()> {
    let fw = root.join("firmware");
    let t = qemu_tests::TARGET;
    cargo(&fw, &["build-board"])?;
    cargo(&fw, &["build-array-board"])?;
    let images = ["--release", "--target", t, "--features", "board", "--bins"];
    cargo(
        &fw,
        &[&["clippy"][..], &images, &["--", "-D", "warnings"]].concat(),
    )?;
    cargo(&fw, &["test", "--lib", "--features", "board"])
}

fn bench() -> Result<()> {
    let (_, benches) = qemu_tests::dsp_bench()?;
    println!("\nCortex-M4 instruction counts (QEMU lm3s6965evb, -icount shift=7,align=off,sleep=off)\n");
    println!("| kernel | instructions | budget |");
    println!("|---|---:|---:|");
    for b in &benches {
        let budget = qemu_tests::DSP_BUDGETS
            .iter()
            .find(|(n, _)| *n == b.name)
            .map(|(_, v)| format!("≤ {v}"))
            .unwrap_or_else(|| "–".into());
        println!("| {} | {} {} | {} |", b.name, b.value, b.unit, budget);
    }
    println!("\nImage sizes (release):\n");
    println!("| image | flash | static RAM |");
    println!("|---|---:|---:|");
    for (bin, feature, what) in [
        (
            "skin-board",
            "board",
            "STM32G474 board, 8 channels; budget 64 KiB / 16 KiB",
        ),
        (
            "skin-array-board",
            "board",
            "STM32G474 board, the array of 16 sensors; budget 128 KiB / 64 KiB",
        ),
        ("skin-qemu", "qemu", "QEMU, with the simulated skin"),
        (
            "skin-array",
            "qemu",
            "QEMU, the array of 16 sensors with its simulated skin",
        ),
        ("dsp-bench", "qemu", "instruction-count bench"),
    ] {
        let elf = qemu_tests::build_firmware(bin, &[feature])?;
        let (flash, ram) = qemu_tests::image_size(&elf)?;
        println!(
            "| `{bin}` ({what}) | {:.1} KiB | {:.1} KiB |",
            flash as f64 / 1024.0,
            ram as f64 / 1024.0
        );
    }
    for (name, max) in qemu_tests::DSP_BUDGETS {
        match benches.iter().find(|b| b.name == name) {
            Some(b) if b.value <= max => {}
            Some(b) => bail!("{name}: {} over the budget {max}", b.value),
            None => bail!("{name}: not reported"),
        }
    }
    Ok(())
}

fn cargo(dir: &Path, args: &[&str]) -> Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    eprintln!("$ (cd {}) cargo {}", dir.display(), args.join(" "));
    let st = Command::new(cargo)
        .current_dir(dir)
        .args(args)
        .status()
        .context("running cargo")?;
    if !st.success() {
        bail!("cargo {} failed", args.join(" "));
    }
    Ok(())
}

/// Install missing system packages with apt-get (as root, or via sudo).
fn setup() -> Result<()> {
    let need: Vec<&str> = [("qemu-system-arm", "qemu-system-arm"), ("ngspice", "ngspice")]
        .into_iter()
        .filter(|(bin, _)| !on_path(bin))
        .map(|(_, pkg)| pkg)
        .collect();
    if !need.is_empty() {
        eprintln!("installing {}", need.join(" "));
        let sudo = if is_root() { vec![] } else { vec!["sudo"] };
        let run = |args: &[&str]| -> Result<()> {
            let mut all: Vec<&str> = sudo.clone();
            all.extend_from_slice(args);
            let st = Command::new(all[0])
                .args(&all[1..])
                .env("DEBIAN_FRONTEND", "noninteractive")
                .status()
                .with_context(|| format!("running {}", all.join(" ")))?;
            if !st.success() {
                bail!("{} failed", all.join(" "));
            }
            Ok(())
        };
        run(&["apt-get", "update"])?;
        let mut args = vec!["apt-get", "install", "-y", "--no-install-recommends"];
        args.extend(&need);
        run(&args)?;
    }
    // rust-toolchain.toml lists the targets; make sure rustup has them.
    let st = Command::new("rustup")
        .args(["target", "add", "thumbv7em-none-eabihf", "thumbv7m-none-eabi"])
        .status();
    if let Ok(st) = st {
        if !st.success() {
            bail!("rustup target add failed");
        }
    }
    Ok(())
}

fn on_path(bin: &str) -> bool {
    std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(bin).is_file()))
        .unwrap_or(false)
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}
