//! What a fresh Debian machine lacks (apt-get, as root or through sudo):
//! QEMU, ngspice, Chromium (the dashboard's test) and npm (the
//! dashboard's chart library); and the Rust targets of
//! `rust-toolchain.toml`.

use anyhow::{bail, Context, Result};
use std::process::Command;

/// The system packages the tests need: (a program on PATH, its package).
const PACKAGES: [(&str, &str); 4] = [
    ("qemu-system-arm", "qemu-system-arm"),
    ("ngspice", "ngspice"),
    ("chromium", "chromium"),
    ("npm", "npm"),
];

/// The Cortex-M targets of `rust-toolchain.toml`.
const TARGETS: [&str; 2] = ["thumbv7em-none-eabihf", "thumbv7m-none-eabi"];

/// Install what is missing.
pub fn run() -> Result<()> {
    let need: Vec<&str> = PACKAGES
        .into_iter()
        .filter(|(bin, _)| !on_path(bin))
        .map(|(_, pkg)| pkg)
        .collect();
    if !need.is_empty() {
        eprintln!("installing {}", need.join(" "));
        apt(&["update"])?;
        let mut args = vec!["install", "-y", "--no-install-recommends"];
        args.extend(&need);
        apt(&args)?;
    }
    // rust-toolchain.toml lists the targets; make sure rustup has them.
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
    all.push("apt-get");
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
