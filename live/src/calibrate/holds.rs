//! The holds: the stretches the skin was held at, and when. A CSV file
//! of `stretch_mm,from_s,to_s` (one stretch for every sensor), or of
//! `sensor,stretch_mm,from_s,to_s`: each sensor its own stretch (a glove,
//! a skin on a curved body), `sensor` its index, or with a skin's
//! description its name or a group's name (every sensor of the group).

use crate::skin::Board;
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
    /// The sensor it is of (None: every sensor).
    pub sensor: Option<u8>,
}

/// The header of a holds file of one stretch for every sensor.
pub const HOLDS_HEADER: &str = "stretch_mm,from_s,to_s";
/// The header of a holds file of each sensor's own stretches.
pub const SENSOR_HOLDS_HEADER: &str = "sensor,stretch_mm,from_s,to_s";

/// Read a holds file: CSV with the header [`HOLDS_HEADER`] or
/// [`SENSOR_HOLDS_HEADER`], one hold per line (`skin`: the names and
/// groups a `sensor` may give). Errors name the file, line, column and
/// reason; at least two holds at different stretches for each sensor,
/// spans of a sensor that do not overlap.
pub fn read_holds(path: &Path, skin: Option<&Board>) -> Result<Vec<Hold>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_holds(&text, skin).map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))
}

/// The holds of sensor `s`: its own and those of every sensor.
pub fn for_sensor(holds: &[Hold], s: u8) -> Vec<Hold> {
    holds
        .iter()
        .filter(|h| h.sensor.is_none_or(|x| x == s))
        .copied()
        .collect()
}

/// The sensors a `sensor` field names: an index, or with `skin` a
/// sensor's name or a group's.
fn sensors_of(field: &str, skin: Option<&Board>) -> Result<Vec<u8>, String> {
    if let Ok(i) = field.parse::<u8>() {
        return Ok(vec![i]);
    }
    let Some(skin) = skin else {
        return Err(format!(
            "'{field}' is not a sensor's index (0 … 255); a name or a group needs --skin"
        ));
    };
    if let Some(s) = skin.sensors.iter().find(|s| s.name == field) {
        return Ok(vec![s.index]);
    }
    let group: Vec<u8> = skin
        .sensors
        .iter()
        .filter(|s| s.group.as_deref() == Some(field))
        .map(|s| s.index)
        .collect();
    match group.is_empty() {
        true => Err(format!(
            "'{field}' is no sensor's index, name or group in skin '{}'",
            skin.skin
        )),
        false => Ok(group),
    }
}

/// [`read_holds`] on text; errors start with `line:column: `.
pub fn parse_holds(text: &str, skin: Option<&Board>) -> Result<Vec<Hold>> {
    let mut lines = text.lines().enumerate();
    let per_sensor = match lines.next() {
        Some((_, h)) if h.trim() == HOLDS_HEADER => false,
        Some((_, h)) if h.trim() == SENSOR_HOLDS_HEADER => true,
        _ => bail!("1:1: the header must be '{HOLDS_HEADER}' or '{SENSOR_HOLDS_HEADER}'"),
    };
    let header = if per_sensor {
        SENSOR_HOLDS_HEADER
    } else {
        HOLDS_HEADER
    };
    let width = if per_sensor { 4 } else { 3 };
    let mut holds: Vec<Hold> = vec![];
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != width {
            bail!("{n}:1: {} fields, not {width} ({header})", fields.len());
        }
        let (sensors, numbers, mut col) = match per_sensor {
            true => match sensors_of(fields[0].trim(), skin) {
                Ok(s) => (
                    s.into_iter().map(Some).collect(),
                    &fields[1..],
                    fields[0].len() + 2,
                ),
                Err(why) => bail!("{n}:1: {why}"),
            },
            false => (vec![None], &fields[..], 1),
        };
        let mut v = [0.0f64; 3];
        for (k, f) in numbers.iter().enumerate() {
            v[k] = match f.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => bail!("{n}:{col}: '{}' is not a finite number", f.trim()),
            };
            col += f.len() + 1;
        }
        for sensor in sensors {
            let h = Hold {
                stretch_mm: v[0],
                from_s: v[1],
                to_s: v[2],
                sensor,
            };
            check_one(&holds, &h).map_err(|why| anyhow::anyhow!("{n}:1: {why}"))?;
            holds.push(h);
        }
    }
    let last = text.lines().count();
    let mut named: Vec<Option<u8>> = holds.iter().map(|h| h.sensor).collect();
    named.sort_unstable();
    named.dedup();
    for s in named {
        let k = holds
            .iter()
            .filter(|h| h.sensor == s || h.sensor.is_none())
            .count();
        if k < 2 {
            match s {
                None => bail!("{last}:1: {k} holds: a calibration needs two stretches at least"),
                Some(s) => {
                    bail!("{last}:1: sensor {s} has {k} hold: a calibration needs two stretches at least")
                }
            }
        }
    }
    Ok(holds)
}

/// Whether hold `h` can join `holds`: its span and stretch sound, and
/// for the sensors it is of, no overlap and no second hold at its
/// stretch.
fn check_one(holds: &[Hold], h: &Hold) -> Result<(), String> {
    if !(h.from_s >= 0.0 && h.to_s > h.from_s) {
        return Err("the span must start at 0 s or later and end after it starts".into());
    }
    if !(0.0..=1000.0).contains(&h.stretch_mm) {
        return Err(format!("stretch {} mm is outside 0 … 1000 mm", h.stretch_mm));
    }
    let shared = |p: &&Hold| p.sensor.is_none() || h.sensor.is_none() || p.sensor == h.sensor;
    let whose = |p: &Hold| p.sensor.map_or(String::new(), |s| format!(" of sensor {s}"));
    if let Some(p) = holds
        .iter()
        .filter(shared)
        .find(|p| p.from_s < h.to_s && h.from_s < p.to_s)
    {
        return Err(format!(
            "its span overlaps the hold{} at {} mm",
            whose(p),
            p.stretch_mm
        ));
    }
    if let Some(p) = holds.iter().filter(shared).find(|p| p.stretch_mm == h.stretch_mm) {
        return Err(format!("a second hold{} at {} mm", whose(p), p.stretch_mm));
    }
    Ok(())
}

/// Write a holds file (read back by [`read_holds`]): each sensor's own
/// where any hold is of one sensor.
pub fn write_holds(path: &Path, holds: &[Hold]) -> Result<()> {
    let per_sensor = holds.iter().any(|h| h.sensor.is_some());
    let mut s = format!(
        "{}\n",
        if per_sensor {
            SENSOR_HOLDS_HEADER
        } else {
            HOLDS_HEADER
        }
    );
    for h in holds {
        if per_sensor {
            match h.sensor {
                Some(i) => write!(s, "{i},")?,
                None => bail!("a hold of every sensor beside holds of one: write each sensor's"),
            }
        }
        writeln!(s, "{},{},{}", h.stretch_mm, h.from_s, h.to_s)?;
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
}
