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

/// Rewrite the trace at `path` (a trace file of [`dataset`]: time,
/// stretch, r_top, r_bottom, freq, cs, rs) onto `rows` rows over the same
/// span, every column interpolated linearly and `noise_pf` of fresh
/// Gaussian noise on each row's Cs (seed `seed`): a long recording of the
/// same run, for the readers' and `identify`'s limits and speed.
pub fn dense_trace(path: &Path, rows: usize, noise_pf: f64, seed: u64) -> Result<()> {
    use std::fmt::Write as _;
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().context("an empty trace")?.to_string();
    let table: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<Vec<f64>, _>>()
        })
        .collect::<Result<_, _>>()
        .with_context(|| format!("{}: not a trace of numbers", path.display()))?;
    anyhow::ensure!(table.len() >= 2 && rows >= 2, "{}: too few rows", path.display());
    anyhow::ensure!(
        table.iter().all(|r| r.len() == 7),
        "{}: not 7 columns",
        path.display()
    );
    let (t0, t1) = (table[0][0], table[table.len() - 1][0]);
    let mut rng = Rng::new(seed);
    let mut out = String::with_capacity(rows * 64);
    out.push_str(&header);
    out.push('\n');
    let mut k = 0;
    for i in 0..rows {
        let t = t0 + (t1 - t0) * i as f64 / (rows - 1) as f64;
        while k + 2 < table.len() && table[k + 1][0] <= t {
            k += 1;
        }
        let (a, b) = (&table[k], &table[k + 1]);
        let u = ((t - a[0]) / (b[0] - a[0])).clamp(0.0, 1.0);
        let v: Vec<f64> = a.iter().zip(b).map(|(x, y)| x + u * (y - x)).collect();
        writeln!(
            out,
            "{t:.6},{:.5},{:.0},{:.0},{},{:.5},{:.0}",
            v[1],
            v[2],
            v[3],
            v[4],
            v[5] + noise_pf * rng.gaussian(),
            v[6]
        )?;
    }
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}
