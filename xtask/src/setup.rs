//! What a fresh Debian machine lacks (apt-get, as root or through sudo):
//! QEMU, ngspice, Chromium (the dashboard's test), npm (the
//! dashboard's chart library), Python's pandas (the CSV files read as
//! a lab reads them) and pytest (the Python reader's tests); the Rust
//! targets of `rust-toolchain.toml`; and a Python environment with
//! pylsl for the LSL outlet's test ([`PYENV`]).

use anyhow::{bail, Context, Result};
use std::process::Command;
use std::thread::JoinHandle;
use std::time::Instant;

/// The system packages the tests need: (what shows it is there, its
/// package).
const PACKAGES: [(Present, &str); 6] = [
    (Present::Program("qemu-system-arm"), "qemu-system-arm"),
    (Present::Program("ngspice"), "ngspice"),
    (Present::Program("chromium"), "chromium"),
    (Present::Program("npm"), "npm"),
    // The CSV files the tools write, read as a lab reads them.
    (Present::PythonModule("pandas"), "python3-pandas"),
    // The Python reader's tests (`python/`).
    (Present::PythonModule("pytest"), "python3-pytest"),
];

/// What shows a package is installed.
#[derive(Clone, Copy)]
enum Present {
    /// A program on PATH.
    Program(&'static str),
    /// A module `python3` imports.
    PythonModule(&'static str),
}

impl Present {
    fn here(self) -> bool {
        match self {
            Present::Program(bin) => on_path(bin),
            // On PATH, or the system's (PATH may lead to another, such
            // as pyenv's): the tests look in both.
            Present::PythonModule(m) => ["python3", "/usr/bin/python3"].iter().any(|py| {
                Command::new(py)
                    .args(["-c", &format!("import {m}")])
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::null())
                    .status()
                    .is_ok_and(|s| s.success())
            }),
        }
    }
}

/// The Cortex-M targets of `rust-toolchain.toml`.
const TARGETS: [&str; 2] = ["thumbv7em-none-eabihf", "thumbv7m-none-eabi"];

/// Install what is missing.
pub fn run() -> Result<()> {
    targets()?;
    packages()
}

/// [`packages`] in a thread of its own, for a command whose first steps
/// (lints, builds) need none of them: apt's download and unpacking then
/// overlap the compiler's work. Join it before the first step that runs
/// QEMU, ngspice or Chromium.
pub fn packages_in_background() -> Result<JoinHandle<Result<()>>> {
    targets()?;
    Ok(std::thread::spawn(packages))
}

/// Where the Python with pylsl is made: a venv over the system's Python
/// (its numpy and pandas), which `live/tests/lsl.rs` runs.
pub const PYENV: &str = "target/pyenv";
/// The LSL binding, from PyPI (its wheels bundle liblsl), pinned.
const PYLSL: &str = "pylsl==1.18.6";

/// [`PYENV`] with [`PYLSL`], where it is not there yet (Debian's venv
/// module is `python3-venv`, installed where missing).
fn python_env() -> Result<()> {
    let python = format!("{PYENV}/bin/python");
    let has = |module: &str| {
        Command::new(&python)
            .args(["-c", &format!("import {module}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if has("pylsl") {
        return Ok(());
    }
    let make = || {
        Command::new("/usr/bin/python3")
            .args(["-m", "venv", "--system-site-packages", "--clear", PYENV])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !make() {
        apt(&["update"])?;
        apt(&["install", "-y", "--no-install-recommends", "python3-venv"])?;
        if !make() {
            bail!("python3 -m venv {PYENV} failed (python3-venv installed)");
        }
    }
    let st = Command::new(format!("{PYENV}/bin/pip"))
        .args(["install", "-q", "--disable-pip-version-check", PYLSL])
        .status()
        .context("running pip")?;
    if !st.success() || !has("pylsl") {
        bail!("pip install {PYLSL} into {PYENV} failed");
    }
    Ok(())
}

/// The system packages of [`PACKAGES`] that are missing, installed; then
/// the Python environment of [`PYENV`].
fn packages() -> Result<()> {
    system_packages()?;
    python_env()
}

/// The system packages of [`PACKAGES`] that are missing, installed.
fn system_packages() -> Result<()> {
    let need: Vec<&str> = PACKAGES
        .into_iter()
        .filter(|(present, _)| !present.here())
        .map(|(_, pkg)| pkg)
        .collect();
    if need.is_empty() {
        return Ok(());
    }
    eprintln!("installing {}", need.join(" "));
    let start = Instant::now();
    apt(&["update"])?;
    let mut args = vec!["install", "-y", "--no-install-recommends"];
    args.extend(&need);
    apt(&args)?;
    eprintln!(
        "installed {} in {:.0} s",
        need.join(" "),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The Cortex-M targets of `rust-toolchain.toml`, which rustup may not
/// have yet.
fn targets() -> Result<()> {
    let mut args = vec!["target", "add"];
    args.extend(TARGETS);
    if let Ok(st) = Command::new("rustup").args(&args).status() {
        if !st.success() {
            bail!("rustup target add failed");
        }
    }
    Ok(())
}

/// `apt-get ARGS`, through sudo unless root.
fn apt(args: &[&str]) -> Result<()> {
    let mut all: Vec<&str> = if is_root() { vec![] } else { vec!["sudo"] };
    all.extend(["apt-get", "-q"]);
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
}

fn on_path(bin: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(bin).is_file()))
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}
