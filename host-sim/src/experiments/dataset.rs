//! Data sets in the interchange format.

use super::sweep::write_sweep;
use super::*;

/// Write a data set in the interchange format (calibration, sweep and six
/// traces) for `params`, read by the LCR meter; no truth columns.
/// The recording's meter is `lcr` (its window and time offset).
pub fn dataset(dir: &Path, params: SensorParams, lcr: Meter, seed: u64, progress: ProgressBar) -> Result<()> {
    let ctx = Ctx {
        out: dir.to_path_buf(),
        sensor: params,
        lcr,
        seed,
        periods: 3,
        progress,
    };
    std::fs::create_dir_all(dir)?;
    calibration(&ctx)?;
    // The sweep at 0, 15, 30 mm, without the truth column.
    write_sweep(&ctx, false)?;
    for Run {
        rate,
        freq_hz: f,
        readings,
    } in lcr_runs(&ctx)
    {
        write_trace(
            &dir.join(format!("trace_{rate:.0}mmps_{f:.0}hz.csv")),
            &readings,
            false,
        )?;
    }
    Ok(())
}
