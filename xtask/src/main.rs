//! `cargo xtask <command>`: the project's automation, one place for what
//! the README and CI run. Each command is a module:
//!
//! * `setup` ([`setup`]): install what a fresh Debian machine lacks (QEMU,
//!   ngspice) and the Rust targets of `rust-toolchain.toml`.
//! * `test` ([`checks`]): set-up, then formatting, clippy, rustdoc, every
//!   host and QEMU test, the cross builds and the board images: the fast
//!   pass (smoke sizes, 10³ cases a fuzz target), or with `--full` the
//!   long tests and 10⁵ cases a fuzz target as well; `--long` is what
//!   `--full` adds alone (CI runs it after the test command).
//! * `run` ([`main_job`]): the main job (see the README).
//! * `bench` ([`mod@bench`]): instruction counts on Cortex-M4 in QEMU
//!   (`-icount`), image sizes, and with `--host` the criterion benchmarks.
//! * `docs` ([`docs`]): every figure of the README and docs/ regenerated.
//! * `example-data`: the example data set (`data/example`) from rig-sim.
//! * `survey`: `identify` over the physical ranges on the three
//!   generators, many seeds, a table per generator.
//! * `soak` ([`soak`]): `live` streaming a day of a skin's records over
//!   TCP with the dashboard open, killed at random moments and
//!   restarted; resident memory and records lost reported (the test
//!   command runs a minute of it).
//! * `fuzz` ([`fuzz`]): every fuzz target with 1 000 000 cases, fresh
//!   seeds (the test command runs them with 10³, the long pass 10⁵).

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

mod bench;
mod cargo;
mod checks;
mod docs;
mod fuzz;
mod main_job;
mod main_skin;
mod setup;
mod soak;

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
    /// The test command: fmt, clippy, rustdoc, every host and QEMU test
    /// at its smoke size, the firmware builds (--full: the long tests and
    /// full fuzz counts too).
    Test {
        /// Also the long sweeps, every QEMU scenario and 10⁵ cases per
        /// fuzz target.
        #[arg(long, conflicts_with = "long")]
        full: bool,
        /// Only what --full adds to the test command (CI runs it after
        /// the test command).
        #[arg(long)]
        long: bool,
    },
    /// Instruction counts on Cortex-M4 (QEMU -icount) and image sizes; --host adds criterion.
    Bench {
        /// Also run the criterion benchmarks on the host.
        #[arg(long)]
        host: bool,
    },
    /// The main job: the instrument at work, results under out/.
    Run,
    /// The main job's whole skin alone: four boards in QEMU, their
    /// clocks offset and drifting, read in one `live` session (out/skin).
    Skin,
    /// Regenerate every figure of the README and docs/: the main job's
    /// plots copied into docs/, and each figure block rewritten by the
    /// test that measures it (`DOCS_UPDATE=1`).
    Docs,
    /// identify over the physical ranges on the three generators
    /// (`rig-sim` and `labgen`: with clean sets and effects outside the
    /// library; `skin-sim`): one hidden effect per set, a row per set and
    /// a table per generator (50 sets of rig-sim take about 6 minutes on
    /// 2 cores, of labgen about 10).
    Survey {
        /// Sets.
        #[arg(long, default_value_t = 50)]
        seeds: u64,
        /// The first seed of rig-sim's draw (another draw: `--first 50`).
        #[arg(long, default_value_t = 0)]
        first: u64,
    },
    /// Write the repository's example data set (`data/example/`) with
    /// rig-sim, the independent bench generator, at its fixed seed.
    ExampleData {
        /// Folder to write (its CSV files are replaced).
        #[arg(long, default_value = "data/example")]
        out: std::path::PathBuf,
    },
    /// `live` streaming a skin's records over TCP (16 × 1,000 a second)
    /// with the dashboard open in headless Chromium, killed at random
    /// moments and restarted: every killed session checked (nothing lost
    /// before its last flush), the last by its manifest, resident memory
    /// held within 256 MiB; the report in out/soak/report.md.
    Soak {
        /// Hours of records the device sends.
        #[arg(long, default_value_t = 24.0)]
        hours: f64,
        /// How fast, as a multiple of real time (0: as fast as live
        /// takes them).
        #[arg(long, default_value_t = 0.0)]
        speed: f64,
        /// Kill live after a random time between this and twice this, s.
        #[arg(long, default_value_t = 30.0)]
        kill_every: f64,
        /// The draw of the kills.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Sensors the device reads (16: a board; 64: a skin of four).
        #[arg(long, default_value_t = 16)]
        sensors: u64,
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
        Cmd::Setup => setup::run(),
        Cmd::Test { full, long } => {
            let packages = setup::packages_in_background()?;
            let pass = match (full, long) {
                (true, _) => checks::Pass::Full,
                (_, true) => checks::Pass::Long,
                _ => checks::Pass::Fast,
            };
            checks::all(&root, pass, packages)
        }
        Cmd::Bench { host } => {
            setup::run()?;
            bench::cortex_m4()?;
            if host {
                bench::host(&root)?;
            }
            Ok(())
        }
        Cmd::Skin => {
            setup::run()?;
            println!("{}", main_skin::run(&root.join("out/skin"))?);
            Ok(())
        }
        Cmd::Run => {
            setup::run()?;
            main_job::all(&root)
        }
        Cmd::Soak {
            hours,
            speed,
            kill_every,
            seed,
            sensors,
        } => {
            setup::run()?;
            let soak = soak::Soak {
                seconds: (hours * 3600.0).round() as u64,
                speed: (speed > 0.0).then_some(speed),
                kill_after_s: (kill_every, 2.0 * kill_every),
                seed,
                dashboard: true,
                sensors,
            };
            print!("{}", soak::run(&root, &soak)?);
            Ok(())
        }
        Cmd::Docs => {
            setup::run()?;
            docs::regenerate(&root)
        }
        Cmd::Survey { seeds, first } => survey(&root, seeds, first),
        Cmd::ExampleData { out } => {
            rig_sim::Bench::example()
                .write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Fuzz { cases } => fuzz::run_all(&root, Some(cases), &[]),
    }
}

/// identify's survey over the three generators (`cargo xtask survey`).
fn survey(root: &std::path::Path, seeds: u64, first: u64) -> Result<()> {
    cargo::run_env(
        root,
        &[
            "test",
            "--profile",
            checks::TEST_PROFILE,
            "-p",
            "host-sim",
            "--test",
            "second_generator",
            "--test",
            "third_generator",
            "--test",
            "identify",
            "--",
            "--ignored",
            "--nocapture",
            "survey",
        ],
        &[("SEEDS", &seeds.to_string()), ("FIRST", &first.to_string())],
    )
}
