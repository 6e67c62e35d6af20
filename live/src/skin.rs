//! A skin's description (TOML): each sensor's name, the board it is on
//! and its index there, its group (finger, palm…), and its place and
//! outline on the skin's 2-D layout. Read whole and checked before a
//! session starts; every error names the file, line and column. A
//! session keeps the names in its manifest and its feed, and names the
//! sensors a device reports that the skin does not, and those it names
//! that the device does not have.
//!
//! ```toml
//! [skin]
//! name = "left hand"
//! units = "mm"            # of the layout (default mm)
//! picture = "hand.svg"    # optional: a drawing the layout is on
//!
//! [[sensor]]
//! name = "index-1"
//! board = "A"             # optional where the skin has one board
//! index = 0               # its input on the board
//! group = "index finger"  # optional
//! place = [12.0, 40.0]    # its centre on the layout
//! outline = [[10, 35], [14, 35], [14, 45], [10, 45]]   # optional
//!
//! [[board]]                # optional: the device id a board reports
//! name = "A"               # (its start frame); left out for one board
//! device = 0x1A2B3C4D
//! ```

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::Path;
use toml::Spanned;

/// The longest name a sensor may have, in characters.
pub const NAME_MAX: usize = 40;

/// A skin, as its file describes it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Skin {
    /// Its name.
    pub name: String,
    /// The layout's unit.
    pub units: String,
    /// A drawing the layout is on, if one.
    pub picture: Option<String>,
    /// Its sensors, in the file's order.
    pub sensors: Vec<Sensor>,
    /// The device id each board reports, where the file gives it: (the
    /// board's name, "" for a skin of one board; the id).
    pub devices: Vec<(String, u32)>,
}

/// One sensor of a skin.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sensor {
    /// Its name, unique in the skin.
    pub name: String,
    /// The board it is on ("" where the skin has one board).
    pub board: String,
    /// Its input on the board.
    pub index: u8,
    /// Its group, if one.
    pub group: Option<String>,
    /// Its centre on the layout.
    pub place: [f64; 2],
    /// Its outline on the layout (none: a point).
    pub outline: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileIn {
    skin: HeadIn,
    #[serde(default, rename = "sensor")]
    sensors: Vec<SensorIn>,
    #[serde(default, rename = "board")]
    boards: Vec<BoardIn>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoardIn {
    #[serde(default)]
    name: Option<Spanned<String>>,
    device: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HeadIn {
    name: Spanned<String>,
    #[serde(default)]
    units: Option<String>,
    #[serde(default)]
    picture: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorIn {
    name: Spanned<String>,
    #[serde(default)]
    board: Option<Spanned<String>>,
    index: Spanned<i64>,
    #[serde(default)]
    group: Option<Spanned<String>>,
    place: Spanned<Vec<f64>>,
    #[serde(default)]
    outline: Option<Spanned<Vec<Vec<f64>>>>,
}

/// Line and column (1-based) of byte `at` in `text`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Read the skin of `path`.
pub fn read(path: &Path) -> Result<Skin> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// The skin of `text` (the file `file`): checked whole; the first error
/// as `file:line:column: reason`.
pub fn parse(text: &str, file: &str) -> Result<Skin> {
    let at = |span: std::ops::Range<usize>, why: String| {
        let (l, c) = line_col(text, span.start);
        anyhow::anyhow!("{file}:{l}:{c}: {why}")
    };
    let raw: FileIn = toml::from_str(text).map_err(|e| {
        let (l, c) = e.span().map_or((1, 1), |s| line_col(text, s.start));
        anyhow::anyhow!("{file}:{l}:{c}: {}", e.message())
    })?;
    if raw.skin.name.get_ref().trim().is_empty() {
        return Err(at(raw.skin.name.span(), "the skin needs a name".into()));
    }
    if raw.sensors.is_empty() {
        bail!("{file}: no [[sensor]]: a skin names at least one sensor");
    }
    let mut out: Vec<Sensor> = Vec::with_capacity(raw.sensors.len());
    for s in &raw.sensors {
        let sensor = one(s, &at)?;
        if let Some(o) = out.iter().find(|o| o.name == sensor.name) {
            return Err(at(
                s.name.span(),
                format!(
                    "'{}' names two sensors (board {:?} index {} too)",
                    o.name, o.board, o.index
                ),
            ));
        }
        if let Some(o) = out
            .iter()
            .find(|o| o.board == sensor.board && o.index == sensor.index)
        {
            return Err(at(
                s.index.span(),
                format!("index {} of board {:?} is '{}' already", o.index, o.board, o.name),
            ));
        }
        out.push(sensor);
    }
    let boards: Vec<&str> = out.iter().map(|s| s.board.as_str()).collect();
    if boards.contains(&"") && boards.iter().any(|b| !b.is_empty()) {
        bail!("{file}: some sensors name their board and some do not: name every sensor's board, or none (one board)");
    }
    let devices = devices(&raw.boards, &boards, &at)?;
    Ok(Skin {
        name: raw.skin.name.into_inner(),
        units: raw.skin.units.unwrap_or_else(|| "mm".into()),
        picture: raw.skin.picture,
        sensors: out,
        devices,
    })
}

/// The `[[board]]` entries, checked: each a board the sensors name (no
/// name: the skin's only board), once; its device id a u32 no other
/// board has.
fn devices(
    raw: &[BoardIn],
    named: &[&str],
    at: &dyn Fn(std::ops::Range<usize>, String) -> anyhow::Error,
) -> Result<Vec<(String, u32)>> {
    let mut out: Vec<(String, u32)> = vec![];
    for b in raw {
        let (name, span) = match &b.name {
            Some(n) => (n.get_ref().trim().to_string(), n.span()),
            None => (String::new(), b.device.span()),
        };
        if !named.contains(&name.as_str()) {
            let why = match name.is_empty() {
                true => "a [[board]] without a name, in a skin of several boards: name it".to_string(),
                false => format!("board '{name}' has no sensor"),
            };
            return Err(at(span, why));
        }
        let Ok(device) = u32::try_from(*b.device.get_ref()) else {
            return Err(at(
                b.device.span(),
                "device: a device id is 0 to 0xFFFFFFFF".into(),
            ));
        };
        if let Some((o, _)) = out.iter().find(|(o, d)| *o == name || *d == device) {
            return Err(at(
                span,
                format!("board {name:?}: board {o:?} has this entry or this device id already"),
            ));
        }
        out.push((name, device));
    }
    Ok(out)
}

/// One sensor of the file, checked.
fn one(s: &SensorIn, at: &dyn Fn(std::ops::Range<usize>, String) -> anyhow::Error) -> Result<Sensor> {
    let name = s.name.get_ref().trim().to_string();
    let bad_char = name.chars().find(|c| c.is_control() || matches!(c, ',' | '"'));
    if name.is_empty() || name.chars().count() > NAME_MAX || bad_char.is_some() {
        return Err(at(
            s.name.span(),
            format!("a sensor's name: 1 to {NAME_MAX} characters, no comma, quote or control character"),
        ));
    }
    let index = *s.index.get_ref();
    let Ok(index) = u8::try_from(index) else {
        return Err(at(
            s.index.span(),
            format!("index {index}: a board's inputs are 0 to 255"),
        ));
    };
    let point = |v: &[f64]| match v {
        [x, y] if x.is_finite() && y.is_finite() => Some([*x, *y]),
        _ => None,
    };
    let Some(place) = point(s.place.get_ref()) else {
        return Err(at(s.place.span(), "place: [x, y], two finite numbers".into()));
    };
    let outline = match &s.outline {
        None => vec![],
        Some(o) => {
            let pts: Option<Vec<[f64; 2]>> = o.get_ref().iter().map(|p| point(p)).collect();
            match pts {
                Some(p) if p.len() >= 3 => p,
                _ => return Err(at(o.span(), "outline: three or more points [x, y]".into())),
            }
        }
    };
    let group = match &s.group {
        Some(g) if g.get_ref().trim().is_empty() => {
            return Err(at(g.span(), "an empty group: leave it out".into()))
        }
        g => g.as_ref().map(|g| g.get_ref().trim().to_string()),
    };
    Ok(Sensor {
        name,
        board: s
            .board
            .as_ref()
            .map_or(String::new(), |b| b.get_ref().trim().to_string()),
        index,
        group,
        place,
        outline,
    })
}

impl Skin {
    /// The boards it names ("" for a skin of one board), in order.
    pub fn boards(&self) -> Vec<&str> {
        let mut b: Vec<&str> = vec![];
        for s in &self.sensors {
            if !b.contains(&s.board.as_str()) {
                b.push(&s.board);
            }
        }
        b
    }

    /// The sensors of `board` (None: the skin's only board); an error
    /// where the skin has several and none is chosen, or no such board.
    pub fn on_board(&self, board: Option<&str>) -> Result<Board> {
        let boards = self.boards();
        let chosen = match board {
            Some(b) if boards.contains(&b) => b.to_string(),
            Some(b) => bail!(
                "skin '{}' has no board '{b}' (its boards: {})",
                self.name,
                boards.join(", ")
            ),
            None if boards.len() == 1 => boards[0].to_string(),
            None => bail!(
                "skin '{}' is on {} boards ({}): say which this device is with --board",
                self.name,
                boards.len(),
                boards.join(", ")
            ),
        };
        Ok(Board {
            device: self.devices.iter().find(|(b, _)| *b == chosen).map(|&(_, d)| d),
            skin: self.name.clone(),
            sensors: self
                .sensors
                .iter()
                .filter(|s| s.board == chosen)
                .cloned()
                .collect(),
            board: chosen,
        })
    }
}

/// The sensors of a skin on one board.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Board {
    /// The skin's name.
    pub skin: String,
    /// The board's name ("" for a skin of one board).
    pub board: String,
    /// The device id it reports, where the skin gives it.
    pub device: Option<u32>,
    /// Its sensors.
    pub sensors: Vec<Sensor>,
}

impl Board {
    /// The name of input `index`, if the skin names it.
    pub fn name_of(&self, index: u8) -> Option<&str> {
        self.sensors
            .iter()
            .find(|s| s.index == index)
            .map(|s| s.name.as_str())
    }

    /// Against a device that reports `count` sensors: the skin's sensors
    /// it does not have (named, with their index), and its inputs the
    /// skin does not name.
    pub fn check(&self, count: u8) -> (Vec<String>, Vec<u8>) {
        let missing = self
            .sensors
            .iter()
            .filter(|s| s.index >= count)
            .map(|s| format!("'{}' (index {})", s.name, s.index))
            .collect();
        let unnamed = (0..count).filter(|&i| self.name_of(i).is_none()).collect();
        (missing, unnamed)
    }

    /// What to say of device `device_id` reporting `count` sensors, a
    /// line each.
    pub fn mismatch(&self, count: u8, device_id: u32) -> Vec<String> {
        let (missing, unnamed) = self.check(count);
        let mut out = vec![];
        if let Some(want) = self.device.filter(|&d| d != device_id) {
            out.push(format!(
                "skin '{}': board {:?} is device {want:#010x}, this device is {device_id:#010x}",
                self.skin, self.board
            ));
        }
        if !missing.is_empty() {
            out.push(format!(
                "skin '{}': {} beyond the {count} sensors the device reports",
                self.skin,
                missing.join(", ")
            ));
        }
        if !unnamed.is_empty() {
            let list: Vec<String> = unnamed.iter().map(u8::to_string).collect();
            out.push(format!(
                "skin '{}': the device's sensors {} are not in the skin",
                self.skin,
                list.join(", ")
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HAND: &str = r#"
[skin]
name = "left hand"

[[sensor]]
name = "index-1"
index = 0
group = "index finger"
place = [12.0, 40.0]
outline = [[10, 35], [14, 35], [14, 45], [10, 45]]

[[sensor]]
name = "palm"
index = 3
place = [30, 10]
"#;

    #[test]
    fn a_skin_reads_whole_and_names_what_a_device_lacks_or_adds() {
        let skin = parse(HAND, "hand.toml").unwrap();
        assert_eq!(skin.units, "mm");
        assert_eq!(skin.sensors[0].outline.len(), 4);
        assert_eq!(skin.sensors[1].place, [30.0, 10.0]);
        let b = skin.on_board(None).unwrap();
        assert_eq!(b.name_of(3), Some("palm"));
        assert_eq!(b.check(2), (vec!["'palm' (index 3)".to_string()], vec![1]));
        assert_eq!(b.check(4), (vec![], vec![1, 2]));
        assert_eq!(
            b.mismatch(4, 0),
            vec!["skin 'left hand': the device's sensors 1, 2 are not in the skin"]
        );
    }

    #[test]
    fn each_board_is_named_by_the_device_id_it_reports() {
        let two = format!(
            "{}\n[[board]]\nname = \"A\"\ndevice = 0x1A2B3C4D\n\n[[board]]\nname = \"B\"\ndevice = 7\n",
            HAND.replace("index = 0\n", "index = 0\nboard = \"A\"\n")
                .replace("index = 3\n", "index = 3\nboard = \"B\"\n")
        );
        let skin = parse(&two, "two.toml").unwrap();
        assert_eq!(
            skin.devices,
            vec![("A".to_string(), 0x1A2B_3C4D), ("B".to_string(), 7)]
        );
        let a = skin.on_board(Some("A")).unwrap();
        assert_eq!(a.device, Some(0x1A2B_3C4D));
        assert!(a.mismatch(1, 0x1A2B_3C4D).is_empty());
        assert_eq!(
            a.mismatch(1, 7),
            vec!["skin 'left hand': board \"A\" is device 0x1a2b3c4d, this device is 0x00000007"]
        );
        let e = |t: &str| format!("{:#}", parse(t, "s.toml").unwrap_err());
        let unknown = two.replace("name = \"B\"\ndevice", "name = \"C\"\ndevice");
        assert!(e(&unknown).contains("board 'C' has no sensor"), "{}", e(&unknown));
        let again = two.replace("device = 7", "device = 0x1A2B3C4D");
        assert!(e(&again).contains("this device id already"), "{}", e(&again));
        let big = two.replace("device = 7", "device = 0x100000000");
        assert!(e(&big).contains("0 to 0xFFFFFFFF"), "{}", e(&big));
        let nameless = two.replace("name = \"B\"\ndevice", "device");
        assert!(e(&nameless).contains("without a name"), "{}", e(&nameless));
        // One board: its entry needs no name.
        let one = parse(&format!("{HAND}\n[[board]]\ndevice = 5\n"), "one.toml").unwrap();
        assert_eq!(one.on_board(None).unwrap().device, Some(5));
    }

    /// `text`'s error, as a user reads it.
    fn error(text: &str) -> String {
        format!("{:#}", parse(text, "s.toml").unwrap_err())
    }

    #[test]
    fn every_error_names_its_line_and_column() {
        let two = HAND.replace("name = \"palm\"", "name = \"index-1\"");
        assert!(
            error(&two).starts_with("s.toml:13:8: 'index-1' names two sensors"),
            "{}",
            error(&two)
        );
        let same = HAND.replace("index = 3", "index = 0");
        assert!(
            error(&same).starts_with("s.toml:14:9: index 0 of board \"\" is 'index-1' already"),
            "{}",
            error(&same)
        );
        let far = HAND.replace("index = 3", "index = 300");
        assert!(
            error(&far).starts_with("s.toml:14:9: index 300"),
            "{}",
            error(&far)
        );
        let place = HAND.replace("place = [30, 10]", "place = [30]");
        assert!(
            error(&place).starts_with("s.toml:15:9: place: [x, y]"),
            "{}",
            error(&place)
        );
        let outline = HAND.replace("[[10, 35], [14, 35], [14, 45], [10, 45]]", "[[10, 35], [14, 35]]");
        assert!(
            error(&outline).starts_with("s.toml:10:11: outline"),
            "{}",
            error(&outline)
        );
        let comma = HAND.replace("\"palm\"", "\"palm, left\"");
        assert!(error(&comma).contains("no comma"), "{}", error(&comma));
        let unknown = HAND.replace("place = [30, 10]", "place = [30, 10]\ncolour = 3");
        assert!(
            error(&unknown).starts_with("s.toml:16:1: unknown field `colour`"),
            "{}",
            error(&unknown)
        );
        let syntax = HAND.replace("index = 3", "index = ");
        assert!(error(&syntax).starts_with("s.toml:14:"), "{}", error(&syntax));
    }

    #[test]
    fn a_skin_on_several_boards_needs_one_chosen() {
        let two = HAND
            .replace("index = 0\n", "board = \"A\"\nindex = 0\n")
            .replace("index = 3\n", "board = \"B\"\nindex = 3\n");
        let skin = parse(&two, "s.toml").unwrap();
        assert_eq!(skin.boards(), vec!["A", "B"]);
        assert!(format!("{:#}", skin.on_board(None).unwrap_err()).contains("--board"));
        assert_eq!(skin.on_board(Some("B")).unwrap().sensors.len(), 1);
        assert!(format!("{:#}", skin.on_board(Some("C")).unwrap_err()).contains("no board 'C'"));
        let mixed = HAND.replace("index = 0\n", "board = \"A\"\nindex = 0\n");
        assert!(error(&mixed).contains("name every sensor's board, or none"));
    }
}
