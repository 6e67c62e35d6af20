//! Writing a recording as a data set: traces per moving channel and
//! frequency, fragments, the calibration from the static channels, and
//! the faults ([the format](../../../docs/data-format.md)).

use super::writer::DatasetWriter;
use super::{LoggedRecord, Roles, STATIC_SPREAD_MM};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// The most bytes [`write_dataset`] holds before writing them.
const PENDING_MAX: usize = 8 << 20;

/// What [`write_dataset`] wrote.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// Trace files.
    pub traces: Vec<PathBuf>,
    /// Fragment files (runs too short for a trace).
    pub fragments: Vec<PathBuf>,
    /// Trace rows in all.
    pub rows: usize,
    /// Calibration points.
    pub calibration_points: usize,
    /// Records listed in `faults.csv`.
    pub faults: usize,
    /// What was left out, and why (a sensor held still whose records
    /// are all flagged gives no calibration point): one line each, also
    /// written as comments in the file it is missing from.
    pub left_out: Vec<String>,
}

/// The mark a data set carries while it is being replaced: a run killed
/// then leaves it, and the readers say so (`decode` also leaves it, with
/// another reason, on a recording cut short).
pub const INCOMPLETE: &str = "INCOMPLETE";

/// The manifest a `live` session writes when it ends: a session's folder
/// without one is incomplete.
pub const MANIFEST: &str = "session.json";

/// What a data set written here says of itself: what its columns hold,
/// its files, and what was left out and why (JSON; the CSV files hold
/// no comments, so that any CSV reader takes them as they are).
pub const DATASET_JSON: &str = "dataset.json";

/// Whether `name` is a file a data set written here consists of.
pub fn is_dataset_file(name: &str) -> bool {
    name == "calibration.csv"
        || name == DATASET_JSON
        || name == "faults.csv"
        || ((name.starts_with("trace_") || name.starts_with("fragment_")) && name.ends_with("hz.csv"))
}

/// Write `recs` as a data set in `dir` (see the module documentation),
/// replacing the data set there: the files are written in a staging
/// folder first; then, with `dir` marked [`INCOMPLETE`], the old set's
/// files are taken away, the new ones renamed in, and the mark removed
/// (or put back as it was, when `dir` carried one already).
/// A failure before that leaves the old set as it was; other files in
/// `dir` (logs, plots) are left alone.
pub fn write_dataset(dir: &Path, recs: &[LoggedRecord], roles: &Roles) -> Result<Written> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let stage = tempfile::Builder::new()
        .prefix(".dataset-")
        .tempdir_in(dir)
        .with_context(|| format!("a staging folder in {}", dir.display()))?;
    let truth = recs.iter().any(|r| r.truth.is_some());
    let mut w = DatasetWriter::create(stage.path(), truth, roles.clone())?;
    for (k, r) in recs.iter().enumerate() {
        w.push(r)?;
        // What is held, bounded.
        if k % 4096 == 4095 && w.pending() > PENDING_MAX {
            w.flush()?;
        }
    }
    let staged = w.finish()?;
    // A mark already there (a recording cut short) says more than ours:
    // it stays.
    let mark = dir.join(INCOMPLETE);
    let prior = std::fs::read(&mark).ok();
    std::fs::write(
        &mark,
        "a data set being replaced: the run writing it did not finish\n",
    )
    .with_context(|| format!("writing {}", mark.display()))?;
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let entry = entry?;
        if entry.file_type()?.is_file() && is_dataset_file(&entry.file_name().to_string_lossy()) {
            std::fs::remove_file(entry.path())
                .with_context(|| format!("removing {}", entry.path().display()))?;
        }
    }
    for entry in std::fs::read_dir(stage.path())? {
        let entry = entry?;
        let to = dir.join(entry.file_name());
        std::fs::rename(entry.path(), &to).with_context(|| format!("moving into {}", to.display()))?;
    }
    match prior {
        Some(text) => std::fs::write(&mark, text),
        None => std::fs::remove_file(&mark),
    }
    .with_context(|| format!("restoring {}", mark.display()))?;
    let moved = |paths: Vec<PathBuf>| -> Vec<PathBuf> {
        paths
            .into_iter()
            .map(|p| dir.join(p.file_name().expect("a file")))
            .collect()
    };
    Ok(Written {
        traces: moved(staged.traces),
        fragments: moved(staged.fragments),
        ..staged
    })
}

/// Whether a sensor whose valid records' stretch spans `spread` mm is
/// held still (a calibration point); NaN (no valid record) is not.
pub(super) fn is_static_spread(spread: f64) -> bool {
    spread < STATIC_SPREAD_MM
}

/// Whether the line's C or R `x` has no value (0, or NaN).
fn no_value(x: f64) -> bool {
    x.is_nan() || x <= 0.0
}

/// Why a record cannot be a trace row, if it cannot (it is listed in
/// `faults.csv` instead): no lumped reading, a value no sensor or
/// instrument gives, or, without the rig's resistances (`truth`: a
/// recording with truth lines), no line resistance to model the row with
/// (a record that failed the model check has none).
pub fn unusable(r: &LoggedRecord, truth: bool) -> Option<&'static str> {
    use crate::dataset::within_bounds;
    let plausible = within_bounds("time_s", r.t_s)
        && within_bounds("stretch_mm", r.stretch())
        && within_bounds("freq_hz", r.freq_hz)
        && within_bounds("cs_pf", r.cs_pf)
        && within_bounds("rs_ohm", r.rs_ohm)
        // The line's C and R may have no value (0 or NaN).
        && (truth || no_value(r.r_ohm) || within_bounds("r_line_ohm", r.r_ohm))
        && (no_value(r.c_pf) || within_bounds("cs_pf", r.c_pf))
        && r.truth.is_none_or(|t| {
            within_bounds("r_top_ohm", t.r_top_ohm) && within_bounds("r_bottom_ohm", t.r_bottom_ohm)
        });
    match r.measured() {
        false => Some("no lumped reading: the tone's impedance is not a lossy capacitor's"),
        true if !plausible => Some(
            "a value outside what any sensor or instrument gives (a corrupted record, or a unit error): not written as a reading",
        ),
        // Written to the ohm: below half an ohm it would read as none.
        true if !truth && (r.r_ohm.is_nan() || r.r_ohm.round() <= 0.0) => Some(
            "no line resistance to model it with: the two tones failed the model check (MODEL), and the recording has no ohmmeter",
        ),
        true => None,
    }
}
