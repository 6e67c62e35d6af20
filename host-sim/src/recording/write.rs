//! Writing a recording as a data set: traces per moving channel and
//! frequency, fragments, the calibration from the static channels, and
//! the faults ([the format](../../../docs/data-format.md)).

use super::{BlockTruth, LoggedRecord, Roles, STATIC_SPREAD_MM};
use crate::model::prepared::MIN_TRACE_ROWS;
use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

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

/// Whether `name` is a file a data set written here consists of.
pub fn is_dataset_file(name: &str) -> bool {
    name == "calibration.csv"
        || name == "faults.csv"
        || ((name.starts_with("trace_ch") || name.starts_with("fragment_ch")) && name.ends_with("hz.csv"))
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
    let staged = write_files(stage.path(), recs, roles)?;
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

/// The data set's files, in `dir`.
fn write_files(dir: &Path, recs: &[LoggedRecord], roles: &Roles) -> Result<Written> {
    // A record that failed the model check is a row of lumped readings
    // without a line (as the array's are once read).
    // (Copied only when one needs it: a replay's records are many.)
    let original = recs;
    let rows: Vec<LoggedRecord>;
    let recs = if recs.iter().any(|r| r.flags.has(instrument::faults::Flags::MODEL)) {
        rows = recs.iter().map(LoggedRecord::as_row).collect();
        rows.as_slice()
    } else {
        recs
    };
    let mut channels: BTreeMap<u8, Vec<&LoggedRecord>> = BTreeMap::new();
    for r in recs {
        channels.entry(r.sensor).or_default().push(r);
    }
    let truth = recs.iter().any(|r| r.truth.is_some());
    let mut out = Written {
        faults: write_faults(dir, original, recs, truth)?,
        ..Written::default()
    };
    let statics: Vec<(u8, &[&LoggedRecord])> = channels
        .iter()
        .filter(|(&ch, rs)| roles.is_static(ch, rs))
        .map(|(&ch, rs)| (ch, rs.as_slice()))
        .collect();
    (out.calibration_points, out.left_out) = write_calibration(dir, &statics, truth)?;
    // One trace per channel and exact frequency (a trace holds one): named
    // by the frequency in whole Hz, or to the mHz where two of a channel's
    // frequencies round to the same Hz.
    let mut groups: BTreeMap<(u8, u64), Vec<&LoggedRecord>> = BTreeMap::new();
    for (&ch, rs) in &channels {
        if roles.is_trace(ch, rs) {
            for r in rs.iter().filter(|r| r.measured() && unusable(r, truth).is_none()) {
                groups.entry((ch, r.freq_hz.to_bits())).or_default().push(r);
            }
        }
    }
    let mut per_hz: BTreeMap<(u8, u64), usize> = BTreeMap::new();
    for &(ch, bits) in groups.keys() {
        *per_hz
            .entry((ch, f64::from_bits(bits).round() as u64))
            .or_default() += 1;
    }
    let mut jobs = vec![];
    for ((ch, bits), rs) in groups {
        let hz = f64::from_bits(bits);
        let f = match per_hz[&(ch, hz.round() as u64)] {
            1 => format!("{}", hz.round() as u64),
            _ => format!("{hz:.3}"),
        };
        let trace = rs.len() >= MIN_TRACE_ROWS;
        let kind = if trace { "trace" } else { "fragment" };
        let path = dir.join(format!("{kind}_ch{ch}_{f}hz.csv"));
        if trace {
            out.rows += rs.len();
            out.traces.push(path.clone());
        } else {
            out.fragments.push(path.clone());
        }
        jobs.push((path, ch, f, rs));
    }
    write_traces(&jobs, truth)?;
    Ok(out)
}

/// Write every trace file of `jobs` (path, channel, frequency text,
/// rows), on as many threads as the machine has cores (each thread a
/// share of the rows); the first error, if any.
#[allow(clippy::type_complexity)]
fn write_traces(jobs: &[(PathBuf, u8, String, Vec<&LoggedRecord>)], truth: bool) -> Result<()> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(jobs.len())
        .max(1);
    // The largest first, each to the thread with the fewest rows so far.
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(jobs[i].3.len()));
    let mut shares: Vec<(usize, Vec<usize>)> = vec![(0, vec![]); threads];
    for i in order {
        let least = shares.iter_mut().min_by_key(|s| s.0).expect("a thread");
        least.0 += jobs[i].3.len();
        least.1.push(i);
    }
    std::thread::scope(|scope| {
        let handles: Vec<_> = shares
            .iter()
            .map(|(_, mine)| {
                scope.spawn(move || {
                    mine.iter().try_for_each(|&i| {
                        let (path, ch, f, rs) = &jobs[i];
                        write_trace(path, *ch, f, rs, truth)
                            .with_context(|| format!("writing {}", path.display()))
                    })
                })
            })
            .collect();
        handles.into_iter().try_for_each(|h| {
            h.join()
                .unwrap_or_else(|_| Err(anyhow::anyhow!("a trace writer panicked")))
        })
    })
}

impl Roles {
    /// Is channel `ch` (records `rs`) a calibration point?
    fn is_static(&self, ch: u8, rs: &[&LoggedRecord]) -> bool {
        match &self.statics {
            Some(list) => list.contains(&ch),
            // A channel with no valid record has no stretch to judge (its
            // records are all in faults.csv).
            None => stretch_spread(rs) < STATIC_SPREAD_MM,
        }
    }

    /// Are channel `ch`'s records (`rs`) traces?
    fn is_trace(&self, ch: u8, rs: &[&LoggedRecord]) -> bool {
        match &self.traces {
            Some(list) => list.contains(&ch),
            None => !self.is_static(ch, rs),
        }
    }
}

/// The spread of the stretch over the valid records, mm (NaN if none).
fn stretch_spread(rs: &[&LoggedRecord]) -> f64 {
    let s = rs.iter().filter(|r| r.valid()).map(|r| r.stretch());
    let (lo, hi) = s.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo <= hi {
        hi - lo
    } else {
        f64::NAN
    }
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
        && (truth || r.r_ohm <= 0.0 || within_bounds("r_line_ohm", r.r_ohm))
        && (r.c_pf <= 0.0 || within_bounds("cs_pf", r.c_pf))
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

/// `faults.csv`: every record of `recs` whose row (`rows`, one each)
/// is flagged invalid, and every valid one that cannot be a trace row
/// ([`unusable`]), with the record's own flags. Returns how many.
fn write_faults(dir: &Path, recs: &[LoggedRecord], rows: &[LoggedRecord], truth: bool) -> Result<usize> {
    let mut faults = std::io::BufWriter::new(std::fs::File::create(dir.join("faults.csv"))?);
    writeln!(faults, "time_s,sensor,freq_hz,flags,reason")?;
    let mut n = 0;
    // Judged as the rows hold them, listed with the flags the records
    // carry (a MODEL record's row is valid for its lumped reading).
    for (r, flags) in rows.iter().zip(recs.iter().map(|r| r.flags.0)) {
        // Flagged, or valid but not a row a trace can hold (no lumped
        // reading, or no resistance to model it with): listed either
        // way, never dropped without a word.
        let reason = match (r.valid(), unusable(r, truth)) {
            (false, _) => r.flags.names().collect::<Vec<_>>().join(" "),
            (true, Some(why)) => why.to_string(),
            (true, None) => continue,
        };
        writeln!(faults, "{:.6},{},{},{flags},{reason}", r.t_s, r.sensor, r.freq_hz)?;
        n += 1;
    }
    faults.flush()?;
    Ok(n)
}

/// `calibration.csv`: one point per static channel, the mean of its valid
/// records at the frequency it was read at most; a channel with none is
/// left out, with a comment that says so. Returns how many points, and
/// what was left out.
fn write_calibration(
    dir: &Path,
    statics: &[(u8, &[&LoggedRecord])],
    truth: bool,
) -> Result<(usize, Vec<String>)> {
    let mut cal = std::io::BufWriter::new(std::fs::File::create(dir.join("calibration.csv"))?);
    writeln!(
        cal,
        "# firmware recording: each static channel's valid records at its most used frequency, averaged"
    )?;
    let rcols = if truth {
        "r_top_ohm,r_bottom_ohm"
    } else {
        "r_line_ohm"
    };
    writeln!(cal, "stretch_mm,freq_hz,cs_pf,rs_ohm,{rcols}")?;
    let mut left_out = vec![];
    for &(ch, rs) in statics {
        let good: Vec<&&LoggedRecord> = rs
            .iter()
            .filter(|r| r.valid() && unusable(r, truth).is_none())
            .collect();
        let mut count: BTreeMap<u64, usize> = BTreeMap::new();
        for r in &good {
            *count.entry(r.freq_hz.to_bits()).or_default() += 1;
        }
        let Some((&f, _)) = count.iter().max_by_key(|(_, n)| **n) else {
            let why = format!(
                "sensor {ch}, held still, has no calibration point: none of its {} records is valid and usable (they are in faults.csv)",
                rs.len()
            );
            writeln!(cal, "# {why}")?;
            left_out.push(why);
            continue;
        };
        let at: Vec<&&&LoggedRecord> = good.iter().filter(|r| r.freq_hz.to_bits() == f).collect();
        let n = at.len() as f64;
        let mean = |g: &dyn Fn(&LoggedRecord) -> f64| at.iter().map(|r| g(r)).sum::<f64>() / n;
        let r_text = if truth {
            let t =
                |g: fn(&BlockTruth) -> f64| mean(&|r: &LoggedRecord| r.truth.as_ref().map_or(f64::NAN, g));
            format!("{:.0},{:.0}", t(|t| t.r_top_ohm), t(|t| t.r_bottom_ohm))
        } else {
            format!("{:.0}", mean(&|r| r.r_ohm))
        };
        writeln!(
            cal,
            "{:.4},{},{:.4},{:.0},{r_text}",
            mean(&|r| r.stretch()),
            f64::from_bits(f),
            mean(&|r| r.cs_pf),
            mean(&|r| r.rs_ohm)
        )?;
    }
    cal.flush()?;
    Ok((statics.len() - left_out.len(), left_out))
}

/// One trace (or fragment) file: channel `ch`'s records `rs` at `f` Hz,
/// with the rig's view where the recording has truth lines.
fn write_trace(path: &Path, ch: u8, f: &str, rs: &[&LoggedRecord], truth: bool) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    if truth {
        writeln!(
            w,
            "# firmware channel {ch} at {f} Hz; stretch and electrode resistances from the rig (simulated truth)"
        )?;
        writeln!(w, "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf,rs_ohm,c_line_pf,r_line_ohm,flags,c_true_pf,r_true_ohm,stretch_true_mm")?;
    } else {
        writeln!(
            w,
            "# firmware channel {ch} at {f} Hz; stretch from the firmware's calibration, resistance its line estimate"
        )?;
        writeln!(
            w,
            "time_s,stretch_mm,r_line_ohm,freq_hz,cs_pf,rs_ohm,c_line_pf,flags"
        )?;
    }
    // Each row through `numfmt` (Rust's `{:.N}` costs more than the
    // rest of a replay); the frequency's text once, a trace holding one
    // frequency (its rows are grouped by the frequency's bits).
    use crate::numfmt::{fixed, int, shortest};
    let mut hz = vec![];
    shortest(&mut hz, rs.first().map_or(0.0, |r| r.freq_hz));
    let field = |line: &mut Vec<u8>, x: f64, prec: usize| {
        fixed(line, x, prec);
        line.push(b',');
    };
    let mut line = Vec::with_capacity(160);
    for r in rs {
        line.clear();
        let t = match r.truth {
            Some(t) if truth => Some(t),
            None if truth => bail!(
                "record of channel {ch} at {:.6} s has no truth line where the others have one",
                r.t_s
            ),
            _ => None,
        };
        field(&mut line, r.t_s, 6);
        match t {
            Some(t) => {
                field(&mut line, t.stretch_mm, 4);
                field(&mut line, t.r_top_ohm, 0);
                field(&mut line, t.r_bottom_ohm, 0);
            }
            None => {
                field(&mut line, r.stretch_mm, 4);
                field(&mut line, r.r_ohm, 0);
            }
        }
        line.extend_from_slice(&hz);
        line.push(b',');
        field(&mut line, r.cs_pf, 4);
        field(&mut line, r.rs_ohm, 0);
        field(&mut line, r.c_pf, 4);
        match t {
            Some(t) => {
                field(&mut line, r.r_ohm, 0);
                int(&mut line, r.flags.0);
                line.push(b',');
                field(&mut line, t.c_pf, 4);
                field(&mut line, t.r_ohm, 0);
                fixed(&mut line, t.stretch_mm, 4);
            }
            None => int(&mut line, r.flags.0),
        }
        line.push(b'\n');
        w.write_all(&line)?;
    }
    w.flush()?;
    Ok(())
}
