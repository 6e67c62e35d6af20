//! Firmware records from QEMU runs, decoded by host-sim's recording
//! reader (`host_sim::recording`, the same code as `host-sim decode`).

use anyhow::Result;
pub use host_sim::recording::{BlockTruth, LoggedRecord, LoggedToneRecord};

/// Build the QEMU firmware, run `scenario`, decode its records.
pub fn run_scenario(scenario: &str) -> Result<(crate::Run, Vec<LoggedRecord>)> {
    run_scenario_args(&[scenario])
}

/// [`run_scenario`] with further semihosting arguments after the name.
pub fn run_scenario_args(args: &[&str]) -> Result<(crate::Run, Vec<LoggedRecord>)> {
    let elf = crate::build_firmware("skin-qemu", &["qemu"])?;
    let run = crate::run_qemu_args(&elf, args, std::time::Duration::from_secs(600))?;
    let lines = host_sim::recording::decode_defmt(&elf, &run.raw)?;
    let recs = host_sim::recording::parse(&format!("QEMU run {}", args.join(" ")), &lines)?;
    Ok((
        crate::Run {
            stdout: lines.into_iter().map(|(_, l)| l).collect::<Vec<_>>().join("\n"),
            ..run
        },
        recs,
    ))
}

/// Build the array firmware (`skin-array`), run `scenario`, decode its
/// records.
pub fn run_array(scenario: &str) -> Result<(crate::Run, Vec<LoggedToneRecord>)> {
    run_array_args(&[scenario])
}

/// How long an array run may take: the longest, ten seconds of the skin
/// in 1 ms blocks (`records=1000`), took 6 minutes alone on a 2-core
/// machine and 12 beside another long test (the long pass runs two at
/// once).
const ARRAY_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1800);

/// [`run_array`] with further semihosting arguments after the name.
pub fn run_array_args(args: &[&str]) -> Result<(crate::Run, Vec<LoggedToneRecord>)> {
    let elf = crate::build_firmware("skin-array", &["qemu"])?;
    let run = crate::run_qemu_args(&elf, args, ARRAY_TIMEOUT)?;
    let lines = host_sim::recording::decode_defmt(&elf, &run.raw)?;
    let recs = host_sim::recording::parse_tones(&format!("QEMU array run {}", args.join(" ")), &lines)?;
    Ok((
        crate::Run {
            stdout: lines.into_iter().map(|(_, l)| l).collect::<Vec<_>>().join("\n"),
            ..run
        },
        recs,
    ))
}
