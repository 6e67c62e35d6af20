//! Firmware recordings: the `rec` and `truth` lines of
//! [`instrument::wire`] (from a decoded log, or raw defmt bytes with the
//! firmware's ELF) turned into a data set of the interchange format
//! (`shared/data-format.md`) that `residual` and `identify` read.
//!
//! A data set from a recording:
//! * `trace_ch{C}_{F}hz.csv`: one file per moving channel and excitation
//!   frequency (a trace holds one frequency; the firmware's policy changes
//!   it), every record with a lumped measurement: `time_s` (the block's
//!   middle), `stretch_mm`, `freq_hz`, `cs_pf`, `rs_ohm`, the firmware's own
//!   `c_line_pf`, `r_line_ohm` and `flags`; with a truth line (QEMU), the
//!   rig's view too: the true stretch and the end-to-end electrode
//!   resistances `r_top_ohm`, `r_bottom_ohm`, and `*_true` columns.
//! * `calibration.csv`: one point per static channel (stretch spread below
//!   [`STATIC_SPREAD_MM`]), the mean of its valid records at the frequency
//!   it was read at most.
//! * `fragment_ch{C}_{F}hz.csv`: a run too short to be modelled as a trace
//!   (fewer than [`MIN_TRACE_ROWS`] records, such as the one start-up block
//!   at the lowest frequency), same columns: kept, but not a trace.
//! * `faults.csv`: every record flagged invalid, with its flags.
//!
//! Without truth lines (a board) the stretch is the firmware's calibrated
//! one and the resistance its line estimate `r_line_ohm`: the analyses say
//! so ([`crate::dataset::Table::resistance`]).

use crate::model::prepared::MIN_TRACE_ROWS;
use anyhow::{bail, Context, Result};
use instrument::faults::Flags;
use instrument::wire::{self, Line, WireError};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A channel whose stretch moves less than this (mm) is static: a
/// calibration point.
pub const STATIC_SPREAD_MM: f64 = 0.5;

/// The simulated truth of one block (QEMU), in the units of the data sets.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Truth {
    /// True line capacitance, pF.
    pub c_pf: f64,
    /// True line resistance, Ω.
    pub r_ohm: f64,
    /// True stretch, mm.
    pub stretch_mm: f64,
    /// End-to-end top electrode resistance, as the rig's ohmmeter reads it
    /// through the tabs, Ω.
    pub r_top_ohm: f64,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom_ohm: f64,
}

impl Truth {
    /// What a series-R-C meter at `f_hz` reads on the true sensor, pF:
    /// its line (`r_ohm`, `c_pf`) through the tab leads and contacts, the
    /// part of the end-to-end resistances outside the line
    /// (`r_top_ohm + r_bottom_ohm − r_ohm`, in series at the read end).
    pub fn series_meter_pf(&self, f_hz: f64) -> Option<f64> {
        let w = std::f64::consts::TAU * f_hz;
        let g = num_complex::Complex64::new(0.0, w * self.r_ohm * self.c_pf * 1e-12).sqrt();
        if g.norm().is_nan() || g.norm() <= 0.0 {
            return None;
        }
        // Open-ended R-C line: Z = R·coth(γ)/γ, γ = √(jωRC).
        let z = self.r_ohm * (g.cosh() / g.sinh()) / g
            + (self.r_top_ohm + self.r_bottom_ohm - self.r_ohm).max(0.0);
        (z.im < 0.0).then(|| -1e12 / (w * z.im))
    }
}

/// One record, with the truth of its block when the recording has one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rec {
    /// Middle of the block, s since start.
    pub t_s: f64,
    /// Channel.
    pub channel: u8,
    /// Excitation frequency, Hz.
    pub freq_hz: f64,
    /// Lumped Cs, pF (0: not measured).
    pub cs_pf: f64,
    /// Lumped Rs, Ω.
    pub rs_ohm: f64,
    /// Line-corrected C, pF (0: not available).
    pub c_pf: f64,
    /// Line-corrected R (both electrodes), Ω.
    pub r_ohm: f64,
    /// Stretch from the firmware's calibration, mm.
    pub stretch_mm: f64,
    /// Flags.
    pub flags: Flags,
    /// The simulated truth of the same block (QEMU only).
    pub truth: Option<Truth>,
}

impl Rec {
    /// True if C can be trusted.
    pub fn valid(&self) -> bool {
        self.flags.valid()
    }

    /// The record carries a lumped measurement (not open, shorted,
    /// settling or clipped).
    pub fn measured(&self) -> bool {
        self.cs_pf > 0.0
            && !(self.flags.has(Flags::OPEN)
                || self.flags.has(Flags::SHORTED)
                || self.flags.has(Flags::SETTLING)
                || self.flags.has(Flags::CLIPPED))
    }

    /// The stretch the rig saw (truth) or else the firmware's, mm.
    pub fn stretch(&self) -> f64 {
        self.truth.map_or(self.stretch_mm, |t| t.stretch_mm)
    }
}

/// The record and truth lines of a decoded text log: everything from the
/// keyword on (a probe prefixes lines with a timestamp and a level), with
/// the line numbers of the log (1-based).
pub fn log_lines(text: &str) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| {
            [wire::REC, wire::TRUTH, wire::TONE].iter().find_map(|k| {
                let at = l.find(&format!("{k} "))?;
                // The keyword starts the line or follows a space.
                (at == 0 || l[..at].ends_with(' ')).then(|| (i + 1, l[at..].to_string()))
            })
        })
        .collect()
}

/// Decode raw defmt bytes with the ELF's defmt table; one string per frame,
/// numbered from 1.
pub fn decode_defmt(elf: &Path, raw: &[u8]) -> Result<Vec<(usize, String)>> {
    let bytes = read_regular(elf, 64 << 20)?;
    let table = defmt_decoder::Table::parse(&bytes)
        .map_err(|e| anyhow::anyhow!("{}: defmt table: {e}", elf.display()))?
        .ok_or_else(|| anyhow::anyhow!("{}: no defmt data", elf.display()))?;
    let mut dec = table.new_stream_decoder();
    dec.received(raw);
    let mut out = vec![];
    loop {
        match dec.decode() {
            Ok(frame) => out.push((out.len() + 1, frame.display_message().to_string())),
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => {
                bail!("malformed defmt stream after {} frames", out.len())
            }
        }
    }
    Ok(out)
}

/// Read a regular file of at most `limit` bytes.
fn read_regular(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).with_context(|| format!("{}: cannot open", path.display()))?;
    if !meta.is_file() {
        bail!("{}: not a regular file", path.display());
    }
    if meta.len() > limit {
        bail!(
            "{}: {} bytes, more than the {limit} read",
            path.display(),
            meta.len()
        );
    }
    std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
}

/// Parse record and truth lines (numbered as in their source; other lines
/// are skipped), pairing each record with the truth line of its block.
/// `source` names the input in errors.
pub fn parse(source: &str, lines: &[(usize, String)]) -> Result<Vec<Rec>> {
    let mut out = vec![];
    let mut truth: BTreeMap<(u64, u8), wire::TruthLine> = BTreeMap::new();
    for item in wire_lines(source, lines) {
        let (n, l, line) = item?;
        match line {
            Line::Truth(t) => {
                truth.insert((t.t_us, t.channel), t);
            }
            Line::Tone(_) => bail!(
                "{source}:{n}: an array record ('tone' line) among single-tone records: read array recordings with parse_tones"
            ),
            Line::Rec(r) => {
                let t = truth.remove(&(r.t_us, r.channel)).map(truth_of);
                if r.freq_hz <= 0.0 {
                    bail!("{source}:{n}: frequency {} Hz is not positive", r.freq_hz);
                }
                let values = [r.cs_farad, r.rs_ohm, r.c_farad, r.r_ohm];
                if values.iter().any(|&v| v < 0.0) {
                    bail!(
                        "{source}:{n}: a negative capacitance or resistance: '{}'",
                        clip(l)
                    );
                }
                if let Some(prev) = out.iter().rev().find(|p: &&Rec| p.channel == r.channel) {
                    if r.t_us as f64 * 1e-6 <= prev.t_s {
                        bail!("{source}:{n}: channel {} goes back in time", r.channel);
                    }
                }
                out.push(Rec {
                    t_s: r.t_us as f64 * 1e-6,
                    channel: r.channel,
                    freq_hz: r.freq_hz as f64,
                    cs_pf: r.cs_farad as f64 * 1e12,
                    rs_ohm: r.rs_ohm as f64,
                    c_pf: r.c_farad as f64 * 1e12,
                    r_ohm: r.r_ohm as f64,
                    stretch_mm: r.stretch_mm as f64,
                    flags: r.flags,
                    truth: t,
                });
            }
        }
    }
    Ok(out)
}

/// One array record ([`instrument::tones::ToneRecord`]) with the truth of
/// its block, if the recording has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneRec {
    /// The record as the firmware wrote it.
    pub rec: instrument::tones::ToneRecord,
    /// The rig's view of its sensor during the block.
    pub truth: Option<Truth>,
}

impl ToneRec {
    /// Time of the block's middle, s.
    pub fn t_s(&self) -> f64 {
        self.rec.t_us as f64 * 1e-6
    }

    /// Relative error of C against the truth, if both are there.
    pub fn c_error(&self) -> Option<f64> {
        let t = self.truth?;
        (self.rec.c_farad > 0.0).then(|| self.rec.c_farad as f64 * 1e12 / t.c_pf - 1.0)
    }

    /// The record as one single-tone record per tone, for the data sets
    /// (a trace per sensor and frequency): each with its tone's lumped
    /// Cs–Rs (0 when its impedance was not measured or is not a lossy
    /// capacitor) and the joint line, flags and truth of the record.
    ///
    /// A record that failed the model check ([`Flags::MODEL`]) still holds
    /// two good lumped readings, which are what `identify` looks at to
    /// find what the line lacks: they keep their validity, and the line
    /// the check could not vouch for is left out (C and R 0, "not
    /// available").
    pub fn per_tone(&self) -> [Rec; 2] {
        let r = &self.rec;
        let model = r.flags.has(Flags::MODEL);
        let flags = Flags(r.flags.0 & !Flags::MODEL);
        let (c_pf, r_ohm) = match model {
            true => (0.0, 0.0),
            false => (r.c_farad as f64 * 1e12, r.r_ohm as f64),
        };
        core::array::from_fn(|k| {
            let lumped = dsp_core::lumped::SeriesRc::from_impedance(r.z[k], r.f_hz[k]).ok();
            Rec {
                t_s: self.t_s(),
                channel: r.channel,
                freq_hz: r.f_hz[k] as f64,
                cs_pf: lumped.map_or(0.0, |m| m.cs_farad as f64 * 1e12),
                rs_ohm: lumped.map_or(0.0, |m| m.rs_ohm as f64),
                c_pf,
                r_ohm,
                stretch_mm: r.stretch_mm as f64,
                flags,
                truth: self.truth,
            }
        })
    }
}

/// Parse an array recording: its `tone` lines (numbered as in their
/// source; other lines are skipped), each paired with the truth line of
/// its block and sensor. An error names the line and says why: a field
/// that does not parse, a frequency that is not positive or tones out of
/// order, a sensor going back in time, a single-tone `rec` line.
pub fn parse_tones(source: &str, lines: &[(usize, String)]) -> Result<Vec<ToneRec>> {
    let mut out: Vec<ToneRec> = vec![];
    let mut truth: BTreeMap<(u64, u8), wire::TruthLine> = BTreeMap::new();
    let mut last: BTreeMap<u8, u64> = BTreeMap::new();
    for item in wire_lines(source, lines) {
        let (n, l, line) = item?;
        match line {
            Line::Truth(t) => {
                truth.insert((t.t_us, t.channel), t);
            }
            Line::Rec(_) => bail!("{source}:{n}: a single-tone record ('rec' line) in an array recording"),
            Line::Tone(r) => {
                if !(r.f_hz[0] > 0.0 && r.f_hz[0] < r.f_hz[1]) {
                    bail!(
                        "{source}:{n}: tones {} Hz and {} Hz are not two positive frequencies, lower first",
                        r.f_hz[0],
                        r.f_hz[1]
                    );
                }
                if r.c_farad < 0.0 || r.r_ohm < 0.0 || r.chi2 < 0.0 || r.sigma_c < 0.0 {
                    bail!(
                        "{source}:{n}: a negative capacitance, resistance, chi2 or sigma: '{}'",
                        clip(l)
                    );
                }
                if let Some(&t0) = last.get(&r.channel) {
                    if r.t_us <= t0 {
                        bail!("{source}:{n}: sensor {} goes back in time", r.channel);
                    }
                }
                last.insert(r.channel, r.t_us);
                let t = truth.remove(&(r.t_us, r.channel)).map(truth_of);
                out.push(ToneRec { rec: r, truth: t });
            }
        }
    }
    Ok(out)
}

/// The record and truth lines of a log, numbered as in `source`; other
/// lines are skipped, a malformed one is an error naming its line.
fn wire_lines<'a>(
    source: &'a str,
    lines: &'a [(usize, String)],
) -> impl Iterator<Item = Result<(usize, &'a str, Line)>> + 'a {
    lines.iter().filter_map(move |(n, l)| match wire::parse(l) {
        Ok(line) => Some(Ok((*n, l.as_str(), line))),
        Err(WireError::NotARecord) => None,
        Err(e) => Some(Err(anyhow::anyhow!("{source}:{n}: {e}: '{}'", clip(l)))),
    })
}

/// The rig's view of a block, as the reports use it.
fn truth_of(t: wire::TruthLine) -> Truth {
    Truth {
        c_pf: t.c_farad as f64 * 1e12,
        r_ohm: t.r_line_ohm as f64,
        stretch_mm: t.stretch_mm as f64,
        r_top_ohm: t.r_top_ohm as f64,
        r_bottom_ohm: t.r_bottom_ohm as f64,
    }
}

/// A line for an error message: at most 120 characters.
fn clip(l: &str) -> String {
    if l.chars().count() > 120 {
        l.chars().take(117).collect::<String>() + "..."
    } else {
        l.to_string()
    }
}

/// Read a recording: a decoded text log, or raw defmt bytes with `elf`.
pub fn read(input: &Path, elf: Option<&Path>) -> Result<Vec<Rec>> {
    let bytes = read_regular(input, 1 << 30)?;
    let name = input.display().to_string();
    let lines = match elf {
        Some(elf) => decode_defmt(elf, &bytes)?,
        None => log_lines(&String::from_utf8_lossy(&bytes)),
    };
    // An array recording ('tone' lines) gives a record per tone.
    let array = lines
        .iter()
        .any(|(_, l)| matches!(wire::parse(l), Ok(Line::Tone(_))));
    let recs = if array {
        parse_tones(&name, &lines)?
            .iter()
            .flat_map(ToneRec::per_tone)
            .collect()
    } else {
        parse(&name, &lines)?
    };
    if recs.is_empty() {
        bail!(
            "{name}: no records (expected '{} ...' or '{} ...' lines, or raw defmt with --elf)",
            wire::REC,
            wire::TONE
        );
    }
    Ok(recs)
}

/// Which channels a recording's data set uses.
#[derive(Clone, Debug, Default)]
pub struct Roles {
    /// Channels whose records become traces (None: the moving ones).
    pub traces: Option<Vec<u8>>,
    /// Channels whose records become calibration points (None: the
    /// static ones).
    pub statics: Option<Vec<u8>>,
}

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
}

/// Write `recs` as a data set in `dir` (see the module documentation).
pub fn write_dataset(dir: &Path, recs: &[Rec], roles: &Roles) -> Result<Written> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut channels: BTreeMap<u8, Vec<&Rec>> = BTreeMap::new();
    for r in recs {
        channels.entry(r.channel).or_default().push(r);
    }
    let spread = |rs: &[&Rec]| {
        let s = rs.iter().filter(|r| r.valid()).map(|r| r.stretch());
        let (lo, hi) = s.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if lo <= hi {
            hi - lo
        } else {
            f64::NAN
        }
    };
    let is_static = |ch: u8, rs: &[&Rec]| match &roles.statics {
        Some(list) => list.contains(&ch),
        // A channel with no valid record has no stretch to judge (its
        // records are all in faults.csv).
        None => spread(rs) < STATIC_SPREAD_MM,
    };
    let is_trace = |ch: u8, rs: &[&Rec]| match &roles.traces {
        Some(list) => list.contains(&ch),
        None => !is_static(ch, rs),
    };
    let truth = recs.iter().any(|r| r.truth.is_some());
    let mut out = Written::default();
    // Faults.
    let mut faults = std::io::BufWriter::new(std::fs::File::create(dir.join("faults.csv"))?);
    writeln!(faults, "time_s,channel,freq_hz,flags")?;
    for r in recs.iter().filter(|r| !r.valid()) {
        writeln!(faults, "{:.6},{},{},{}", r.t_s, r.channel, r.freq_hz, r.flags.0)?;
        out.faults += 1;
    }
    faults.flush()?;
    // Calibration: one point per static channel.
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
    for (&ch, rs) in &channels {
        if !is_static(ch, rs) {
            continue;
        }
        let good: Vec<&&Rec> = rs.iter().filter(|r| r.valid() && r.measured()).collect();
        let mut count: BTreeMap<u64, usize> = BTreeMap::new();
        for r in &good {
            *count.entry(r.freq_hz.to_bits()).or_default() += 1;
        }
        let Some((&f, _)) = count.iter().max_by_key(|(_, n)| **n) else {
            bail!("static channel {ch} has no valid record");
        };
        let at: Vec<&&&Rec> = good.iter().filter(|r| r.freq_hz.to_bits() == f).collect();
        let n = at.len() as f64;
        let mean = |g: &dyn Fn(&Rec) -> f64| at.iter().map(|r| g(r)).sum::<f64>() / n;
        let r_text = if truth {
            let t = |g: fn(&Truth) -> f64| mean(&|r: &Rec| r.truth.as_ref().map_or(f64::NAN, g));
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
        out.calibration_points += 1;
    }
    cal.flush()?;
    // Traces: one file per trace channel and frequency.
    let mut groups: BTreeMap<(u8, u64), Vec<&Rec>> = BTreeMap::new();
    for (&ch, rs) in &channels {
        if is_trace(ch, rs) {
            for r in rs.iter().filter(|r| r.measured()) {
                groups.entry((ch, r.freq_hz.round() as u64)).or_default().push(r);
            }
        }
    }
    for ((ch, f), rs) in groups {
        let kind = if rs.len() >= MIN_TRACE_ROWS {
            "trace"
        } else {
            "fragment"
        };
        let path = dir.join(format!("{kind}_ch{ch}_{f}hz.csv"));
        let mut w = std::io::BufWriter::new(std::fs::File::create(&path)?);
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
        for r in rs {
            match r.truth {
                Some(t) if truth => writeln!(
                    w,
                    "{:.6},{:.4},{:.0},{:.0},{},{:.4},{:.0},{:.4},{:.0},{},{:.4},{:.0},{:.4}",
                    r.t_s,
                    t.stretch_mm,
                    t.r_top_ohm,
                    t.r_bottom_ohm,
                    r.freq_hz,
                    r.cs_pf,
                    r.rs_ohm,
                    r.c_pf,
                    r.r_ohm,
                    r.flags.0,
                    t.c_pf,
                    t.r_ohm,
                    t.stretch_mm
                )?,
                None if truth => bail!(
                    "record of channel {ch} at {:.6} s has no truth line where the others have one",
                    r.t_s
                ),
                _ => writeln!(
                    w,
                    "{:.6},{:.4},{:.0},{},{:.4},{:.0},{:.4},{}",
                    r.t_s, r.stretch_mm, r.r_ohm, r.freq_hz, r.cs_pf, r.rs_ohm, r.c_pf, r.flags.0
                )?,
            }
            if kind == "trace" {
                out.rows += 1;
            }
        }
        w.flush()?;
        if kind == "trace" {
            out.traces.push(path);
        } else {
            out.fragments.push(path);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {

    #[test]
    fn an_array_recording_reads_as_a_record_per_tone() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("array.log");
        // Sensor 3: a clean record, then one the model check flagged.
        std::fs::write(
            &log,
            "start array\n\
             truth 2000 3 205 1000000 0 1300000 1300000\n\
             tone 2000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 1.2 0.0004 0.1 0\n\
             12:00:01 INFO tone 6000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 40 0.0004 0.1 256\n",
        )
        .unwrap();
        let recs = read(&log, None).unwrap();
        assert_eq!(recs.len(), 4);
        assert_eq!(
            recs.iter().map(|r| r.freq_hz).collect::<Vec<_>>(),
            [500.0, 2000.0, 500.0, 2000.0]
        );
        // Each tone's lumped reading from its own impedance.
        let cs = -1e12 / (std::f64::consts::TAU * 2000.0 * -390000.0);
        assert!((recs[1].cs_pf - cs).abs() < 1e-3 * cs && recs[1].rs_ohm == 200000.0);
        assert!(recs[0].truth.is_some() && recs[2].truth.is_none());
        assert!((recs[0].c_pf - 205.1).abs() < 1e-3 && recs[0].valid());
        // The flagged record keeps its lumped readings, valid, without a line.
        assert!(recs[2].valid() && recs[2].c_pf == 0.0 && recs[2].cs_pf > 0.0);
        // A `rec` line among them says what is wrong, with its line.
        std::fs::write(
            &log,
            "tone 2000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 1.2 0.0004 0.1 0\nrec 1 2 3 4 5 6 7 8 9\n",
        )
        .unwrap();
        let e = read(&log, None).unwrap_err().to_string();
        assert!(e.contains(":2: a single-tone record"), "{e}");
    }
    use super::*;

    fn lines(s: &str) -> Vec<(usize, String)> {
        log_lines(s)
    }

    /// The series meter on the truth: the open line alone against
    /// dsp-core's line model (f32); tab leads are a pure series
    /// resistance, which a series meter's Cs does not see.
    #[test]
    fn series_meter_on_the_truth_is_the_line_through_its_leads() {
        use dsp_core::lumped::SeriesRc;
        use dsp_core::tline::LineModel;
        for (r, c, f) in [
            (712e3, 210.0, 585.9375),
            (712e3, 210.0, 5859.375),
            (2.8e6, 230.0, 1953.125),
        ] {
            let t = Truth {
                c_pf: c,
                r_ohm: r,
                r_top_ohm: r / 2.0,
                r_bottom_ohm: r / 2.0,
                ..Truth::default()
            };
            let z = LineModel::Continuous
                .impedance(r as f32, (c * 1e-12) as f32, f as f32)
                .unwrap();
            let cs = SeriesRc::from_impedance(z, f as f32).unwrap().cs_farad as f64 * 1e12;
            let got = t.series_meter_pf(f).unwrap();
            assert!((got - cs).abs() < 1e-4 * c, "{got} vs {cs}");
            // Leads of 1.8× the line: in series, the imaginary part (and
            // so Cs) is the line's.
            let leads = Truth {
                r_top_ohm: 1.4 * r,
                r_bottom_ohm: 1.4 * r,
                ..t
            };
            assert!((leads.series_meter_pf(f).unwrap() - got).abs() < 1e-9 * c);
        }
        assert_eq!(Truth::default().series_meter_pf(1e3), None);
    }

    #[test]
    fn parses_pairs_and_splits_by_channel_and_frequency() {
        let log = "start 8 channels\n\
             truth 2880 0 210.0 712000 0.0 350000 362000\n\
             rec 2880 0 585.9375 0 0 0 0 0 16\n\
             truth 8320 1 214.2 712000 2.0 350000 362000\n\
             rec 8320 1 585.9375 213.3 240000 214.21 711000 2.01 0\n\
             12:00:01 INFO truth 13760 1 214.2 712000 4.0 350000 362000\n\
             12:00:01 INFO rec 13760 1 1953.125 200.1 230000 214.25 712500 4.02 0\n\
             truth 19200 2 214.2 712000 0.0 350000 362000\n\
             rec 19200 2 585.9375 0 0 0 0 0 2\n";
        let recs = parse("log", &lines(log)).unwrap();
        assert_eq!(recs.len(), 4);
        assert!((recs[1].truth.unwrap().c_pf - 214.2).abs() < 1e-4);
        assert!((recs[1].t_s - 8.32e-3).abs() < 1e-12);
        assert!(recs[1].valid() && recs[2].valid() && !recs[3].valid() && !recs[0].valid());
        // A held C (flag 32) is no new reading: not valid.
        assert!(!Flags(Flags::HELD).valid());
        let dir = tempfile::tempdir().unwrap();
        let w = write_dataset(dir.path(), &recs, &Roles::default()).unwrap();
        let names: Vec<String> = w
            .fragments
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        // Channel 1 moves (one record at each of two frequencies: runs too
        // short for a trace, kept as fragments); channel 0 (settling only)
        // and channel 2 (open) have no valid record: channel 0 is no
        // calibration point, and the open one is listed as a fault.
        assert!(w.traces.is_empty() && w.rows == 0);
        assert_eq!(names, ["fragment_ch1_586hz.csv", "fragment_ch1_1953hz.csv"]);
        let text = std::fs::read_to_string(&w.fragments[0]).unwrap();
        let row: Vec<&str> = text.lines().nth(2).unwrap().split(',').collect();
        assert_eq!(
            (row[0], row[4], row[5], row[7]),
            ("0.008320", "585.9375", "213.3000", "214.2100")
        );
        let faults = std::fs::read_to_string(dir.path().join("faults.csv")).unwrap();
        assert_eq!(faults.lines().count(), 3, "{faults}");
        assert_eq!(w.faults, 2);
    }

    #[test]
    fn a_board_recording_without_truth_reads_back_with_the_line_estimate() {
        // Channel 0 moves; channels 1-3 are held at 0, 10, 20 mm.
        let mut log = String::new();
        for k in 0..40u64 {
            for ch in 0..4u64 {
                let t = (k * 4 + ch) * 5440 + 2880;
                let s = if ch == 0 {
                    0.5 * k as f64
                } else {
                    10.0 * (ch - 1) as f64
                };
                let c = 210.0 * (1.0 + s / 100.0);
                log += &format!(
                    "rec {t} {ch} 1953.125 {:.3} 90000 {c:.3} 712000 {s:.3} 0\n",
                    c - 2.0
                );
            }
        }
        let recs = parse("board.log", &lines(&log)).unwrap();
        assert!(recs.iter().all(|r| r.truth.is_none()));
        let dir = tempfile::tempdir().unwrap();
        let w = write_dataset(dir.path(), &recs, &Roles::default()).unwrap();
        assert_eq!((w.calibration_points, w.traces.len(), w.rows), (3, 1, 40));
        let ds = crate::dataset::read_dir(dir.path()).unwrap();
        use crate::dataset::Resistance;
        assert_eq!(ds.calibration.resistance, Resistance::InstrumentLine);
        assert_eq!(ds.traces[0].resistance, Resistance::InstrumentLine);
        assert_eq!(ds.traces[0].rows[3].r_rec(), 712000.0);
        assert_eq!(ds.calibration.rows[2].stretch_mm(), 20.0);
    }

    #[test]
    fn malformed_records_are_errors_with_their_position() {
        let err = parse("log", &lines("rec 0 0 585.9 1 2 3\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("7 fields"), "{err}");
        let err = parse("log", &lines("start\nrec 0 0 585.9 1 2 3 4 x 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:2") && err.contains("field 9"), "{err}");
        let err = parse("log", &lines("rec 9 0 1 1 2 3 4 5 0\nrec 9 0 1 1 2 3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:2") && err.contains("back in time"), "{err}");
        let err = parse("log", &lines("rec 9 0 -585.9 1 2 3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("not positive"), "{err}");
        let err = parse("log", &lines("rec 9 0 585.9 1 2 -3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("negative"), "{err}");
        // Not a keyword inside a word.
        assert!(lines("prec 0 0\n").is_empty());
    }
}
