//! Sources to sessions: a stream followed as it arrives, or a recorded
//! one replayed.

use crate::recorder::Sink;
use crate::session::{Earlier, Finished, Session, ARRIVALS_COLUMNS};
use anyhow::{Context, Result};
use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How many bytes a replay hands the session at once.
const CHUNK: usize = 64 << 10;

/// Replay a recorded stream's `bytes` into `dir` (a folder that holds
/// files already as `earlier` says), in pieces as a link would bring
/// them.
pub fn replay(bytes: &[u8], dir: &Path, earlier: Earlier) -> Result<Finished> {
    let mut s = Session::new(dir, earlier)?;
    for part in bytes.chunks(CHUNK) {
        s.push(part)?;
    }
    s.finish()
}

/// Replay a recorded stream read from `source` (a file) into `sink`,
/// to its end, writing what arrived at least once a second. With the
/// session's `arrivals` (its `arrivals.csv`), each record gets the time
/// it arrived at first, and the clock fit is the session's again.
pub fn replay_from(mut source: impl Read, sink: &mut Sink, arrivals: Option<Arrivals>) -> Result<()> {
    let mut buf = vec![0u8; CHUNK];
    let mut last = Instant::now();
    let mut arrivals = arrivals;
    let mut next = arrivals.as_mut().map(Arrivals::next).transpose()?.flatten();
    // The bytes of the read being rebuilt (up to its end's arrival),
    // pushed whole as the session took them.
    let mut read: Vec<u8> = vec![];
    let mut at = 0u64;
    loop {
        let n = match source.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e).context("reading the recorded stream"),
        };
        let mut part = &buf[..n];
        while !part.is_empty() {
            let Some((end, time)) = next else {
                sink.push_at(part, None)?;
                at += part.len() as u64;
                break;
            };
            let len = (end - at).min(part.len() as u64) as usize;
            read.extend_from_slice(&part[..len]);
            at += len as u64;
            part = &part[len..];
            if at == end || read.len() > READ_MAX {
                sink.push_at(&std::mem::take(&mut read), Some(time))?;
            }
            if at == end {
                next = arrivals.as_mut().map(Arrivals::next).transpose()?.flatten();
            }
        }
        if last.elapsed() >= Duration::from_secs(1) {
            last = Instant::now();
            sink.flush()?;
        }
    }
    if let Some((_, time)) = next.filter(|_| !read.is_empty()) {
        sink.push_at(&read, Some(time))?;
    }
    sink.flush()
}

/// The most bytes of one read a replay holds before it pushes them (a
/// read that long completed no records but at its end).
const READ_MAX: usize = 4 << 20;

/// A session's `arrivals.csv`, read a line at a time: (the stream's
/// length in bytes at a read's end, the host's UTC then in µs).
pub struct Arrivals {
    lines: std::io::Lines<std::io::BufReader<std::fs::File>>,
    path: std::path::PathBuf,
    line: usize,
    last: u64,
}

impl Arrivals {
    /// `path`, its header checked.
    pub fn open(path: &Path) -> Result<Self> {
        use std::io::BufRead;
        let file = std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
        let mut lines = std::io::BufReader::new(file).lines();
        let head = lines.next().transpose()?.unwrap_or_default();
        if head.trim() != ARRIVALS_COLUMNS {
            anyhow::bail!("{}:1:1: the header must be '{ARRIVALS_COLUMNS}'", path.display());
        }
        Ok(Self {
            lines,
            path: path.to_path_buf(),
            line: 1,
            last: 0,
        })
    }

    /// The next arrival; an error names the file, line and column.
    fn next(&mut self) -> Result<Option<(u64, i64)>> {
        let Some(text) = self.lines.next().transpose()? else {
            return Ok(None);
        };
        self.line += 1;
        let (n, p) = (self.line, self.path.display());
        let (bytes, utc) = text
            .split_once(',')
            .with_context(|| format!("{p}:{n}:1: two fields, {ARRIVALS_COLUMNS}"))?;
        let end: u64 = bytes
            .trim()
            .parse()
            .with_context(|| format!("{p}:{n}:1: '{bytes}' is not a byte count"))?;
        let col = bytes.len() + 2;
        let t: i64 = utc
            .trim()
            .parse()
            .with_context(|| format!("{p}:{n}:{col}: '{utc}' is not a time in µs"))?;
        if end <= self.last {
            anyhow::bail!(
                "{p}:{n}:1: {end} bytes is not after the line before's {}",
                self.last
            );
        }
        self.last = end;
        Ok(Some((end, t)))
    }
}

/// Why [`follow`] stopped reading.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Stopped {
    /// The stream's end frame arrived.
    End,
    /// The source ended: EOF, a closed socket, a port that vanished (why).
    Source(String),
    /// The user asked (`stop` was set: Ctrl-C).
    Asked,
}

/// Read `source` until it ends (EOF, a closed socket, a port that
/// vanished), the stream's end frame arrives or `stop` is set (checked at
/// least every read timeout), writing what arrived at least once a
/// second and printing the link's health each second.
pub fn follow(mut source: impl Read, sink: &mut Sink, stop: &AtomicBool) -> Result<Stopped> {
    let mut buf = vec![0u8; CHUNK];
    let mut last = Instant::now();
    let stopped = loop {
        if stop.load(Ordering::Relaxed) {
            break Stopped::Asked;
        }
        let n = match source.read(&mut buf) {
            Ok(0) => break Stopped::Source("end of the stream".into()),
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                0
            }
            Err(e) => break Stopped::Source(e.to_string()),
        };
        sink.push_at(&buf[..n], Some(chrono::Utc::now().timestamp_micros()))?;
        sink.take_marks();
        sink.take_commands()?;
        if last.elapsed() >= Duration::from_secs(1) {
            last = Instant::now();
            sink.flush()?;
            eprintln!("{}", sink.line());
        }
        if sink.ended() {
            break Stopped::End;
        }
        if let Some(why) = sink.session.as_ref().and_then(|s| s.stopped()) {
            break Stopped::Source(why.to_string());
        }
    };
    sink.flush()?;
    Ok(stopped)
}
