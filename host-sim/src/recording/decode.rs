//! Reading a firmware recording: the record, tone and truth lines of
//! [`instrument::wire`], from a decoded text log or raw defmt bytes with
//! the firmware's ELF, each record paired with the truth of its block.

use super::{BlockTruth, LoggedRecord, LoggedToneRecord};
use anyhow::{bail, Context, Result};
use instrument::wire::{self, Line, WireError};
use std::collections::BTreeMap;
use std::path::Path;

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
pub fn parse(source: &str, lines: &[(usize, String)]) -> Result<Vec<LoggedRecord>> {
    let mut out = vec![];
    let mut truth: BTreeMap<(u64, u8), wire::TruthLine> = BTreeMap::new();
    for item in wire_lines(source, lines) {
        let (n, l, line) = item?;
        match line {
            Line::Truth(t) => {
                truth.insert((t.t_us, t.sensor), t);
            }
            Line::Tone(_) => bail!(
                "{source}:{n}: an array record ('tone' line) among single-tone records: read array recordings with parse_tones"
            ),
            Line::Rec(r) => {
                let t = truth.remove(&(r.t_us, r.sensor)).map(truth_of);
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
                if let Some(prev) = out.iter().rev().find(|p: &&LoggedRecord| p.sensor == r.sensor) {
                    if r.t_us as f64 * 1e-6 <= prev.t_s {
                        bail!("{source}:{n}: channel {} goes back in time", r.sensor);
                    }
                }
                out.push(LoggedRecord {
                    t_s: r.t_us as f64 * 1e-6,
                    sensor: r.sensor,
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

/// Parse an array recording: its `tone` lines (numbered as in their
/// source; other lines are skipped), each paired with the truth line of
/// its block and sensor. An error names the line and says why: a field
/// that does not parse, a frequency that is not positive or tones out of
/// order, a sensor going back in time, a single-tone `rec` line.
pub fn parse_tones(source: &str, lines: &[(usize, String)]) -> Result<Vec<LoggedToneRecord>> {
    let mut out: Vec<LoggedToneRecord> = vec![];
    let mut truth: BTreeMap<(u64, u8), wire::TruthLine> = BTreeMap::new();
    let mut last: BTreeMap<u8, u64> = BTreeMap::new();
    for item in wire_lines(source, lines) {
        let (n, l, line) = item?;
        match line {
            Line::Truth(t) => {
                truth.insert((t.t_us, t.sensor), t);
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
                if r.c_farad < 0.0 || r.r_ohm < 0.0 || r.chi2 < 0.0 || r.sigma_ln_c < 0.0 {
                    bail!(
                        "{source}:{n}: a negative capacitance, resistance, chi2 or sigma: '{}'",
                        clip(l)
                    );
                }
                if let Some(&t0) = last.get(&r.sensor) {
                    if r.t_us <= t0 {
                        bail!("{source}:{n}: sensor {} goes back in time", r.sensor);
                    }
                }
                last.insert(r.sensor, r.t_us);
                let t = truth.remove(&(r.t_us, r.sensor)).map(truth_of);
                out.push(LoggedToneRecord { rec: r, truth: t });
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
fn truth_of(t: wire::TruthLine) -> BlockTruth {
    BlockTruth {
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
pub fn read(input: &Path, elf: Option<&Path>) -> Result<Vec<LoggedRecord>> {
    Ok(read_recording(input, elf)?.0)
}

/// The line a QEMU image logs last (`firmware::qemu::end`): a log
/// without it was cut short (a crash, a hang, a recording stopped by
/// hand).
pub const END: &str = "end";

/// Whether a log's text holds its end line.
fn ends(text: &str) -> bool {
    text.lines().any(|l| {
        let l = l.trim_end();
        l == END || l.ends_with(&format!(" {END}"))
    })
}

/// [`read`], and whether the recording ended as a run does (its
/// [`END`] line): false for one cut short.
pub fn read_recording(input: &Path, elf: Option<&Path>) -> Result<(Vec<LoggedRecord>, bool)> {
    let bytes = read_regular(input, 1 << 30)?;
    let name = input.display().to_string();
    let (lines, ended) = match elf {
        Some(elf) => {
            let all = decode_defmt(elf, &bytes)?;
            let ended = all.iter().any(|(_, l)| l.trim_end() == END);
            (all, ended)
        }
        None => {
            let text = String::from_utf8_lossy(&bytes);
            (log_lines(&text), ends(&text))
        }
    };
    // An array recording ('tone' lines) gives a record per tone.
    let array = lines
        .iter()
        .any(|(_, l)| matches!(wire::parse(l), Ok(Line::Tone(_))));
    let recs = if array {
        parse_tones(&name, &lines)?
            .iter()
            .flat_map(LoggedToneRecord::per_tone)
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
    Ok((recs, ended))
}
