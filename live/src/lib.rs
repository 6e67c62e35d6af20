//! The host's end of the record link ([`link`]): a session reads a
//! stream's bytes as they arrive, keeps them, turns its frames into
//! records, writes them down as they come, and at the end writes the
//! data set ([`host_sim::recording`]'s writer, the format of
//! `docs/data-format.md`).
//!
//! A session writes nothing until its stream's start frame has arrived,
//! and never over another session's files: a folder that holds files
//! already is refused unless the user asks to replace them
//! ([`Earlier::Overwrite`]). A stream that ends without its end frame
//! (the device crashed, hung or was unplugged) leaves an `INCOMPLETE`
//! file beside the data that says so, and [`Session::finish`] returns
//! [`Outcome::Incomplete`].

pub mod calibrate;
pub mod config;
pub mod dashboard;

use anyhow::{bail, Context, Result};
use dsp_core::lumped::SeriesRc;
use dsp_core::Complex32;
use host_sim::recording::{self, LoggedRecord, LoggedToneRecord, Roles};
use link::{Body, Decoder, Record, Start};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The records file, written as records arrive (at least once a second).
pub const RECORDS_CSV: &str = "records.csv";
/// The raw stream, every byte as it arrived from the start frame's on.
pub const STREAM_BIN: &str = "stream.bin";
/// The most bytes a session holds while it waits for the start frame: a
/// source that sends this many without one is not a record stream.
pub const BEFORE_START_MAX: usize = 1 << 20;
/// The marker of a stream that did not end with its end frame.
pub const INCOMPLETE: &str = "INCOMPLETE";

/// The header of [`RECORDS_CSV`].
const RECORDS_HEADER: &str = "seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags";

/// How a stream ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// With its end frame: every record the device sent, less those lost
    /// on the way (counted).
    Complete,
    /// Without its end frame; the reason.
    Incomplete(String),
}

/// What a session does with a folder that holds files already.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Earlier {
    /// Refuse it: nothing is written there.
    #[default]
    Refuse,
    /// Replace the earlier session's files (its records, stream, marker
    /// and data set; other files stay) once the new stream has started.
    Overwrite,
}

/// A link session: bytes in; records, counts and files out.
pub struct Session {
    dir: PathBuf,
    earlier: Earlier,
    decoder: Decoder,
    start: Option<Start>,
    end: Option<link::End>,
    records: Vec<Record>,
    /// Each record's frame sequence number.
    seqs: Vec<u32>,
    /// `records.csv` and `stream.bin`, open from the start frame on;
    /// `records.csv` holds the first `in_csv` records (the rest join it
    /// at the next [`Session::flush`], at least once a second while
    /// following a stream, or at [`Session::finish`]).
    files: Option<Files>,
    /// The bytes before the start frame's end, while it has not arrived.
    before_start: Vec<u8>,
    in_csv: usize,
    /// One line of `records.csv`, its buffer kept.
    line: Vec<u8>,
    /// Frames after the end frame, or before the start frame.
    stray: u64,
    /// The first frames refused: where (the byte that closed them) and
    /// why.
    refused: Vec<(u64, link::Error)>,
    /// Records that decoded but cannot be the device's, set aside.
    set_aside: SetAside,
    /// Each sensor's last record time in this run of the device, µs.
    last_t_us: std::collections::BTreeMap<u8, u64>,
    /// Start frames after the first: the device restarted.
    restarts: u32,
    /// Why the session took no more frames, where it stopped early.
    stopped: Option<String>,
}

/// Records that decoded but that the stream's own terms rule out: set
/// aside (not written), counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SetAside {
    /// Of a sensor beyond the count the start frame gave.
    pub beyond_sensors: u64,
    /// Not after its sensor's previous record in time (time going
    /// backwards, or a record again).
    pub not_later: u64,
}

impl SetAside {
    /// How many in all.
    pub fn total(&self) -> u64 {
        self.beyond_sensors + self.not_later
    }
}

/// How many refused frames a session describes (the rest are counted).
pub const REFUSED_SHOWN: usize = 20;

/// A session's files.
struct Files {
    csv: std::io::BufWriter<std::fs::File>,
    raw: std::io::BufWriter<std::fs::File>,
}

impl Session {
    /// A session that will write into `dir` once its stream's start
    /// frame arrives (nothing before). A `dir` that holds files already
    /// is refused here, unless `earlier` says to overwrite them.
    pub fn new(dir: &Path, earlier: Earlier) -> Result<Self> {
        if earlier == Earlier::Refuse {
            let held = held_files(dir)?;
            if !held.is_empty() {
                bail!(
                    "{} holds files already ({}): a session never writes over another; choose a new folder, or pass --overwrite to replace the session there",
                    dir.display(),
                    held.join(", ")
                );
            }
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            earlier,
            decoder: Decoder::new(),
            start: None,
            end: None,
            records: vec![],
            seqs: vec![],
            files: None,
            before_start: vec![],
            in_csv: 0,
            line: Vec::with_capacity(192),
            stray: 0,
            refused: vec![],
            set_aside: SetAside::default(),
            last_t_us: Default::default(),
            restarts: 0,
            stopped: None,
        })
    }

    /// The start frame has arrived: the folder made ready (an earlier
    /// session's files taken away where the user asked) and the
    /// session's files created.
    fn open_files(&mut self) -> Result<Files> {
        let dir = &self.dir;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        if self.earlier == Earlier::Overwrite {
            for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
                let entry = entry?;
                let name = entry.file_name().to_string_lossy().into_owned();
                if entry.file_type()?.is_file() && session_file(&name) {
                    std::fs::remove_file(entry.path())
                        .with_context(|| format!("removing {}", entry.path().display()))?;
                }
            }
        }
        // Created anew, never through a link an earlier run left.
        let create = |name: &str| {
            let path = dir.join(name);
            std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
                .map(std::io::BufWriter::new)
                .with_context(|| format!("creating {}", path.display()))
        };
        let mut csv = create(RECORDS_CSV)?;
        writeln!(csv, "{RECORDS_HEADER}")?;
        let raw = create(STREAM_BIN)?;
        Ok(Files { csv, raw })
    }

    /// Take `bytes` as they arrived; the records they completed.
    pub fn push(&mut self, bytes: &[u8]) -> Result<usize> {
        let n = self.decode(bytes)?;
        match &mut self.files {
            Some(files) => files.raw.write_all(bytes).context("keeping the raw stream")?,
            None if self.start.is_some() => {
                let mut files = self.open_files()?;
                files.raw.write_all(&self.before_start)?;
                files.raw.write_all(bytes).context("keeping the raw stream")?;
                self.before_start = vec![];
                self.files = Some(files);
            }
            None => {
                self.before_start.extend_from_slice(bytes);
                if self.before_start.len() > BEFORE_START_MAX {
                    bail!(
                        "no start frame in the first {} bytes: not a record stream (the wrong port, or the wrong baud rate?); nothing written",
                        self.before_start.len()
                    );
                }
            }
        }
        Ok(n)
    }

    /// The frames `bytes` complete, taken in; the records among them.
    fn decode(&mut self, bytes: &[u8]) -> Result<usize> {
        let mut n = 0;
        let mut rest = bytes;
        while self.stopped.is_none() {
            let Some(got) = self.decoder.next_frame(&mut rest) else {
                break;
            };
            let frame = match got {
                Ok(frame) => frame,
                Err(e) => {
                    if self.refused.len() < REFUSED_SHOWN {
                        self.refused.push((self.decoder.stats().bytes, e));
                    }
                    continue;
                }
            };
            match frame.body {
                Body::Start(s) => self.started(s)?,
                Body::Record(r) if self.start.is_some() && self.end.is_none() => {
                    if self.take(&r) {
                        self.records.push(r);
                        self.seqs.push(frame.seq);
                        n += 1;
                    }
                }
                Body::End(e) if self.start.is_some() => self.end = Some(e),
                _ => self.stray += 1,
            }
        }
        Ok(n)
    }

    /// A start frame: the stream's first, or the device's again after a
    /// restart (its records' times start over). Of another wire version:
    /// refused when it is the first (nothing came before it), else the
    /// session stops, keeping what came before.
    fn started(&mut self, s: Start) -> Result<()> {
        if s.version != link::VERSION {
            let why = format!(
                "the stream is of wire version {} and this tool reads version {}: update the host tools",
                s.version,
                link::VERSION
            );
            if self.start.is_none() {
                bail!("{why}");
            }
            self.stopped = Some(format!(
                "the device restarted and {why}; the records before are kept"
            ));
            return Ok(());
        }
        if self.start.is_some() {
            self.restarts += 1;
            self.last_t_us.clear();
        }
        self.start = Some(s);
        Ok(())
    }

    /// Whether record `r` can be the device's: of a sensor the start
    /// frame counts, and later than its sensor's last record since the
    /// device started. Counted where it is set aside.
    fn take(&mut self, r: &Record) -> bool {
        let sensors = self.start.map_or(0, |s| s.sensors);
        if r.sensor >= sensors {
            self.set_aside.beyond_sensors += 1;
            return false;
        }
        if self.last_t_us.get(&r.sensor).is_some_and(|&last| r.t_us <= last) {
            self.set_aside.not_later += 1;
            return false;
        }
        self.last_t_us.insert(r.sensor, r.t_us);
        true
    }

    /// Why the session took no more frames, if it stopped early (the
    /// device restarted with another wire version).
    pub fn stopped(&self) -> Option<&str> {
        self.stopped.as_deref()
    }

    /// The start frame, once received.
    pub fn start(&self) -> Option<&Start> {
        self.start.as_ref()
    }

    /// Records received so far.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// The link's counts so far.
    pub fn stats(&self) -> link::Stats {
        self.decoder.stats()
    }

    /// The first frames refused ([`REFUSED_SHOWN`] at most): the byte of
    /// the stream that closed each (1-based), and why.
    pub fn refused(&self) -> &[(u64, link::Error)] {
        &self.refused
    }

    /// The end frame, once received.
    pub fn end(&self) -> Option<&link::End> {
        self.end.as_ref()
    }

    /// Write the records received so far into `records.csv` (a reader
    /// may be watching).
    pub fn flush(&mut self) -> Result<()> {
        let Some(files) = &mut self.files else {
            return Ok(());
        };
        let from = self.in_csv;
        write_records(
            &mut files.csv,
            &mut self.line,
            &self.seqs[from..],
            &self.records[from..],
        )?;
        self.in_csv = self.records.len();
        files.raw.flush().context("keeping the raw stream")?;
        files.csv.flush().context("writing records.csv")
    }

    /// The stream is over: write the data set of what arrived, and the
    /// [`INCOMPLETE`] marker if it did not end with its end frame.
    pub fn finish(mut self) -> Result<Finished> {
        let summary = self.summary();
        // The files are open from the start frame on.
        let Some(mut files) = self.files.take() else {
            // No start frame: nothing was written, and nothing is.
            return Ok(Finished {
                outcome: Outcome::Incomplete(
                    "no start frame: nothing from the device; nothing written".into(),
                ),
                summary,
                written: recording::Written::default(),
            });
        };
        let outcome = match (&self.stopped, &self.end) {
            (Some(why), _) => Outcome::Incomplete(why.clone()),
            (None, Some(_)) => Outcome::Complete,
            (None, None) => Outcome::Incomplete(format!(
                "the stream stopped after {} records without its end frame (a crash, a hang, the link was cut, or it was stopped)",
                self.records.len()
            )),
        };
        files.raw.flush().context("keeping the raw stream")?;
        // The rest of records.csv on a thread of its own while the data
        // set is written (a replay's records all arrive at once).
        let Self {
            dir,
            records,
            seqs,
            in_csv,
            line,
            ..
        } = &mut self;
        let (records, from) = (&*records, *in_csv);
        let csv = &mut files.csv;
        let (rest, written) = std::thread::scope(|scope| {
            let rest = scope.spawn(move || {
                write_records(csv, line, &seqs[from..], &records[from..])?;
                csv.flush().context("writing records.csv")
            });
            let written = recording::write_dataset(dir, &logged(records), &Roles::default());
            let rest = rest
                .join()
                .unwrap_or_else(|_| Err(anyhow::anyhow!("the records.csv writer panicked")));
            (rest, written)
        });
        rest?;
        let written = written?;
        if let Outcome::Incomplete(why) = &outcome {
            let marker = self.dir.join(INCOMPLETE);
            std::fs::write(&marker, format!("{why}\n"))
                .with_context(|| format!("writing {}", marker.display()))?;
        }
        Ok(Finished {
            outcome,
            summary,
            written,
        })
    }
}

/// The names of the entries `dir` holds (none where it does not exist).
fn held_files(dir: &Path) -> Result<Vec<String>> {
    match std::fs::read_dir(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(vec![]),
        Err(e) => Err(e).with_context(|| format!("reading {}", dir.display())),
        Ok(entries) => entries
            .map(|e| Ok(e?.file_name().to_string_lossy().into_owned()))
            .collect::<std::io::Result<Vec<_>>>()
            .with_context(|| format!("reading {}", dir.display())),
    }
}

/// Whether `name` is a file a session writes: its records, its stream,
/// its marker, its data set's files.
fn session_file(name: &str) -> bool {
    name == RECORDS_CSV || name == STREAM_BIN || name == INCOMPLETE || recording::is_dataset_file(name)
}

/// The link's records as the data set writer takes them: an array record
/// (two tones) as a record per tone, a multiplexed one as it is.
pub fn logged(records: &[Record]) -> Vec<LoggedRecord> {
    let mut out = Vec::with_capacity(2 * records.len());
    for r in records {
        if r.measured().count() == 2 {
            let tone = LoggedToneRecord {
                rec: instrument::frames::to_tone_record(r),
                truth: None,
            };
            out.extend(tone.per_tone());
        } else {
            let t = r.tones[0];
            // The lumped reading of its one tone, as `per_tone` takes an
            // array record's (none where the tone has no capacitive Z).
            let lumped = SeriesRc::from_impedance(Complex32::new(t.z_re_ohm, t.z_im_ohm), t.f_hz).ok();
            out.push(LoggedRecord {
                t_s: r.t_us as f64 * 1e-6,
                sensor: r.sensor,
                freq_hz: t.f_hz as f64,
                cs_pf: lumped.map_or(0.0, |m| m.cs_farad as f64 * 1e12),
                rs_ohm: lumped.map_or(0.0, |m| m.rs_ohm as f64),
                c_pf: r.c_farad as f64 * 1e12,
                r_ohm: r.r_ohm as f64,
                stretch_mm: r.stretch_mm as f64,
                flags: instrument::faults::Flags(r.flags),
                truth: None,
            });
        }
    }
    out
}

/// `records.csv`'s lines of `records` (their frames' sequence numbers
/// `seqs`).
fn write_records(w: &mut impl Write, line: &mut Vec<u8>, seqs: &[u32], records: &[Record]) -> Result<()> {
    for (&seq, r) in seqs.iter().zip(records) {
        write_record(w, line, seq, r)?;
    }
    Ok(())
}

fn write_record(w: &mut impl Write, line: &mut Vec<u8>, seq: u32, r: &Record) -> Result<()> {
    // Through `numfmt`: `{}` on eleven floats was most of a replay.
    use host_sim::numfmt::{fixed, int, shortest_f32};
    line.clear();
    int(line, seq);
    line.push(b',');
    int(line, r.t_us);
    line.push(b',');
    int(line, r.sensor);
    for t in r.tones {
        for x in [t.f_hz, t.z_re_ohm, t.z_im_ohm] {
            line.push(b',');
            shortest_f32(line, x);
        }
    }
    line.push(b',');
    fixed(line, r.c_farad as f64 * 1e12, 4);
    for x in [r.r_ohm, r.stretch_mm, r.chosen_hz, r.chi2, r.sigma_ln_c] {
        line.push(b',');
        shortest_f32(line, x);
    }
    line.push(b',');
    int(line, r.flags);
    line.push(b'\n');
    w.write_all(line).context("writing records.csv")
}

/// What a session received, in numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The firmware that sent it (from the start frame).
    pub firmware: Option<String>,
    /// Bytes received.
    pub bytes: u64,
    /// Records received.
    pub records: usize,
    /// Records flagged (not valid).
    pub flagged: usize,
    /// The link's counts: frames decoded, refused, lost, repeated.
    pub link: link::Stats,
    /// Records the device dropped before sending (from the end frame).
    pub dropped: Option<u32>,
    /// Sensors heard from.
    pub sensors: usize,
    /// Records per second per sensor: least and most.
    pub rate: (f64, f64),
    /// Records set aside: of no sensor the start frame counts, or not
    /// later than their sensor's last.
    pub set_aside: SetAside,
    /// Times the device restarted (a start frame again).
    pub restarts: u32,
    /// Where the end frame's count of records sent disagrees with what
    /// arrived: how.
    pub end_mismatch: Option<String>,
}

impl Summary {
    /// Mean bytes on the wire per record.
    pub fn bytes_per_record(&self) -> f64 {
        self.bytes as f64 / self.records.max(1) as f64
    }

    /// One line for a terminal.
    pub fn line(&self) -> String {
        format!(
            "{} records from {} sensors ({:.1}–{:.1} records/s each), {} flagged; {:.1} bytes per record; frames: {} refused, {} lost, {} repeated{}",
            self.records,
            self.sensors,
            self.rate.0,
            self.rate.1,
            self.flagged,
            self.bytes_per_record(),
            self.link.bad,
            self.link.lost,
            self.link.repeated,
            self.dropped.map_or(String::new(), |d| format!("; {d} dropped on the device"))
        ) + &self.remarks()
    }

    /// What the line adds where the stream broke its own terms.
    fn remarks(&self) -> String {
        let mut out = String::new();
        let a = self.set_aside;
        if a.beyond_sensors > 0 {
            out += &format!(
                "; {} records of sensors beyond the start frame's count set aside",
                a.beyond_sensors
            );
        }
        if a.not_later > 0 {
            out += &format!("; {} records not later than their sensor's last set aside (time went backwards, or a record again)", a.not_later);
        }
        if self.restarts > 0 {
            out += &format!("; the device restarted {} time(s)", self.restarts);
        }
        if let Some(m) = &self.end_mismatch {
            out += &format!("; {m}");
        }
        out
    }
}

impl Session {
    /// What the session has received so far.
    pub fn summary(&self) -> Summary {
        let mut per: std::collections::BTreeMap<u8, (usize, u64, u64)> = Default::default();
        for r in &self.records {
            let e = per.entry(r.sensor).or_insert((0, r.t_us, r.t_us));
            e.0 += 1;
            e.1 = e.1.min(r.t_us);
            e.2 = e.2.max(r.t_us);
        }
        let rates: Vec<f64> = per
            .values()
            .filter(|(n, a, b)| *n > 1 && b > a)
            .map(|&(n, a, b)| (n - 1) as f64 / ((b - a) as f64 * 1e-6))
            .collect();
        let stats = self.decoder.stats();
        Summary {
            firmware: self.start.map(|s| s.firmware_str().to_string()),
            bytes: stats.bytes,
            records: self.records.len(),
            flagged: self
                .records
                .iter()
                .filter(|r| !instrument::faults::Flags(r.flags).valid())
                .count(),
            link: stats,
            dropped: self.end.map(|e| e.dropped),
            set_aside: self.set_aside,
            restarts: self.restarts,
            end_mismatch: self.end_mismatch(&stats),
            sensors: per.len(),
            rate: (
                rates.iter().copied().fold(f64::NAN, f64::min),
                rates.iter().copied().fold(f64::NAN, f64::max),
            ),
        }
    }

    /// Where the end frame's count of records sent cannot be what
    /// arrived: fewer than arrived, or more than arrived and the frames
    /// lost could hold. Not judged across a restart: the device's count
    /// starts over with it.
    fn end_mismatch(&self, stats: &link::Stats) -> Option<String> {
        let sent = u64::from(self.end?.records);
        if self.restarts > 0 {
            return None;
        }
        let arrived = self.records.len() as u64 + self.set_aside.total();
        (sent < arrived || sent > arrived + stats.lost).then(|| {
            format!(
                "the end frame says {sent} records were sent, but {arrived} arrived and {} frames were lost",
                stats.lost
            )
        })
    }
}

/// A finished session.
#[derive(Clone, Debug)]
pub struct Finished {
    /// How the stream ended.
    pub outcome: Outcome,
    /// What it received.
    pub summary: Summary,
    /// The data set's files.
    pub written: recording::Written,
}

/// Replay a recorded stream's `bytes` into `dir` (a folder that holds
/// files already as `earlier` says).
pub fn replay(bytes: &[u8], dir: &Path, earlier: Earlier) -> Result<Finished> {
    let mut s = Session::new(dir, earlier)?;
    s.push(bytes)?;
    s.finish()
}

/// Where bytes go: the session, and the records they complete to the
/// dashboard when there is one.
pub struct Sink<'a> {
    /// The session.
    pub session: &'a mut Session,
    /// The dashboard, if one is served.
    pub dashboard: Option<&'a dashboard::Dashboard>,
}

impl Sink<'_> {
    /// Take `bytes` as they arrived.
    pub fn push(&mut self, bytes: &[u8]) -> Result<()> {
        let before = self.session.records().len();
        self.session.push(bytes)?;
        if let Some(d) = self.dashboard {
            d.push(&self.session.records()[before..]);
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
/// least every read timeout), printing the link's health each second.
pub fn follow(mut source: impl Read, sink: &mut Sink, stop: &AtomicBool) -> Result<Stopped> {
    let mut buf = [0u8; 4096];
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
            sink.session.flush()?;
            eprintln!("{}", sink.session.summary().line());
        }
        if sink.session.end().is_some() {
            break Stopped::End;
        }
        if let Some(why) = sink.session.stopped() {
            break Stopped::Source(why.to_string());
        }
    };
    sink.session.flush()?;
    Ok(stopped)
}
