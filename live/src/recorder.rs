//! Where a link's bytes go: the recording running (a [`Session`]
//! writing its folder), the dashboard, and a watch over the link that
//! lasts as long as `live` does. Recordings start and stop on request
//! (`live`'s standard input, the dashboard) while the device runs on: a
//! recording started mid-run begins at the next frame, with the run's
//! start frame written again before it ([`Session::join`]).

use crate::dashboard::Dashboard;
use crate::markers::Mark;
use crate::session::{Arrived, Earlier, Finished, Session};
use anyhow::Result;
use link::{Body, Decoder, Start};
use std::path::PathBuf;
use std::sync::mpsc::Receiver;

/// A request to the recordings, and where to say how it went.
#[derive(Debug)]
pub enum Command {
    /// Start a recording (into this folder, or the next of [`Folders`]).
    Start(Option<PathBuf>, Option<Reply>),
    /// Stop the recording running: its set written, complete.
    Stop(Option<Reply>),
}

/// Told the folder of the recording started or stopped, or why not.
pub type Reply = tokio::sync::oneshot::Sender<Result<PathBuf, String>>;

/// Where recordings go: the first into `first`, each later one into
/// `first-2`, `first-3`, … (the first free), unless its start names one.
#[derive(Clone, Debug)]
pub struct Folders {
    /// The first recording's folder.
    pub first: PathBuf,
    /// What a recording does with a folder that holds files.
    pub earlier: Earlier,
    /// Recordings started so far.
    started: u32,
}

impl Folders {
    /// Recordings into `first`, then beside it.
    pub fn new(first: PathBuf, earlier: Earlier) -> Self {
        Self {
            first,
            earlier,
            started: 0,
        }
    }

    /// The next recording's folder.
    pub fn take_next(&mut self) -> PathBuf {
        self.started += 1;
        if self.started == 1 {
            return self.first.clone();
        }
        let name = self
            .first
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        (self.started..)
            .map(|k| self.first.with_file_name(format!("{name}-{k}")))
            .find(|p| !p.exists())
            .unwrap_or_else(|| self.first.clone())
    }
}

/// The link as `live` sees it whatever records: the run's start frame,
/// the last frame's number, whether the bytes so far end at a frame's
/// end, and whether the device's end frame came.
#[derive(Default)]
struct Watch {
    decoder: Decoder,
    start: Option<Start>,
    /// The run's segment (a start frame each), as records.csv counts.
    segment: u32,
    last_seq: u32,
    boundary: bool,
    ended: bool,
}

impl Watch {
    /// Take `bytes`; the records they complete where `keep` asks (for
    /// the dashboard while nothing records: a recording gives its own).
    fn push(&mut self, bytes: &[u8], host_utc_us: Option<i64>, keep: bool) -> Vec<Arrived> {
        let mut out = vec![];
        let mut rest = bytes;
        while let Some(got) = self.decoder.next_frame(&mut rest) {
            let Ok(frame) = got else { continue };
            match frame.body {
                Body::Start(s) => {
                    self.start = Some(s);
                    self.segment += 1;
                    self.ended = false;
                }
                Body::End(_) => self.ended = true,
                // A recording started from here on starts with the set
                // now in force.
                Body::Applied(a) => {
                    if let Some(s) = &mut self.start {
                        s.generation = a.generation;
                        s.settings_digest = a.settings_digest;
                        s.calibration_digest = a.calibration_digest;
                    }
                }
                Body::Record(record) if keep => out.push(Arrived {
                    segment: self.segment,
                    seq: frame.seq,
                    host_utc_us,
                    record,
                }),
                _ => {}
            }
            self.last_seq = frame.seq;
        }
        if let Some(&b) = bytes.last() {
            self.boundary = b == 0;
        }
        out
    }
}

/// Where bytes go: the recording running, the dashboard, and the link's
/// watch.
pub struct Sink<'a> {
    /// The recording running, if one.
    pub session: Option<Session>,
    /// The dashboard, if one is served.
    pub dashboard: Option<&'a Dashboard>,
    /// Markers asked for (from `live`'s standard input, the dashboard).
    pub marks: Option<&'a Receiver<Mark>>,
    /// Recordings started and stopped on request.
    pub commands: Option<&'a Receiver<Command>>,
    /// Where recordings go.
    pub folders: Option<Folders>,
    /// The recordings that ended, each with its folder.
    pub finished: Vec<(PathBuf, Finished)>,
    /// The skin's sensors on this board, given to each recording.
    pub skin: Option<std::sync::Arc<crate::skin::Board>>,
    /// The board's name where a session reads several: its health
    /// lines carry it.
    pub label: Option<String>,
    /// Where the board is one of a skin's several: its side of the
    /// skin's dashboard (records shown on the skin's numbers and axis).
    pub view: Option<crate::skin_view::SkinView>,
    watch: Watch,
    /// A start asked for: it begins at the next frame.
    starting: Option<(PathBuf, Option<Reply>)>,
}

impl<'a> Sink<'a> {
    /// Bytes into `session` (none: nothing records until asked), the
    /// dashboard where there is one.
    pub fn new(session: Option<Session>, dashboard: Option<&'a Dashboard>) -> Self {
        if let (Some(d), Some(s)) = (dashboard, &session) {
            d.recording(Some(s.dir()));
        }
        Self {
            session,
            dashboard,
            marks: None,
            commands: None,
            folders: None,
            finished: vec![],
            skin: None,
            label: None,
            view: None,
            watch: Watch::default(),
            starting: None,
        }
    }

    /// Take `bytes` as they arrived, at host UTC `host_utc_us` where
    /// known.
    pub fn push_at(&mut self, bytes: &[u8], host_utc_us: Option<i64>) -> Result<()> {
        let mut rest = bytes;
        if self.starting.is_some() {
            rest = self.begin(rest, host_utc_us)?;
        }
        let passing = self.watch.push(rest, host_utc_us, self.session.is_none());
        let Some(session) = &mut self.session else {
            if let Some(d) = self.dashboard {
                d.passing(&passing);
                // The device as the watch sees it (no clock fit: that is
                // a recording's).
                if let Some(start) = &self.watch.start {
                    d.device(self.watch.segment, start, None);
                }
            }
            return Ok(());
        };
        session.push_at(rest, host_utc_us)?;
        if let (Some(d), Some(v)) = (self.dashboard, &mut self.view) {
            v.show(d, session, false);
            return Ok(());
        }
        if let Some(d) = self.dashboard {
            d.push(session.fresh());
            if let Some(status) = session.fresh_status() {
                d.status(&status);
            }
            d.availability(session.availability(), session.interpolated(), false);
            d.written(session.on_disk());
            if let Some(seg) = session.segments().last() {
                let segment = session.segments().len() as u32;
                d.device(segment, &seg.start, seg.clock.line());
            }
        }
        Ok(())
    }

    /// A start asked for: once the bytes reach a frame's end (those
    /// before it go to the watch alone), the recording begins, joining
    /// the run where its start frame was seen. The bytes left.
    fn begin<'b>(&mut self, bytes: &'b [u8], host_utc_us: Option<i64>) -> Result<&'b [u8]> {
        let mut rest = bytes;
        if !self.watch.boundary && self.watch.start.is_some() {
            let Some(end) = bytes.iter().position(|&b| b == 0) else {
                self.watch.push(bytes, host_utc_us, false);
                return Ok(&[]);
            };
            self.watch.push(&bytes[..=end], host_utc_us, false);
            rest = &bytes[end + 1..];
        }
        let Some((dir, reply)) = self.starting.take() else {
            return Ok(rest);
        };
        let earlier = self.folders.as_ref().map_or(Earlier::Refuse, |f| f.earlier);
        let made = match self.watch.start {
            Some(start) => Session::join(&dir, earlier, &start, self.watch.last_seq, host_utc_us),
            // No start frame seen yet: the recording waits for it.
            None => Session::new(&dir, earlier),
        };
        let answer = match made {
            Ok(mut s) => {
                if let Some(skin) = &self.skin {
                    s.set_skin(skin.clone());
                }
                eprintln!("recording into {}", dir.display());
                if let Some(d) = self.dashboard {
                    d.recording(Some(&dir));
                }
                self.session = Some(s);
                Ok(dir)
            }
            Err(e) => {
                eprintln!("recording refused: {e:#}");
                Err(format!("{e:#}"))
            }
        };
        if let Some(reply) = reply {
            let _ = reply.send(answer);
        }
        Ok(rest)
    }

    /// The markers asked for since the last call, written; each asker
    /// told the marker or why it was refused.
    pub fn take_marks(&mut self) {
        let Some(marks) = self.marks else {
            return;
        };
        while let Ok(m) = marks.try_recv() {
            let done = match &mut self.session {
                Some(s) => s.mark(m.host_utc_us, &m.source, &m.text),
                None => Err(anyhow::anyhow!("no recording runs: start one first")),
            };
            match &done {
                Ok(w) => {
                    eprintln!("marker from {}: {}", w.source, w.text);
                    if let Some(d) = self.dashboard {
                        d.marker(w);
                    }
                }
                Err(e) => eprintln!("marker refused: {e}"),
            }
            if let Some(reply) = m.reply {
                let _ = reply.send(done.map_err(|e| e.to_string()));
            }
        }
    }

    /// The recordings started and stopped since the last call.
    pub fn take_commands(&mut self) -> Result<()> {
        let Some(commands) = self.commands else {
            return Ok(());
        };
        while let Ok(c) = commands.try_recv() {
            match c {
                Command::Start(dir, reply) => {
                    let refused = match (&self.session, &self.starting, &self.folders) {
                        (Some(s), _, _) => {
                            Some(format!("a recording runs already, into {}", s.dir().display()))
                        }
                        (_, Some((d, _)), _) => {
                            Some(format!("a recording is starting already, into {}", d.display()))
                        }
                        (_, _, None) => Some("this run takes no recordings (a replay)".to_string()),
                        _ => None,
                    };
                    match (refused, &mut self.folders) {
                        (Some(why), _) => {
                            eprintln!("start refused: {why}");
                            if let Some(reply) = reply {
                                let _ = reply.send(Err(why));
                            }
                        }
                        (None, Some(f)) => {
                            let dir = dir.unwrap_or_else(|| f.take_next());
                            self.starting = Some((dir, reply));
                            // At a frame's end already: it begins now.
                            self.begin(&[], None)?;
                        }
                        (None, None) => {}
                    }
                }
                Command::Stop(reply) => {
                    let answer = match self.stop()? {
                        Some(dir) => Ok(dir),
                        None => Err("no recording runs".to_string()),
                    };
                    if let Some(reply) = reply {
                        let _ = reply.send(answer);
                    }
                }
            }
        }
        Ok(())
    }

    /// Stop the recording running: its set written (complete, stopped
    /// when asked); its folder.
    pub fn stop(&mut self) -> Result<Option<PathBuf>> {
        let Some(mut s) = self.session.take() else {
            return Ok(None);
        };
        s.flush()?;
        s.ask_stop();
        let dir = s.dir().to_path_buf();
        let done = s.finish()?;
        eprintln!("recording stopped: {} ({})", dir.display(), done.summary.line());
        if let Some(d) = self.dashboard {
            d.recording(None);
        }
        self.finished.push((dir.clone(), done));
        Ok(Some(dir))
    }

    /// The device's end frame came (its stream is over).
    pub fn ended(&self) -> bool {
        self.watch.ended || self.session.as_ref().is_some_and(|s| s.end().is_some())
    }

    /// Write what arrived so far (see [`Session::flush`]).
    pub fn flush(&mut self) -> Result<()> {
        let Some(s) = &mut self.session else {
            return Ok(());
        };
        s.flush()?;
        if let Some(d) = self.dashboard {
            d.written(s.on_disk());
        }
        Ok(())
    }

    /// The link's health line: the recording's, or the watch's (after
    /// the board's name, where it has one).
    pub fn line(&self) -> String {
        let line = self.health();
        match &self.label {
            Some(board) => format!("board {board}: {line}"),
            None => line,
        }
    }

    fn health(&self) -> String {
        match &self.session {
            Some(s) => s.summary().line(),
            None => format!(
                "not recording ({} bytes, {} frames seen; `start` records)",
                self.watch.decoder.stats().bytes,
                self.watch.decoder.stats().frames
            ),
        }
    }
}
