//! `cargo xtask docs`: every figure of the README and `docs/`
//! regenerated. The main job's plots are copied into `docs/`, and each
//! figure block is rewritten by the test that measures it (the `figures`
//! crate, `DOCS_UPDATE=1`).

use crate::cargo;
use anyhow::{Context, Result};
use std::path::Path;

/// The plots the docs show: (what the main job writes, where the docs
/// keep it).
const PLOTS: [(&str, &str); 4] = [
    ("out/firmware/firmware_paper.svg", "docs/firmware_paper.svg"),
    ("out/array/array_paper.svg", "docs/array_paper.svg"),
    ("out/paper/accuracy_20mmps.svg", "docs/accuracy_20mmps.svg"),
    ("out/paper/fig10_capacitance.svg", "docs/fig10_capacitance.svg"),
];

/// The test files that hold figure tests: (crate, test file).
const FILES: [(&str, &str); 10] = [
    ("qemu-tests", "decode"),
    ("qemu-tests", "array"),
    ("qemu-tests", "dsp_bench"),
    ("qemu-tests", "budgets"),
    ("host-sim", "paper"),
    ("host-sim", "residual"),
    ("host-sim", "cli"),
    ("host-sim", "disturbances"),
    ("host-sim", "ceiling"),
    ("front-end", "files"),
];

/// The tests that measure the figures (each checks its blocks).
const TESTS: [&str; 13] = [
    "the_main_jobs_recording_decodes",
    "sixteen_sensors_250_times_a_second_within",
    "sixteen_sensors_1000_times_a_second_within",
    "dsp_kernels_on_cortex_m4_within_budget",
    "every_benchmark_in_cycles_from_the_cycle_model",
    "every_image_is_tabulated",
    "the_docs_show_what_host_sim_paper_prints",
    "the_docs_show_the_example_data_sets_verdicts",
    "the_docs_show_what_model_and_invert_print",
    "neither_path_vouches_for_a_wrong_record_under_any_disturbance",
    "the_ceilings_are_tabulated",
    "the_array_boards_files_are_its_circuits",
    "the_multiplexed_boards_files_are_its_circuits",
];

/// Run the main job, copy its plots, rewrite the figure blocks.
pub fn regenerate(root: &Path) -> Result<()> {
    crate::main_job::all(root)?;
    for (from, to) in PLOTS {
        std::fs::copy(root.join(from), root.join(to)).with_context(|| format!("copying {from} to {to}"))?;
        eprintln!("wrote {to}");
    }
    let mut args = vec!["test", "--profile", crate::checks::TEST_PROFILE];
    for (krate, _) in FILES {
        if !args.contains(&krate) {
            args.extend(["-p", krate]);
        }
    }
    for (_, file) in FILES {
        args.extend(["--test", file]);
    }
    // The figure tests are long ones (ignored by the fast pass).
    args.extend(["--", "--include-ignored"]);
    args.extend(TESTS);
    let update = [(figures::UPDATE_VAR, "1")];
    cargo::run_env(root, &args, &update)?;
    // The README's table from the rows just written.
    cargo::run_env(
        root,
        &[
            "test",
            "--profile",
            crate::checks::TEST_PROFILE,
            "-p",
            "figures",
            "--test",
            "readme",
        ],
        &update,
    )?;
    dashboard_screenshot(root)
}

/// The dashboard on the main job's array stream (`out/live/stream.bin`),
/// photographed by headless Chromium into `docs/dashboard.png`.
fn dashboard_screenshot(root: &Path) -> Result<()> {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    cargo::run(root, &["build", "--profile", "quick", "-p", "live"])?;
    let mut child = Command::new(root.join("target/quick/live"))
        .arg("--replay")
        .arg(root.join("out/live/stream.bin"))
        .arg("--dataset")
        .arg(root.join("out/live-docs"))
        .args(["--overwrite", "--serve", "127.0.0.1:0", "--linger", "120"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .context("starting live")?;
    let mut first = String::new();
    if let Some(out) = child.stdout.take() {
        BufReader::new(out).read_line(&mut first)?;
    }
    let url = first.trim().strip_prefix("dashboard: ").map(str::to_string);
    let shot = root.join("docs/dashboard.png");
    let st = match &url {
        Some(url) => Command::new("chromium")
            .args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"])
            .args(["--virtual-time-budget=4000", "--window-size=1280,1250"])
            .arg(format!("--screenshot={}", shot.display()))
            .arg(url)
            .stderr(Stdio::null())
            .status()
            .context("running chromium")?,
        None => anyhow::bail!("live did not say where its dashboard is: {first}"),
    };
    let _ = child.kill();
    let _ = child.wait();
    anyhow::ensure!(
        st.success() && shot.is_file(),
        "chromium took no screenshot of {url:?}"
    );
    eprintln!("wrote docs/dashboard.png");
    Ok(())
}
