//! A data set written as its records arrive ([`DatasetWriter`]): every
//! file appended to, never rebuilt, in memory only what has not been
//! written yet and a few sums per sensor. `live` writes a session's data
//! set with it while the session runs; [`super::write_dataset`] writes a
//! whole recording's with it.

use super::write::{is_static_spread, unusable, Written, DATASET_JSON};
use super::{BlockTruth, LoggedRecord, Roles};
use crate::model::prepared::MIN_TRACE_ROWS;
use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The most trace files a writer keeps open between flushes (the rest
/// are opened again to append).
const OPEN_MAX: usize = 128;

/// A file appended to in whole lines: those not yet written, and how
/// long it is.
pub struct LineFile {
    path: PathBuf,
    file: Option<File>,
    pending: Vec<u8>,
    /// Bytes in the file: every line before `pending`, whole.
    len: u64,
}

impl LineFile {
    /// A new file at `path` (created here: never an earlier file, nor
    /// one a link points at), starting with `head`.
    pub fn create(path: PathBuf, head: &str) -> Result<Self> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .with_context(|| format!("creating {}", path.display()))?;
        Ok(Self {
            path,
            file: Some(file),
            pending: head.as_bytes().to_vec(),
            len: 0,
        })
    }

    /// Write what is pending; the file left with whole lines only (cut
    /// back to them where a write failed: a full disk). `keep` says
    /// whether to keep the file open.
    pub fn flush(&mut self, keep: bool) -> Result<()> {
        if !self.pending.is_empty() {
            let file = match &mut self.file {
                Some(f) => f,
                None => self.file.insert(
                    OpenOptions::new()
                        .append(true)
                        .open(&self.path)
                        .with_context(|| format!("opening {}", self.path.display()))?,
                ),
            };
            if let Err(e) = file.write_all(&self.pending) {
                let _ = file.set_len(self.len);
                return Err(e).with_context(|| format!("writing {}", self.path.display()));
            }
            self.len += self.pending.len() as u64;
            self.pending.clear();
        }
        if !keep {
            self.file = None;
        }
        Ok(())
    }

    /// Bytes written (whole lines).
    pub fn written_bytes(&self) -> u64 {
        self.len
    }

    /// Lines to write at the next flush (each ending in a newline).
    pub fn pending(&mut self) -> &mut Vec<u8> {
        &mut self.pending
    }

    /// Move the file to `to` (it stays open where it is).
    fn rename(&mut self, to: PathBuf) -> Result<()> {
        std::fs::rename(&self.path, &to)
            .with_context(|| format!("renaming {} to {}", self.path.display(), to.display()))?;
        self.path = to;
        Ok(())
    }
}

/// One trace (or, while shorter than a trace, fragment) file: a
/// sensor's records at one frequency in one segment of the recording.
struct Trace {
    file: LineFile,
    rows: usize,
    /// The frequency's text in the rows.
    hz: Vec<u8>,
}

/// A sensor's sums: its records, the stretch's range over its valid
/// ones, and per frequency (its bits) the sums of its usable ones.
#[derive(Default)]
struct Sensor {
    records: usize,
    lo: f64,
    hi: f64,
    at: BTreeMap<u64, Sums>,
}

/// Sums of a sensor's usable records at one frequency.
#[derive(Clone, Copy, Default)]
struct Sums {
    n: usize,
    stretch_mm: f64,
    cs_pf: f64,
    rs_ohm: f64,
    r_ohm: f64,
    r_top_ohm: f64,
    r_bottom_ohm: f64,
}

/// A data set written as records arrive, into a folder (the format of
/// `docs/data-format.md`): `faults.csv` and a file per sensor,
/// frequency and segment appended to, a fragment renamed a trace once it
/// holds [`MIN_TRACE_ROWS`] rows; at [`DatasetWriter::flush`] every file
/// holds whole lines up to the last record pushed, and `calibration.csv`
/// the points so far. [`DatasetWriter::finish`] takes a sensor held
/// still out of the traces (it is a calibration point).
///
/// A record after [`DatasetWriter::restart`] (the device started over,
/// its clock from zero) is in files of its own: `trace_s{K}_ch…` for
/// segment K ≥ 2.
pub struct DatasetWriter {
    dir: PathBuf,
    truth: bool,
    roles: Roles,
    segment: u32,
    sensors: BTreeMap<u8, Sensor>,
    traces: BTreeMap<(u32, u8, u64), Trace>,
    faults: LineFile,
    n_faults: usize,
    line: Vec<u8>,
}

impl DatasetWriter {
    /// A writer into `dir` (which must not hold a data set's files:
    /// they are created anew), of records with the rig's truth (`truth`)
    /// or without.
    pub fn create(dir: &Path, truth: bool, roles: Roles) -> Result<Self> {
        let faults = LineFile::create(dir.join("faults.csv"), "time_s,sensor,freq_hz,flags,reason\n")?;
        Ok(Self {
            dir: dir.to_path_buf(),
            truth,
            roles,
            segment: 1,
            sensors: BTreeMap::new(),
            traces: BTreeMap::new(),
            faults,
            n_faults: 0,
            line: Vec::with_capacity(192),
        })
    }

    /// The device started over: the records that follow are a new
    /// segment, in files of their own.
    pub fn restart(&mut self) {
        self.segment += 1;
    }

    /// Bytes held, not yet written.
    pub fn pending(&self) -> usize {
        self.faults.pending.len() + self.traces.values().map(|t| t.file.pending.len()).sum::<usize>()
    }

    /// Take record `r`: listed in `faults.csv` where it is flagged or
    /// cannot be a row, counted towards its sensor's calibration point,
    /// and a row of its trace.
    pub fn push(&mut self, r: &LoggedRecord) -> Result<()> {
        // A record that failed the model check is a row of its lumped
        // reading without a line; faults.csv lists the record's flags.
        let row = r.as_row();
        let why = unusable(&row, self.truth);
        let reason = match (row.lumped_valid(), why) {
            (false, _) => Some(row.flags.names().collect::<Vec<_>>().join(" ")),
            (true, Some(why)) => Some(why.to_string()),
            (true, None) => None,
        };
        if let Some(reason) = reason {
            // The reason quoted (RFC 4180): it may hold commas.
            writeln!(
                self.faults.pending,
                "{:.6},{},{},{},\"{}\"",
                row.t_s,
                row.sensor,
                row.freq_hz,
                r.flags.0,
                reason.replace('"', "\"\"")
            )?;
            self.n_faults += 1;
        }
        self.count(&row, why.is_none());
        let could_trace = self.roles.traces.as_ref().is_none_or(|l| l.contains(&row.sensor));
        if could_trace && row.measured() && why.is_none() {
            self.trace_row(&row)?;
        }
        Ok(())
    }

    /// Count `row` in its sensor's sums (`usable`: it can be a row).
    fn count(&mut self, row: &LoggedRecord, usable: bool) {
        let s = self.sensors.entry(row.sensor).or_insert(Sensor {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            ..Sensor::default()
        });
        s.records += 1;
        if !row.lumped_valid() {
            return;
        }
        s.lo = s.lo.min(row.stretch());
        s.hi = s.hi.max(row.stretch());
        if usable {
            let t = row.truth.unwrap_or(BlockTruth {
                r_top_ohm: f64::NAN,
                r_bottom_ohm: f64::NAN,
                ..BlockTruth::default()
            });
            let a = s.at.entry(row.freq_hz.to_bits()).or_default();
            a.n += 1;
            a.stretch_mm += row.stretch();
            a.cs_pf += row.cs_pf;
            a.rs_ohm += row.rs_ohm;
            a.r_ohm += row.r_ohm;
            a.r_top_ohm += t.r_top_ohm;
            a.r_bottom_ohm += t.r_bottom_ohm;
        }
    }

    /// `row` appended to its trace (the file made where it is the
    /// first).
    fn trace_row(&mut self, row: &LoggedRecord) -> Result<()> {
        let t = match (row.truth, self.truth) {
            (Some(t), true) => Some(t),
            (None, true) => bail!(
                "record of channel {} at {:.6} s has no truth line where the others have one",
                row.sensor,
                row.t_s
            ),
            _ => None,
        };
        let key = (self.segment, row.sensor, row.freq_hz.to_bits());
        if !self.traces.contains_key(&key) {
            let trace = self.new_trace(key)?;
            self.traces.insert(key, trace);
        }
        let trace = self.traces.get_mut(&key).expect("made above");
        row_line(&mut self.line, row, t, &trace.hz);
        trace.file.pending.extend_from_slice(&self.line);
        trace.rows += 1;
        Ok(())
    }

    /// A new fragment file for `key` (segment, sensor, frequency's
    /// bits): named by the frequency in whole Hz, or to the mHz where
    /// another of the sensor's frequencies in the segment rounds to the
    /// same Hz.
    fn new_trace(&self, (seg, ch, bits): (u32, u8, u64)) -> Result<Trace> {
        let hz = f64::from_bits(bits);
        let clash = self
            .traces
            .keys()
            .any(|&(s, c, b)| s == seg && c == ch && f64::from_bits(b).round() == hz.round());
        let f = match clash {
            false => format!("{}", hz.round() as u64),
            true => format!("{hz:.3}"),
        };
        let head = match self.truth {
            true => "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf,rs_ohm,c_line_pf,r_line_ohm,flags,c_true_pf,r_true_ohm,stretch_true_mm\n",
            false => "time_s,stretch_mm,r_line_ohm,freq_hz,cs_pf,rs_ohm,c_line_pf,flags\n",
        };
        let mut text = vec![];
        crate::numfmt::shortest(&mut text, hz);
        Ok(Trace {
            file: LineFile::create(self.dir.join(file_name("fragment", seg, ch, &f)), head)?,
            rows: 0,
            hz: text,
        })
    }

    /// Write every record pushed so far (each file whole lines), a
    /// fragment that is long enough renamed a trace, and
    /// `calibration.csv` rewritten with the points so far.
    pub fn flush(&mut self) -> Result<()> {
        self.write_pending()?;
        self.write_calibration().map(|_| ())
    }

    /// Every record pushed so far written to its files (whole lines), a
    /// fragment that is long enough renamed a trace.
    fn write_pending(&mut self) -> Result<()> {
        self.faults.flush(true)?;
        let keep = self.traces.len() <= OPEN_MAX;
        for t in self.traces.values_mut() {
            if t.rows >= MIN_TRACE_ROWS {
                let name = t.file.path.file_name().map(|n| n.to_string_lossy().into_owned());
                if let Some(rest) = name.as_deref().and_then(|n| n.strip_prefix("fragment_")) {
                    t.file.rename(self.dir.join(format!("trace_{rest}")))?;
                }
            }
            t.file.flush(keep)?;
        }
        Ok(())
    }

    /// The data set finished: every file written, a sensor held still
    /// taken out of the traces (its records are its calibration point),
    /// `calibration.csv` and `dataset.json` written once of what stays,
    /// and what is where.
    pub fn finish(mut self) -> Result<Written> {
        self.write_pending()?;
        let held: Vec<(u32, u8, u64)> = self
            .traces
            .keys()
            .copied()
            .filter(|&(_, ch, _)| !self.is_trace(ch))
            .collect();
        for key in held {
            if let Some(t) = self.traces.remove(&key) {
                std::fs::remove_file(&t.file.path)
                    .with_context(|| format!("removing {}", t.file.path.display()))?;
            }
        }
        let (points, left_out) = self.write_calibration()?;
        let mut out = Written {
            calibration_points: points,
            left_out,
            faults: self.n_faults,
            ..Written::default()
        };
        for t in std::mem::take(&mut self.traces).into_values() {
            if t.rows >= MIN_TRACE_ROWS {
                out.rows += t.rows;
                out.traces.push(t.file.path);
            } else {
                out.fragments.push(t.file.path);
            }
        }
        Ok(out)
    }

    /// Is sensor `ch` a calibration point?
    fn is_static(&self, ch: u8) -> bool {
        match &self.roles.statics {
            Some(list) => list.contains(&ch),
            None => self
                .sensors
                .get(&ch)
                .is_some_and(|s| is_static_spread(s.hi - s.lo)),
        }
    }

    /// Are sensor `ch`'s records traces?
    fn is_trace(&self, ch: u8) -> bool {
        match &self.roles.traces {
            Some(list) => list.contains(&ch),
            None => !self.is_static(ch),
        }
    }

    /// `calibration.csv` (replaced whole: a reader sees the old points or
    /// the new): one point per sensor held still, the mean of its usable
    /// records at the frequency it was read at most; a sensor with none
    /// is left out, with a comment that says so. How many points, and
    /// what was left out.
    fn write_calibration(&self) -> Result<(usize, Vec<String>)> {
        let rcols = match self.truth {
            true => "r_top_ohm,r_bottom_ohm",
            false => "r_line_ohm",
        };
        let mut text = format!("stretch_mm,freq_hz,cs_pf,rs_ohm,{rcols}\n");
        let mut left_out = vec![];
        let statics: Vec<u8> = self
            .sensors
            .keys()
            .copied()
            .filter(|&ch| self.is_static(ch))
            .collect();
        for &ch in &statics {
            let s = &self.sensors[&ch];
            match s.at.iter().max_by_key(|(_, a)| a.n) {
                Some((&f, a)) => text += &calibration_line(f64::from_bits(f), a, self.truth),
                None => {
                    let why = format!(
                        "sensor {ch}, held still, has no calibration point: none of its {} records is valid and usable (they are in faults.csv)",
                        s.records
                    );
                    left_out.push(why);
                }
            }
        }
        replace(&self.dir, "calibration.csv", text.as_bytes())?;
        self.write_description(&left_out)?;
        Ok((statics.len() - left_out.len(), left_out))
    }
}

impl DatasetWriter {
    /// [`DATASET_JSON`]: what the columns hold, each trace file's sensor,
    /// frequency, segment and rows, and what was left out.
    fn write_description(&self, left_out: &[String]) -> Result<()> {
        let traces: Vec<serde_json::Value> = self
            .traces
            .iter()
            .map(|(&(segment, sensor, bits), t)| {
                serde_json::json!({
                    "file": t.file.path.file_name().map(|n| n.to_string_lossy().into_owned()),
                    "sensor": sensor,
                    "freq_hz": f64::from_bits(bits),
                    "segment": segment,
                    "rows": t.rows,
                })
            })
            .collect();
        let source = match self.truth {
            true => "a firmware recording in QEMU: stretch and electrode resistances (r_top_ohm, r_bottom_ohm) from the rig, the simulated truth in the *_true columns",
            false => "a firmware recording: stretch from the firmware's calibration, resistance its line estimate r_line_ohm",
        };
        let text = serde_json::to_string_pretty(&serde_json::json!({
            "format": "docs/data-format.md",
            "source": source,
            "calibration": "each sensor held still: its valid records at its most used frequency, averaged",
            "no_value": "an empty field: c_line_pf and r_line_ohm of a record whose line was not vouched for (flags MODEL, or a fault)",
            "traces": traces,
            "left_out": left_out,
        }))?;
        replace(&self.dir, DATASET_JSON, text.as_bytes())
    }
}

/// Replace `dir`'s file `name` with `bytes` whole (a reader sees the old
/// or the new), through a temporary file of its own.
fn replace(dir: &Path, name: &str, bytes: &[u8]) -> Result<()> {
    let mut tmp = tempfile::Builder::new()
        .prefix(".new-")
        .tempfile_in(dir)
        .with_context(|| format!("a new {name} in {}", dir.display()))?;
    tmp.write_all(bytes)?;
    let path = dir.join(name);
    tmp.persist(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// A calibration point's line: the means of `a`, read at `f` Hz.
fn calibration_line(f: f64, a: &Sums, truth: bool) -> String {
    let n = a.n as f64;
    let r_text = match truth {
        true => format!("{:.0},{:.0}", a.r_top_ohm / n, a.r_bottom_ohm / n),
        false => format!("{:.0}", a.r_ohm / n),
    };
    format!(
        "{:.4},{},{:.4},{:.0},{r_text}\n",
        a.stretch_mm / n,
        f,
        a.cs_pf / n,
        a.rs_ohm / n
    )
}

/// A trace file's name: `{kind}_ch{C}_{F}hz.csv`, `{kind}_s{K}_ch…`
/// in segment K ≥ 2.
fn file_name(kind: &str, seg: u32, ch: u8, f: &str) -> String {
    match seg {
        1 => format!("{kind}_ch{ch}_{f}hz.csv"),
        _ => format!("{kind}_s{seg}_ch{ch}_{f}hz.csv"),
    }
}

/// `row`'s line in its trace (`t`: the rig's view, where the data set
/// has it; `hz`: the frequency's text), into `line`.
fn row_line(line: &mut Vec<u8>, row: &LoggedRecord, t: Option<BlockTruth>, hz: &[u8]) {
    // Through `numfmt`: Rust's `{:.N}` costs more than the rest of a
    // replay.
    use crate::numfmt::{fixed, int};
    let field = |line: &mut Vec<u8>, x: f64, prec: usize| {
        fixed(line, x, prec);
        line.push(b',');
    };
    line.clear();
    field(line, row.t_s, 6);
    match t {
        Some(t) => {
            field(line, t.stretch_mm, 4);
            field(line, t.r_top_ohm, 0);
            field(line, t.r_bottom_ohm, 0);
        }
        None => {
            field(line, row.stretch_mm, 4);
            // A trace row without the rig's resistances has its line's
            // (unusable rows, without one, are not written).
            field(line, row.r_ohm, 0);
        }
    }
    line.extend_from_slice(hz);
    line.push(b',');
    // The line's C and R: empty where there is none (0 or NaN).
    let line_field = |line: &mut Vec<u8>, x: f64, prec: usize| {
        if x > 0.0 && x.is_finite() {
            fixed(line, x, prec);
        }
        line.push(b',');
    };
    field(line, row.cs_pf, 4);
    field(line, row.rs_ohm, 0);
    line_field(line, row.c_pf, 4);
    match t {
        Some(t) => {
            line_field(line, row.r_ohm, 0);
            int(line, row.flags.0);
            line.push(b',');
            field(line, t.c_pf, 4);
            field(line, t.r_ohm, 0);
            fixed(line, t.stretch_mm, 4);
        }
        None => int(line, row.flags.0),
    }
    line.push(b'\n');
}
