//! Reading measured data sets in the interchange format
//! (`docs/data-format.md`): CSV with one header row, `#` comments
//! anywhere, columns in any order, unknown columns ignored.
//!
//! A reader rejects, naming the file, line and column: a field of a known
//! column that is not a finite number, a row whose field count differs
//! from the header's, a missing required column, a negative resistance or
//! capacitance, a non-increasing `time_s`, a trace whose `freq_hz` is not
//! constant, and a byte that is not UTF-8. It reads regular files only,
//! of at most [`MAX_FILE_BYTES`], and never drops rows.

use anyhow::{bail, Context, Result};
use instrument::faults::Flags;
use std::path::{Path, PathBuf};

/// Which file of a data set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `calibration.csv`: static stretch–capacitance points.
    Calibration,
    /// `sweep.csv`: static frequency sweeps.
    Sweep,
    /// `trace_*.csv`: a dynamic recording at one frequency.
    Trace,
}

impl Kind {
    /// Columns the file must have, besides the electrode resistances
    /// ([`Kind::needs_resistance`]).
    pub fn required(self) -> &'static [&'static str] {
        match self {
            Kind::Calibration | Kind::Sweep => &["stretch_mm", "freq_hz", "cs_pf"],
            Kind::Trace => &["time_s", "stretch_mm", "freq_hz", "cs_pf"],
        }
    }

    /// The file must carry the electrode resistances: `r_top_ohm` and
    /// `r_bottom_ohm`, or an instrument's own line estimate `r_line_ohm`.
    pub fn needs_resistance(self) -> bool {
        self != Kind::Sweep
    }
}

/// Where a table's electrode resistance comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resistance {
    /// The four-terminal end-to-end resistances `r_top_ohm + r_bottom_ohm`
    /// (tabs at both ends of each electrode).
    FourTerminal,
    /// The instrument's own line estimate `r_line_ohm` (a recording from a
    /// two-tab instrument such as this project's firmware).
    InstrumentLine,
    /// None (a sweep).
    None,
}

impl std::fmt::Display for Resistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Resistance::FourTerminal => "four-terminal r_top_ohm + r_bottom_ohm",
            Resistance::InstrumentLine => "the instrument's line estimate r_line_ohm",
            Resistance::None => "none",
        })
    }
}

/// Header of the static files (`calibration.csv`, `sweep.csv`) as this
/// project writes them.
pub const STATIC_HEADER: [&str; 6] = [
    "stretch_mm",
    "freq_hz",
    "cs_pf",
    "rs_ohm",
    "r_top_ohm",
    "r_bottom_ohm",
];
/// Header of trace files as this project writes them.
pub const TRACE_HEADER: [&str; 7] = [
    "time_s",
    "stretch_mm",
    "r_top_ohm",
    "r_bottom_ohm",
    "freq_hz",
    "cs_pf",
    "rs_ohm",
];

/// The known columns, in this order in [`Row::values`].
pub const COLUMNS: [&str; 9] = [
    "time_s",
    "stretch_mm",
    "freq_hz",
    "cs_pf",
    "rs_ohm",
    "r_top_ohm",
    "r_bottom_ohm",
    "r_line_ohm",
    "cs_sigma_pf",
];

/// One row: the known columns present in the file (NaN where absent), and
/// the line it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Values in [`COLUMNS`] order; NaN for a column the file lacks.
    pub values: [f64; 9],
    /// Line number in the file (1-based).
    pub line: u64,
}

impl Row {
    /// time_s.
    pub fn time_s(&self) -> f64 {
        self.values[0]
    }
    /// stretch_mm.
    pub fn stretch_mm(&self) -> f64 {
        self.values[1]
    }
    /// freq_hz.
    pub fn freq_hz(&self) -> f64 {
        self.values[2]
    }
    /// cs_pf.
    pub fn cs_pf(&self) -> f64 {
        self.values[3]
    }
    /// rs_ohm (NaN if not recorded).
    pub fn rs_ohm(&self) -> f64 {
        self.values[4]
    }
    /// r_top_ohm.
    pub fn r_top_ohm(&self) -> f64 {
        self.values[5]
    }
    /// r_bottom_ohm.
    pub fn r_bottom_ohm(&self) -> f64 {
        self.values[6]
    }
    /// r_line_ohm (NaN if not recorded).
    pub fn r_line_ohm(&self) -> f64 {
        self.values[7]
    }
    /// cs_sigma_pf: the stated 1σ uncertainty of cs_pf, pF (NaN if not
    /// given). An extension of the interchange format for points whose
    /// precision is known but that carry no trace to measure a noise
    /// floor on (transcribed values); other readers ignore the column.
    pub fn cs_sigma_pf(&self) -> f64 {
        self.values[8]
    }
    /// The recorded electrode resistance the analyses use, Ω: R_top +
    /// R_bottom where recorded, else the instrument's line estimate (see
    /// [`Table::resistance`]).
    pub fn r_rec(&self) -> f64 {
        let four = self.r_top_ohm() + self.r_bottom_ohm();
        if four.is_finite() {
            four
        } else {
            self.r_line_ohm()
        }
    }
}

/// One file of a data set.
#[derive(Clone, Debug)]
pub struct Table {
    /// Where it came from.
    pub path: PathBuf,
    /// Which kind of file.
    pub kind: Kind,
    /// Where its electrode resistance comes from.
    pub resistance: Resistance,
    /// Every data row the instrument vouched for, in file order.
    pub rows: Vec<Row>,
    /// Rows the instrument flagged (a `flags` column with a fault bit;
    /// [`Flags::UNCALIBRATED`] is a status, not a fault): read
    /// and checked like the others, then left out of [`Table::rows`], so
    /// that no analysis fits a reading the instrument did not stand by;
    /// the analyses say how many.
    pub flagged: usize,
}

/// The largest data file read, bytes (a million-row trace is ~60 MB).
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// A field as quoted in an error: at most 40 characters.
fn quote(field: &str) -> String {
    if field.chars().count() > 40 {
        format!(
            "'{}…' ({} characters)",
            field.chars().take(40).collect::<String>(),
            field.chars().count()
        )
    } else {
        format!("'{field}'")
    }
}

/// The text of a regular file of at most [`MAX_FILE_BYTES`]; a byte that
/// is not UTF-8 is an error with its line and column.
fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path).with_context(|| format!("{name}: cannot open"))?;
    if !meta.is_file() {
        bail!("{name}: not a regular file (a data set holds regular files only)");
    }
    if meta.len() > MAX_FILE_BYTES {
        bail!(
            "{name}: {} bytes, more than the {MAX_FILE_BYTES} a data file may have",
            meta.len()
        );
    }
    // At most the size the file reports: a file of the kernel's (/proc)
    // reports 0 and would otherwise be read without end, or block.
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, meta.len()), &mut bytes))
        .with_context(|| format!("{name}: cannot read"))?;
    Ok(bytes)
}

/// The most a data set's files may hold together, bytes.
pub const MAX_DATASET_BYTES: u64 = 1 << 30;

/// The physical bounds of each of [`COLUMNS`]: no sensor, rig or
/// instrument gives a value outside them (a value outside is a unit
/// error or a corrupted file), with its unit for the message.
const BOUNDS: [(f64, f64, &str); 9] = [
    (-1e7, 1e7, "s"),
    (-1e4, 1e4, "mm"),
    (1e-3, 1e9, "Hz"),
    (1e-3, 1e9, "pF"),
    (0.0, 1e12, "Ω"),
    (0.0, 1e12, "Ω"),
    (0.0, 1e12, "Ω"),
    (0.0, 1e12, "Ω"),
    (0.0, 1e9, "pF"),
];

/// Whether `v` lies within the physical bounds of column `col` (one of
/// [`COLUMNS`]; any other column has none): what the reader accepts, so
/// that a writer never writes a row its own reader refuses.
pub fn within_bounds(col: &str, v: f64) -> bool {
    match COLUMNS.iter().position(|c| *c == col) {
        Some(k) => (BOUNDS[k].0..=BOUNDS[k].1).contains(&v),
        None => true,
    }
}

/// `bytes` as text, or the line and column of the first byte that is not
/// UTF-8.
fn utf8(name: &str, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let ok = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = ok.iter().filter(|&&b| b == b'\n').count() + 1;
        let col = ok.len() - ok.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1) + 1;
        anyhow::anyhow!("{name}:{line}:{col}: not UTF-8 text")
    })
}

/// Read and check one file.
pub fn read_table(path: &Path, kind: Kind) -> Result<Table> {
    parse_table(path, read_bytes(path)?, kind)
}

/// Check the contents `bytes` of the file `path` (named in the messages)
/// as a table of `kind`: what [`read_table`] does once the file is read.
pub fn parse_table(path: &Path, bytes: Vec<u8>, kind: Kind) -> Result<Table> {
    let name = path.display().to_string();
    let text = utf8(&name, bytes)?;
    // Comments may stand anywhere; drop them but keep each kept line's
    // physical number for the messages.
    let kept: Vec<(u64, &str)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with('#'))
        .map(|(i, l)| (i as u64 + 1, l))
        .collect();
    let physical = |csv_line: u64| {
        kept.get(csv_line.saturating_sub(1) as usize)
            .map_or(csv_line, |k| k.0)
    };
    let joined = kept.iter().map(|k| k.1).collect::<Vec<_>>().join("\n");
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(joined.as_bytes());
    let head = rd
        .headers()
        .with_context(|| format!("{name}: cannot read the header row"))?
        .clone();
    let header = Header::of(&name, &head, physical(1), kind)?;
    let mut rows: Vec<Row> = vec![];
    let mut flagged = 0;
    for rec in rd.records() {
        let rec = rec.with_context(|| format!("{name}: malformed CSV"))?;
        let line = physical(rec.position().map_or(0, |p| p.line()));
        let row = header.row(&name, &rec, line)?;
        header.check_order(&name, &row, &rows, kind)?;
        if header.usable(&row, header.flags(&name, &rec, line)?) {
            rows.push(row);
        } else {
            flagged += 1;
        }
    }
    if rows.is_empty() {
        bail!(
            "{name}: no data rows{}",
            if flagged > 0 {
                format!(" the instrument vouched for ({flagged} flagged)")
            } else {
                String::new()
            }
        );
    }
    Ok(Table {
        path: path.to_path_buf(),
        kind,
        resistance: header.resistance,
        rows,
        flagged,
    })
}

/// A file's header row, checked: where each known column stands.
struct Header {
    /// Fields per row.
    fields: usize,
    /// Its physical line.
    line: u64,
    /// Where each of [`COLUMNS`] stands, if it does.
    index: Vec<Option<usize>>,
    /// Where the instrument's `flags` stand, if they do.
    flags_at: Option<usize>,
    /// Where the electrode resistance comes from.
    resistance: Resistance,
}

impl Header {
    /// The header `head` (at physical line `line`) of a file of `kind`:
    /// an error naming a missing required column.
    fn of(name: &str, head: &csv::StringRecord, line: u64, kind: Kind) -> Result<Self> {
        let has = |c: &str| head.iter().any(|h| h == c);
        let header = || head.iter().collect::<Vec<_>>().join(",");
        for req in kind.required() {
            if !has(req) {
                bail!(
                    "{name}:{line}: missing required column '{req}' (header: {})",
                    header()
                );
            }
        }
        let resistance = if !kind.needs_resistance() {
            Resistance::None
        } else if has("r_top_ohm") && has("r_bottom_ohm") {
            Resistance::FourTerminal
        } else if has("r_line_ohm") {
            Resistance::InstrumentLine
        } else {
            bail!(
                "{name}:{line}: missing required columns 'r_top_ohm' and 'r_bottom_ohm' (or an instrument's 'r_line_ohm') (header: {})",
                header()
            );
        };
        Ok(Self {
            fields: head.len(),
            line,
            index: COLUMNS
                .iter()
                .map(|c| head.iter().position(|h| h == *c))
                .collect(),
            flags_at: head.iter().position(|h| h == "flags"),
            resistance,
        })
    }

    /// One data row at physical `line`, every known field checked.
    fn row(&self, name: &str, rec: &csv::StringRecord, line: u64) -> Result<Row> {
        if rec.len() != self.fields {
            bail!(
                "{name}:{line}: {} fields where the header (line {}) has {}",
                rec.len(),
                self.line,
                self.fields
            );
        }
        let mut values = [f64::NAN; 9];
        // An instrument's own r_line_ohm is modelled only where no
        // four-terminal resistances are given, and has no value (an empty
        // field, or 0) in a record the instrument flagged.
        let flagged = self.flags_at.is_some_and(|i| {
            rec.get(i)
                .is_some_and(|f| f.trim().parse::<u16>().map_or(true, |f| !Flags(f).valid()))
        });
        for (k, col) in COLUMNS.iter().enumerate() {
            let Some(i) = self.index[k] else { continue };
            let field = rec.get(i).unwrap_or("");
            if field.is_empty() && flagged && *col == "r_line_ohm" {
                continue;
            }
            let v: f64 = match field.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => bail!(
                    "{name}:{line}:{}: column '{col}': {} is not a finite number",
                    i + 1,
                    quote(field)
                ),
            };
            let nonneg = matches!(
                *col,
                "cs_pf" | "rs_ohm" | "r_top_ohm" | "r_bottom_ohm" | "r_line_ohm"
            );
            if nonneg && v < 0.0 {
                bail!("{name}:{line}:{}: column '{col}': negative value {v}", i + 1);
            }
            // Zero is no reading: Cs is undefined at DC, a zero Cs is no
            // capacitor, a zero resistance no carbon electrode; none can
            // be modelled.
            let positive = match *col {
                "freq_hz" | "cs_pf" | "r_top_ohm" | "r_bottom_ohm" | "cs_sigma_pf" => true,
                "r_line_ohm" => self.resistance == Resistance::InstrumentLine && !flagged,
                _ => false,
            };
            if positive && v <= 0.0 {
                bail!(
                    "{name}:{line}:{}: column '{col}': {v} is not positive (no reading: it cannot be modelled)",
                    i + 1
                );
            }
            let (lo, hi, unit) = BOUNDS[k];
            if !(lo..=hi).contains(&v) {
                bail!(
                    "{name}:{line}:{}: column '{col}': {v:e} is outside {lo:e} … {hi:e} {unit} (no sensor or instrument gives it: a unit error, or a corrupted file?)",
                    i + 1
                );
            }
            values[k] = v;
        }
        Ok(Row { values, line })
    }

    /// Whether `row`, of `flags`, is one the analyses take: one with no
    /// fault bit, or flagged only by the model check ([`Flags::MODEL`]:
    /// its lumped reading stands, its line has no value) where its
    /// resistance does not come from that line.
    fn usable(&self, row: &Row, flags: u16) -> bool {
        let model_only = flags & Flags::MODEL != 0 && Flags(flags & !Flags::MODEL).valid();
        Flags(flags).valid()
            || (model_only && (self.resistance != Resistance::InstrumentLine || row.r_line_ohm() > 0.0))
    }

    /// The row's `flags` (0 without the column): an error naming the place
    /// unless a whole number of 16 bits.
    fn flags(&self, name: &str, rec: &csv::StringRecord, line: u64) -> Result<u16> {
        let Some(i) = self.flags_at else {
            return Ok(0);
        };
        let field = rec.get(i).unwrap_or("");
        field.parse::<u16>().map_err(|_| {
            anyhow::anyhow!(
                "{name}:{line}:{}: column 'flags': {} is not the instrument's flags (a whole number 0..65535)",
                i + 1,
                quote(field)
            )
        })
    }

    /// `row` after `rows`: time must increase, and a trace holds one
    /// frequency.
    fn check_order(&self, name: &str, row: &Row, rows: &[Row], kind: Kind) -> Result<()> {
        let line = row.line;
        if let (Some(prev), Some(i)) = (rows.last(), self.index[0]) {
            if row.time_s() <= prev.time_s() {
                bail!(
                    "{name}:{line}:{}: column 'time_s': {} does not increase (line {}: {})",
                    i + 1,
                    row.time_s(),
                    prev.line,
                    prev.time_s()
                );
            }
        }
        if kind == Kind::Trace {
            if let (Some(first), Some(i)) = (rows.first(), self.index[2]) {
                if row.freq_hz() != first.freq_hz() {
                    bail!(
                        "{name}:{line}:{}: column 'freq_hz': {} differs from {} (line {}); a trace holds one frequency",
                        i + 1,
                        row.freq_hz(),
                        first.freq_hz(),
                        first.line
                    );
                }
            }
        }
        Ok(())
    }
}

/// A data set: the calibration, the sweep if present, and the traces.
#[derive(Clone, Debug)]
pub struct DataSet {
    /// `calibration.csv`.
    pub calibration: Table,
    /// `sweep.csv`, if present.
    pub sweep: Option<Table>,
    /// `trace_*.csv`, sorted by file name.
    pub traces: Vec<Table>,
}

/// Read a data set folder.
pub fn read_dir(dir: &Path) -> Result<DataSet> {
    let cal = dir.join("calibration.csv");
    if !cal.exists() {
        bail!("{}: missing calibration.csv", dir.display());
    }
    let sweep_path = dir.join("sweep.csv");
    // There (as anything: a FIFO or a device is refused by the reader),
    // or not there at all.
    let has_sweep = sweep_path.symlink_metadata().is_ok();
    let mut names: Vec<PathBuf> = vec![];
    for entry in std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let path = entry
            .with_context(|| format!("{}: cannot list", dir.display()))?
            .path();
        let Some(n) = path.file_name().and_then(|n| n.to_str()) else {
            let shown = path
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned();
            if shown.to_lowercase().starts_with("trace_") {
                bail!("{}: '{shown}': a trace's name must be UTF-8 text", dir.display());
            }
            continue;
        };
        let lower = n.to_lowercase();
        if lower.starts_with("trace_") && lower.ends_with(".csv") {
            if !(n.starts_with("trace_") && n.ends_with(".csv")) {
                bail!(
                    "{}: '{n}': a trace is named trace_*.csv, in lower case (rename it, or it would be left out)",
                    dir.display()
                );
            }
            names.push(path);
        }
    }
    names.sort();
    // Every file's size before any is read: a data set's files together
    // hold at most MAX_DATASET_BYTES.
    let total: u64 = names
        .iter()
        .chain([&cal, &sweep_path])
        .filter_map(|p| p.metadata().ok())
        .map(|m| m.len())
        .sum();
    if total > MAX_DATASET_BYTES {
        bail!(
            "{}: its files hold {total} bytes together, more than the {MAX_DATASET_BYTES} a data set may have",
            dir.display()
        );
    }
    let calibration = read_table(&cal, Kind::Calibration)?;
    let sweep = match has_sweep {
        true => Some(read_table(&sweep_path, Kind::Sweep)?),
        false => None,
    };
    let traces = names
        .iter()
        .map(|p| read_table(p, Kind::Trace))
        .collect::<Result<Vec<_>>>()?;
    Ok(DataSet {
        calibration,
        sweep,
        traces,
    })
}
