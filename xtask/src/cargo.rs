//! Running cargo and system commands, each printed before it runs.

use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The cargo that runs xtask.
pub fn bin() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// `cargo ARGS` in `dir`, with `envs`; an error if it fails. How long
/// each step took (build and run) is printed, so that a CI log shows
/// where its time goes.
pub fn run_env(dir: &Path, args: &[&str], envs: &[(&str, &str)]) -> Result<()> {
    system(dir, &bin(), args, envs)
}

/// `program ARGS` in `dir` with `envs`, printed and timed; an error if
/// it fails.
pub fn system(dir: &Path, program: &str, args: &[&str], envs: &[(&str, &str)]) -> Result<()> {
    let shown: Vec<String> = envs.iter().map(|(k, v)| format!("{k}={v} ")).collect();
    let line = format!("{}{program} {}", shown.concat(), args.join(" "));
    eprintln!("$ (cd {}) {line}", dir.display());
    let started = Instant::now();
    let st = Command::new(program)
        .current_dir(dir)
        .args(args)
        .envs(envs.iter().copied())
        .status()
        .with_context(|| format!("running {program}"))?;
    eprintln!("$ {line}: {:.1} s", started.elapsed().as_secs_f64());
    if !st.success() {
        bail!("{line} failed");
    }
    Ok(())
}

/// `cargo ARGS` in `dir`; an error if it fails.
pub fn run(dir: &Path, args: &[&str]) -> Result<()> {
    run_env(dir, args, &[])
}

/// Whether cargo has the subcommand `name` (an installed `cargo-NAME`).
pub fn has_subcommand(name: &str) -> bool {
    Command::new(bin())
        .args([name, "--version"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}
