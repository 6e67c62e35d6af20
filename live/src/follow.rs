//! Sources to sessions: a stream followed as it arrives, or a recorded
//! one replayed.

use crate::dashboard::Dashboard;
use crate::session::{Earlier, Finished, Session};
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
/// to its end, writing what arrived at least once a second.
pub fn replay_from(mut source: impl Read, sink: &mut Sink) -> Result<()> {
    let mut buf = vec![0u8; CHUNK];
    let mut last = Instant::now();
    loop {
        let n = match source.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e).context("reading the recorded stream"),
        };
        sink.push(&buf[..n])?;
        if last.elapsed() >= Duration::from_secs(1) {
            last = Instant::now();
            sink.flush()?;
        }
    }
    sink.flush()
}

/// Where bytes go: the session, and the records they complete to the
/// dashboard when there is one.
pub struct Sink<'a> {
    /// The session.
    pub session: &'a mut Session,
    /// The dashboard, if one is served.
    pub dashboard: Option<&'a Dashboard>,
}

impl Sink<'_> {
    /// Take `bytes` as they arrived.
    pub fn push(&mut self, bytes: &[u8]) -> Result<()> {
        self.session.push(bytes)?;
        if let Some(d) = self.dashboard {
            d.push(self.session.fresh());
            if let Some(status) = self.session.fresh_status() {
                d.status(&status);
            }
            d.availability(self.session.availability(), self.session.interpolated(), false);
            d.written(self.session.on_disk());
        }
        Ok(())
    }

    /// Write what arrived so far (see [`Session::flush`]).
    pub fn flush(&mut self) -> Result<()> {
        self.session.flush()?;
        if let Some(d) = self.dashboard {
            d.written(self.session.on_disk());
        }
        Ok(())
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
        sink.push(&buf[..n])?;
        if last.elapsed() >= Duration::from_secs(1) {
            last = Instant::now();
            sink.flush()?;
            eprintln!("{}", sink.session.summary().line());
        }
        if sink.session.end().is_some() {
            break Stopped::End;
        }
        if let Some(why) = sink.session.stopped() {
            break Stopped::Source(why.to_string());
        }
    };
    sink.flush()?;
    Ok(stopped)
}
