//! `cargo xtask bench`: the Cortex-M4 instruction counts, the same in
//! cycles from the cycle model, and the image sizes (the tables of
//! `docs/benchmarks.md`), and with `--host` the criterion benchmarks.

use crate::cargo;
use anyhow::{bail, Result};
use std::path::Path;

/// The criterion benchmarks: (crate, bench).
const HOST: [(&str, &str); 4] = [
    ("dsp-core", "dsp"),
    ("host-sim", "paper"),
    ("host-sim", "identify"),
    ("live", "replay"),
];

/// Print the instruction counts and image sizes; fail on a budget passed.
pub fn cortex_m4() -> Result<()> {
    let (_, benches) = qemu_tests::dsp_bench()?;
    println!("\nCortex-M4 instruction counts (QEMU lm3s6965evb, -icount shift=7,align=off,sleep=off)\n");
    print!("{}", qemu_tests::tables::bench_table(&benches));
    let cycles = qemu_tests::dsp_bench_cycles(&benches)?;
    println!("\nThe same in cycles (the cycle model: low–high bounds; the code as the firmware places it, its per-block section in CCM SRAM; all in CCM SRAM; all in flash behind the ART)\n");
    print!("{}", qemu_tests::tables::cycle_table(&cycles));
    println!("\nImage sizes (release):\n");
    print!("{}", qemu_tests::tables::image_table()?);
    for (name, max) in qemu_tests::DSP_BUDGETS {
        match benches.iter().find(|b| b.name == name) {
            Some(b) if b.value <= max => {}
            Some(b) => bail!("{name}: {} over the budget {max}", b.value),
            None => bail!("{name}: not reported"),
        }
    }
    Ok(())
}

/// The criterion benchmarks on the host.
pub fn host(root: &Path) -> Result<()> {
    for (krate, bench) in HOST {
        cargo::run(root, &["bench", "-p", krate, "--bench", bench])?;
    }
    Ok(())
}
