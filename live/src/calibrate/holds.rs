//! The holds: the stretches the skin was held at, and when (a CSV file
//! of `stretch_mm,from_s,to_s`).

use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// One hold: the skin at a known stretch for a span of the device's
/// clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Stretch held, mm.
    pub stretch_mm: f64,
    /// Start of the span, s since the device's start.
    pub from_s: f64,
    /// End of the span, s.
    pub to_s: f64,
}

/// The header of a holds file.
pub const HOLDS_HEADER: &str = "stretch_mm,from_s,to_s";

/// Read a holds file: CSV with the header [`HOLDS_HEADER`], one hold per
/// line. Errors name the file, line, column and reason; at least two
/// holds at different stretches, spans that do not overlap.
pub fn read_holds(path: &Path) -> Result<Vec<Hold>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_holds(&text).map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))
}

/// [`read_holds`] on text; errors start with `line:column: `.
pub fn parse_holds(text: &str) -> Result<Vec<Hold>> {
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == HOLDS_HEADER => {}
        _ => bail!("1:1: the header must be '{HOLDS_HEADER}'"),
    }
    let mut holds: Vec<Hold> = vec![];
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let mut v = [0.0f64; 3];
        let mut col = 1;
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 3 {
            bail!("{n}:1: {} fields, not 3 ({HOLDS_HEADER})", fields.len());
        }
        for (k, f) in fields.iter().enumerate() {
            v[k] = match f.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => bail!("{n}:{col}: '{}' is not a finite number", f.trim()),
            };
            col += f.len() + 1;
        }
        let h = Hold {
            stretch_mm: v[0],
            from_s: v[1],
            to_s: v[2],
        };
        if !(h.from_s >= 0.0 && h.to_s > h.from_s) {
            bail!("{n}:1: the span must start at 0 s or later and end after it starts");
        }
        if !(0.0..=1000.0).contains(&h.stretch_mm) {
            bail!("{n}:1: stretch {} mm is outside 0 … 1000 mm", h.stretch_mm);
        }
        if let Some(p) = holds.iter().find(|p| p.from_s < h.to_s && h.from_s < p.to_s) {
            bail!("{n}:1: its span overlaps the hold at {} mm", p.stretch_mm);
        }
        if holds.iter().any(|p| p.stretch_mm == h.stretch_mm) {
            bail!("{n}:1: a second hold at {} mm", h.stretch_mm);
        }
        holds.push(h);
    }
    if holds.len() < 2 {
        bail!(
            "{}:1: {} holds: a calibration needs two stretches at least",
            text.lines().count(),
            holds.len()
        );
    }
    Ok(holds)
}

/// Write a holds file (read back by [`read_holds`]).
pub fn write_holds(path: &Path, holds: &[Hold]) -> Result<()> {
    let mut s = format!("{HOLDS_HEADER}\n");
    for h in holds {
        writeln!(s, "{},{},{}", h.stretch_mm, h.from_s, h.to_s)?;
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
}
