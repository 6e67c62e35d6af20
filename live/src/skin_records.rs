//! The skin's `records.csv`: every board's records in one table, each
//! keyed by its board and sensor (and the sensor's name where the skin
//! gives one) and placed on one time axis, the host's UTC, through its
//! board's clock fit for its segment. Merged from the boards' own
//! `records.csv` in order of that time, a line at a time from each: its
//! memory does not grow with the session.
//!
//! The fit used is the one the session ended with (every arrival of the
//! segment in it). Records of a segment without a fit (a replay without
//! its arrivals; fewer than two reads) have no place on the axis: their
//! `t_utc_us` is empty and they follow the others, board by board.

use crate::boards::BoardDone;
use crate::clock::Line;
use crate::records_csv::HEADER;
use crate::skin::Skin;
use anyhow::{bail, Context, Result};
use std::collections::BinaryHeap;
use std::io::{BufRead, Write};
use std::path::Path;

/// The columns put before a board's own.
pub const KEY_COLUMNS: &str = "board,name,t_utc_us";

/// One board's file, read a line at a time.
struct Reader {
    board: usize,
    lines: std::io::Lines<std::io::BufReader<std::fs::File>>,
    path: std::path::PathBuf,
    line: usize,
    clocks: Vec<Option<Line>>,
    /// Its inputs' names in the skin.
    names: std::collections::BTreeMap<u8, String>,
}

/// A line waiting its turn: its time on the axis (none sorts last), its
/// board, the sensor's name, the line.
#[derive(PartialEq, Eq)]
struct Pending {
    t: Option<i64>,
    board: usize,
    name: String,
    text: String,
}

impl Ord for Pending {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // BinaryHeap is a max-heap: the earliest first, a missing time last.
        let key = |p: &Self| (p.t.is_none(), p.t, p.board);
        key(other).cmp(&key(self))
    }
}

impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Reader {
    fn open(board: usize, done: &BoardDone, skin: &Skin) -> Result<Self> {
        let path = done.dir.join(crate::RECORDS_CSV);
        let file = std::fs::File::open(&path).with_context(|| format!("reading {}", path.display()))?;
        let mut lines = std::io::BufReader::new(file).lines();
        let head = lines.next().transpose()?.unwrap_or_default();
        if head.trim() != HEADER.trim() {
            bail!("{}:1:1: not a records file (its header differs)", path.display());
        }
        Ok(Self {
            board,
            lines,
            path,
            line: 1,
            clocks: done.clocks.clone(),
            names: skin
                .sensors
                .iter()
                .filter(|s| s.board == done.board)
                .map(|s| (s.index, s.name.clone()))
                .collect(),
        })
    }

    /// The next line with its place on the axis.
    fn next(&mut self) -> Result<Option<Pending>> {
        let Some(text) = self.lines.next().transpose()? else {
            return Ok(None);
        };
        self.line += 1;
        let mut f = text.splitn(5, ',');
        let (segment, _seq, t_us, sensor) = (f.next(), f.next(), f.next(), f.next());
        let at = |col: usize, what: &str| format!("{}:{}:{col}: {what}", self.path.display(), self.line);
        let segment: usize = segment
            .and_then(|s| s.parse().ok())
            .with_context(|| at(1, "no segment number"))?;
        let t_us: u64 = t_us
            .and_then(|s| s.parse().ok())
            .with_context(|| at(3, "no time in µs"))?;
        let sensor: u8 = sensor
            .and_then(|s| s.parse().ok())
            .with_context(|| at(4, "no sensor index"))?;
        let line = segment
            .checked_sub(1)
            .and_then(|k| self.clocks.get(k).copied().flatten());
        let t = line.map(|l| (l.host_of(t_us as f64 * 1e-6) * 1e6).round() as i64);
        let name = self.names.get(&sensor).cloned().unwrap_or_default();
        Ok(Some(Pending {
            t,
            board: self.board,
            name,
            text,
        }))
    }
}

/// Merge the boards' records into `dir`'s `records.csv`; the lines
/// written.
pub fn merge(dir: &Path, skin: &Skin, done: &[BoardDone]) -> Result<u64> {
    let path = dir.join(crate::RECORDS_CSV);
    let file = std::fs::File::create(&path).with_context(|| format!("writing {}", path.display()))?;
    let mut out = std::io::BufWriter::new(file);
    write!(out, "{KEY_COLUMNS},{HEADER}")?;
    let mut readers = done
        .iter()
        .enumerate()
        .map(|(k, d)| Reader::open(k, d, skin))
        .collect::<Result<Vec<_>>>()?;
    let mut heap = BinaryHeap::new();
    for r in readers.iter_mut() {
        if let Some(p) = r.next()? {
            heap.push(p);
        }
    }
    let mut n = 0u64;
    while let Some(p) = heap.pop() {
        let t = p.t.map_or(String::new(), |t| t.to_string());
        let (board, name) = (quoted(&done[p.board].board), quoted(&p.name));
        writeln!(out, "{board},{name},{t},{}", p.text)?;
        n += 1;
        if let Some(next) = readers[p.board].next()? {
            heap.push(next);
        }
    }
    out.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(n)
}

/// `field` as a CSV field: quoted where it holds a comma, a quote or a
/// line break.
fn quoted(field: &str) -> std::borrow::Cow<'_, str> {
    match field.contains([',', '"', '\n', '\r']) {
        true => format!("\"{}\"", field.replace('"', "\"\"")).into(),
        false => field.into(),
    }
}
