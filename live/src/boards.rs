//! One session, several boards: a skin too big for one board read as a
//! whole. Each board's source (a serial port, a TCP socket, a recorded
//! stream) is read in a thread of its own into its own recording, a
//! folder per board under the skin's (`<dataset>/<board>/`, the
//! single-board data set, unchanged); a port that goes away is opened
//! again until the session ends, and what the board sends after it
//! comes back goes on in the same recording (a restart of the device is
//! a new segment, as on one board). When the session ends the boards'
//! records are merged into the skin's `records.csv`, each keyed by board
//! and sensor and placed on one time axis, the host's UTC, through its
//! board's clock fit ([`crate::clock`]); `skin.json` is the skin's
//! manifest: each board's device, folder, how it ended, its clock (offset,
//! drift and their 1σ) and its records.

use crate::clock::Line;
use crate::dashboard::Dashboard;
use crate::recorder::Sink;
use crate::session::{Earlier, Session};
use crate::skin::Skin;
use crate::skin_view::SkinView;
use crate::{follow, Stopped};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// The skin's manifest.
pub const SKIN_JSON: &str = "skin.json";
/// The version of [`SKIN_JSON`]'s layout.
pub const SKIN_LAYOUT: u32 = 1;

/// Where one board's bytes come from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A TCP socket (QEMU's `-serial tcp:…`): `tcp:HOST:PORT`.
    Tcp(String),
    /// A serial port at a baud rate: `serial:PORT` or `serial:PORT@BAUD`.
    Serial(String, u32),
    /// A recorded stream, with its arrivals where they are beside it:
    /// `replay:PATH`.
    Replay(PathBuf),
}

/// A board of the skin and its source: `NAME=tcp:HOST:PORT`,
/// `NAME=serial:PORT[@BAUD]` or `NAME=replay:PATH`.
#[derive(Clone, Debug, PartialEq)]
pub struct BoardSource {
    /// The board's name in the skin's description.
    pub board: String,
    /// Where its bytes come from.
    pub source: Source,
}

impl std::str::FromStr for BoardSource {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (board, spec) = s.split_once('=').ok_or_else(|| {
            format!("'{s}': NAME=tcp:HOST:PORT, NAME=serial:PORT[@BAUD] or NAME=replay:PATH")
        })?;
        let (kind, at) = spec
            .split_once(':')
            .ok_or_else(|| format!("'{spec}': tcp:HOST:PORT, serial:PORT[@BAUD] or replay:PATH"))?;
        let source = match kind {
            "tcp" => Source::Tcp(at.to_string()),
            "serial" => match at.rsplit_once('@') {
                Some((port, baud)) => Source::Serial(
                    port.to_string(),
                    baud.parse()
                        .map_err(|_| format!("'{baud}': a baud rate in bits/s"))?,
                ),
                None => Source::Serial(at.to_string(), link::BOARD_BAUD),
            },
            "replay" => Source::Replay(PathBuf::from(at)),
            other => return Err(format!("'{other}': tcp, serial or replay")),
        };
        if board.is_empty() || at.is_empty() {
            return Err(format!("'{s}': a board's name and where it is"));
        }
        Ok(Self {
            board: board.to_string(),
            source,
        })
    }
}

/// What a board's recording came to.
#[derive(Clone, Debug)]
pub struct BoardDone {
    /// The board's name.
    pub board: String,
    /// Its recording's folder.
    pub dir: PathBuf,
    /// The device id each segment's start frame reported.
    pub devices: Vec<u32>,
    /// Each segment's clock fit, where it has one.
    pub clocks: Vec<Option<Line>>,
    /// Its summary line.
    pub summary: String,
    /// Its availability, a line per sensor.
    pub availability: Vec<String>,
    /// How it ended: complete, or why not.
    pub outcome: crate::Outcome,
    /// Records kept.
    pub records: u64,
    /// Opened again after it was lost, times.
    pub reconnects: u32,
}

/// The boards of `skin` each sources names: every name one of the
/// skin's boards, none twice; a board of the skin without a source is
/// said (its sensors will be missing), not refused.
pub fn check(skin: &Skin, sources: &[BoardSource]) -> Result<Vec<String>> {
    let boards = skin.boards();
    let mut said = vec![];
    for (k, s) in sources.iter().enumerate() {
        if !boards.contains(&s.board.as_str()) {
            bail!(
                "--source {}: skin '{}' has no board '{}' (its boards: {})",
                s.board,
                skin.name,
                s.board,
                boards.join(", ")
            );
        }
        if sources[..k].iter().any(|o| o.board == s.board) {
            bail!("--source {}: the board is given twice", s.board);
        }
    }
    for b in boards {
        if !sources.iter().any(|s| s.board == b) {
            said.push(format!(
                "board {b} of the skin has no --source: its sensors are missing"
            ));
        }
    }
    Ok(said)
}

/// Read every board of `sources` into its folder under `dir` until each
/// ends (its end frame, a recording's end, or `stop`); then the skin's
/// records and manifest. What each board came to, in `sources`' order.
pub fn read_all(
    dir: &Path,
    earlier: Earlier,
    skin: &Skin,
    sources: &[BoardSource],
    stop: &AtomicBool,
    dashboard: Option<&Dashboard>,
) -> Result<Vec<BoardDone>> {
    // Every folder checked before any source opens.
    let mut sessions = vec![];
    for s in sources {
        let mut session = Session::new(&dir.join(&s.board), earlier)?;
        session.set_skin(Arc::new(skin.on_board(Some(&s.board))?));
        sessions.push(session);
    }
    let epoch_s = chrono::Utc::now().timestamp_micros() as f64 * 1e-6;
    if let Some(d) = dashboard {
        let names: Vec<&str> = sources.iter().map(|s| s.board.as_str()).collect();
        d.skin_layout(crate::skin_view::layout_json(skin, &names));
    }
    let done = std::thread::scope(|scope| {
        let runs: Vec<_> = sources
            .iter()
            .zip(sessions)
            .map(|(s, session)| {
                let view = SkinView::new(skin, &s.board, epoch_s);
                scope.spawn(move || read_board(s, session, stop, dashboard.map(|d| (d, view))))
            })
            .collect();
        runs.into_iter()
            .map(|r| r.join().unwrap_or_else(|_| bail!("a board's reader panicked")))
            .collect::<Result<Vec<_>>>()
    })?;
    crate::skin_records::merge(dir, skin, &done)?;
    write_manifest(dir, skin, &done)?;
    Ok(done)
}

/// One board: its source read into `session` until it ends, opened again
/// while it is lost; the recording finished.
fn read_board(
    src: &BoardSource,
    session: Session,
    stop: &AtomicBool,
    shown: Option<(&Dashboard, SkinView)>,
) -> Result<BoardDone> {
    // The skin's names are the session's (set in read_all); the sink
    // starts no recordings of its own, so it needs none.
    let mut sink = Sink::new(Some(session), None);
    sink.label = Some(src.board.clone());
    if let Some((d, view)) = shown {
        sink.dashboard = Some(d);
        sink.view = Some(view);
    }
    let mut reconnects = 0;
    let stopped = match &src.source {
        Source::Replay(path) => {
            let file = std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
            let beside = path.with_file_name(crate::ARRIVALS_CSV);
            let arrivals = beside
                .is_file()
                .then(|| crate::Arrivals::open(&beside))
                .transpose()?;
            crate::replay_from(file, &mut sink, arrivals)?;
            None
        }
        live => loop {
            let Some(port) = open_until(&src.board, live, stop, reconnects > 0) else {
                break Some(Stopped::Asked);
            };
            match follow(port, &mut sink, stop)? {
                Stopped::Source(why) if !stop.load(Ordering::Relaxed) && session_runs(&sink) => {
                    eprintln!("board {}: lost ({why}); opening it again", src.board);
                    reconnects += 1;
                    if let Some(v) = &mut sink.view {
                        v.reconnects = reconnects;
                    }
                }
                other => break Some(other),
            }
        },
    };
    finish_board(src, sink, stopped, reconnects)
}

/// Whether the board's recording can take more (it has not stopped on
/// its own: a full disk, a size limit).
fn session_runs(sink: &Sink) -> bool {
    sink.session
        .as_ref()
        .is_some_and(|s| s.stopped().is_none() && s.end().is_none())
}

/// A port that reads and writes.
trait Port: std::io::Read + Send {}
impl<T: std::io::Read + Send> Port for T {}

/// `source` opened, tried once a second until it opens or `stop` is
/// set (None). The first failure is said; after a loss, so is the
/// success.
fn open_until(board: &str, source: &Source, stop: &AtomicBool, again: bool) -> Option<Box<dyn Port>> {
    let mut said = false;
    while !stop.load(Ordering::Relaxed) {
        match open(source) {
            Ok(port) => {
                if said || again {
                    eprintln!("board {board}: open");
                }
                return Some(port);
            }
            Err(e) if !said => {
                eprintln!("board {board}: {e:#}; trying again each second");
                said = true;
            }
            Err(_) => {}
        }
        std::thread::sleep(Duration::from_secs(1));
    }
    None
}

/// A live source opened (reads time out after 200 ms, so that `stop`
/// is seen).
fn open(source: &Source) -> Result<Box<dyn Port>> {
    let timeout = Duration::from_millis(200);
    match source {
        Source::Tcp(addr) => {
            let sock = std::net::TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
            sock.set_read_timeout(Some(timeout))?;
            Ok(Box::new(sock))
        }
        Source::Serial(name, baud) => Ok(Box::new(
            serialport::new(name, *baud)
                .timeout(timeout)
                .open()
                .with_context(|| format!("opening the serial port {name}"))?,
        )),
        Source::Replay(_) => bail!("a recorded stream is replayed, not opened"),
    }
}

/// The board's recording finished: what it came to.
fn finish_board(
    src: &BoardSource,
    mut sink: Sink,
    stopped: Option<Stopped>,
    reconnects: u32,
) -> Result<BoardDone> {
    let Some(mut session) = sink.session.take() else {
        bail!("board {}: its recording is gone", src.board);
    };
    if stopped == Some(Stopped::Asked) {
        session.ask_stop();
    }
    if let (Some(d), Some(v)) = (sink.dashboard, &mut sink.view) {
        v.show(d, &session, true);
    }
    let devices = session.segments().iter().map(|g| g.start.device_id).collect();
    let clocks = session.segments().iter().map(|g| g.clock.line()).collect();
    let records = session.segments().iter().map(|g| g.records).sum();
    let dir = session.dir().to_path_buf();
    let finished = session.finish()?;
    Ok(BoardDone {
        board: src.board.clone(),
        dir,
        devices,
        clocks,
        summary: finished.summary.line(),
        availability: finished.summary.availability_lines(),
        outcome: finished.outcome,
        records,
        reconnects,
    })
}

/// The skin's manifest: its boards, each with its folder, devices,
/// clock fits, records and how it ended.
fn write_manifest(dir: &Path, skin: &Skin, done: &[BoardDone]) -> Result<()> {
    use serde_json::json;
    let boards: Vec<_> = done
        .iter()
        .map(|b| {
            json!({
                "board": b.board,
                "folder": b.dir.file_name().map(|n| n.to_string_lossy().into_owned()),
                "devices": b.devices.iter().map(|d| format!("{d:#010x}")).collect::<Vec<_>>(),
                "clock": b.clocks.iter().map(|c| c.map(|l| l.json())).collect::<Vec<_>>(),
                "records": b.records,
                "reconnects": b.reconnects,
                "complete": matches!(b.outcome, crate::Outcome::Complete),
                "summary": b.summary,
            })
        })
        .collect();
    let manifest = json!({
        "layout": SKIN_LAYOUT,
        "skin": skin.name,
        "axis": "t_utc_us: the host's UTC, µs, through each board's clock fit",
        "boards": boards,
    });
    let path = dir.join(SKIN_JSON);
    std::fs::write(&path, serde_json::to_string_pretty(&manifest)? + "\n")
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_parse_or_say_why_not() {
        let s: BoardSource = "A=tcp:127.0.0.1:4000".parse().unwrap();
        assert_eq!(s.source, Source::Tcp("127.0.0.1:4000".into()));
        let s: BoardSource = "hand=serial:/dev/ttyACM0@115200".parse().unwrap();
        assert_eq!(s.source, Source::Serial("/dev/ttyACM0".into(), 115_200));
        let s: BoardSource = "B=serial:/dev/ttyACM1".parse().unwrap();
        assert_eq!(s.source, Source::Serial("/dev/ttyACM1".into(), link::BOARD_BAUD));
        let s: BoardSource = "C=replay:out/a/stream.bin".parse().unwrap();
        assert_eq!(s.source, Source::Replay("out/a/stream.bin".into()));
        for bad in ["A", "A=usb:x", "=tcp:x:1", "A=tcp:", "A=serial:p@fast"] {
            assert!(bad.parse::<BoardSource>().is_err(), "{bad}");
        }
    }
}
