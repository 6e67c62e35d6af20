//! A link session: bytes in; records, counts and files out, written as
//! they arrive.

use crate::clock::ClockFit;
use crate::interpolated::{self, Gaps, INTERPOLATED_CSV};
use crate::markers::{self, MARKERS_CSV};
use crate::records_csv::{self, RECORDS_CSV};
use crate::summary::{Counts, Cpu, Summary};
use crate::{INCOMPLETE, STREAM_BIN};
use anyhow::{bail, Context, Result};
use host_sim::recording::{self, DatasetWriter, LineFile, Roles};
use link::{Body, Decoder, Record, Start};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The most bytes a session holds while it waits for the start frame: a
/// source that sends this many without one is not a record stream.
pub const BEFORE_START_MAX: usize = 1 << 20;
/// The most bytes of records a session holds before it writes them (it
/// writes them at least once a second while following a stream).
const PENDING_MAX: usize = 4 << 20;
/// How many refused frames a session describes (the rest are counted).
pub const REFUSED_SHOWN: usize = 20;

/// The host's times of arrival: each read that completed records, as the
/// stream's length in bytes at its end and the host's UTC then.
pub const ARRIVALS_CSV: &str = "arrivals.csv";
/// The columns of [`ARRIVALS_CSV`] (its header line, which the replay's
/// reader checks).
pub(crate) const ARRIVALS_COLUMNS: &str = "stream_bytes,host_utc_us";

/// A record kept, with where it came: its segment (1, then one more
/// after each restart of the device), its frame's sequence number and
/// the host's UTC when it arrived (µs since the Unix epoch; none in a
/// replay without its arrivals), as `records.csv` holds them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Arrived {
    /// The segment.
    pub segment: u32,
    /// The frame's sequence number.
    pub seq: u32,
    /// The host's UTC at its arrival, µs since the Unix epoch.
    pub host_utc_us: Option<i64>,
    /// The record.
    pub record: Record,
}

/// How a stream ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// With its end frame: every record the device sent, less those lost
    /// on the way (counted).
    Complete,
    /// Stopped by the user (Ctrl-C, a stop command) while the device
    /// ran on: every record that arrived until then, a set as complete
    /// as one that ended with its end frame.
    Stopped,
    /// Without its end frame, and not asked to stop (a lost source, a
    /// crash, a hang); the reason.
    Incomplete(String),
}

impl Outcome {
    /// A complete set: ended with its end frame, or stopped when asked.
    pub fn is_complete(&self) -> bool {
        !matches!(self, Outcome::Incomplete(_))
    }
}

/// What a session does with a folder that holds files already.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Earlier {
    /// Refuse it: nothing is written there.
    #[default]
    Refuse,
    /// Replace the earlier session's files (its records, stream, marker,
    /// manifest and data set; other files stay) once the new stream has
    /// started.
    Overwrite,
}

/// One run of the device: from a start frame to the next (a restart) or
/// the stream's end.
#[derive(Clone, Debug)]
pub struct Segment {
    /// Its start frame.
    pub start: Start,
    /// The start frame's sequence number.
    pub first_seq: u32,
    /// The highest sequence number taken.
    pub high_seq: u32,
    /// Frames taken (each sequence number once).
    pub distinct: u64,
    /// Frames again (a sequence number at or before the highest taken:
    /// a replay), dropped.
    pub duplicates: u64,
    /// Records that arrived, and of those, kept (the rest set aside).
    pub arrived: u64,
    /// Records kept.
    pub records: u64,
    /// Its end frame, if it came.
    pub end: Option<link::End>,
    /// How the device's CPU kept up (its status frames), if it said.
    pub cpu: Option<Cpu>,
    /// Its clock fitted to the host's, from the records' arrivals.
    pub clock: ClockFit,
    /// The sets the device applied while it ran, each with its frame's
    /// sequence number: in force for the records numbered after it.
    pub applied: Vec<(u32, link::Applied)>,
}

impl Segment {
    fn new(start: Start, seq: u32) -> Self {
        Self {
            start,
            first_seq: seq,
            high_seq: seq,
            distinct: 1,
            duplicates: 0,
            arrived: 0,
            records: 0,
            end: None,
            cpu: None,
            clock: ClockFit::default(),
            applied: vec![],
        }
    }

    /// Every set in force during the segment, with the sequence number
    /// after which it holds: the start frame's (its digests, time 0),
    /// then each one applied.
    pub fn in_force(&self) -> Vec<(u32, link::Applied)> {
        let s = &self.start;
        let first = link::Applied {
            generation: s.generation,
            settings_digest: s.settings_digest,
            calibration_digest: s.calibration_digest,
            t_us: 0,
        };
        std::iter::once((self.first_seq, first))
            .chain(self.applied.iter().copied())
            .collect()
    }

    /// Whether the recording joined the device's run after its start:
    /// its start frame is numbered past 0 (a device numbers its start
    /// frame 0; `live` writes it again, numbered just before the first
    /// frame a recording started mid-run holds).
    pub fn joined(&self) -> bool {
        self.first_seq != 0
    }

    /// Frames whose sequence numbers never arrived.
    pub fn lost(&self) -> u64 {
        u64::from(self.high_seq.wrapping_sub(self.first_seq)) + 1 - self.distinct
    }

    /// Take sequence number `seq`: false for a frame again (counted).
    fn take_seq(&mut self, seq: u32) -> bool {
        let ahead = seq.wrapping_sub(self.high_seq);
        if ahead == 0 || ahead > u32::MAX / 2 {
            self.duplicates += 1;
            return false;
        }
        self.high_seq = seq;
        self.distinct += 1;
        true
    }

    /// Where its end frame's count of records sent cannot be what
    /// arrived (fewer than arrived, or more than arrived and the frames
    /// lost could hold): how.
    /// A recording that joined the run mid-way ([`Segment::joined`])
    /// cannot check the count: it covers the device's whole run.
    pub fn end_mismatch(&self) -> Option<String> {
        if self.joined() {
            return None;
        }
        let sent = u64::from(self.end?.records);
        let lost = self.lost();
        (sent < self.arrived || sent > self.arrived + lost).then(|| {
            format!(
                "the end frame says {sent} records were sent, but {} arrived and {lost} frames were lost",
                self.arrived
            )
        })
    }
}

/// A session's files, open from the start frame on.
struct Files {
    csv: LineFile,
    /// Records in `csv`'s pending lines.
    csv_pending: u64,
    /// Records written to `csv`.
    csv_written: u64,
    raw: std::io::BufWriter<std::fs::File>,
    data: DatasetWriter,
    /// Values for the records not vouched for, from their neighbours.
    interpolated: LineFile,
    /// When records arrived ([`ARRIVALS_CSV`]).
    arrivals: LineFile,
    /// The user's markers ([`MARKERS_CSV`]).
    markers: LineFile,
}

/// A link session: bytes in; records, counts and files out.
pub struct Session {
    dir: PathBuf,
    earlier: Earlier,
    decoder: Decoder,
    segments: Vec<Segment>,
    files: Option<Files>,
    /// When the files were opened (UTC).
    pub(crate) opened: Option<chrono::DateTime<chrono::Utc>>,
    /// The bytes before the start frame's end, while it has not arrived.
    before_start: Vec<u8>,
    /// The records the last [`Session::push`] completed.
    fresh: Vec<Arrived>,
    /// The latest status frame of the last push.
    fresh_status: Option<link::Status>,
    counts: Counts,
    /// Frames after the end frame, or before the start frame.
    pub(crate) stray: u64,
    /// The first frames refused: where (the byte that closed them) and
    /// why.
    refused: Vec<(u64, link::Error)>,
    /// Each sensor's last record time in this segment, µs.
    last_t_us: std::collections::BTreeMap<u8, u64>,
    /// Why the session took no more frames, where it stopped early.
    stopped: Option<String>,
    /// The user asked the session to stop ([`Session::ask_stop`]).
    asked: bool,
    /// Each sensor's gap since its last valid record.
    gaps: Gaps,
    /// Bytes taken so far: the stream's length.
    bytes_in: u64,
    /// The host's UTC of the bytes being taken, µs, if known.
    arrival: Option<i64>,
    /// Markers written.
    markers: u64,
    /// The skin's sensors on this board, where a skin is described.
    skin: Option<std::sync::Arc<crate::skin::Board>>,
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
            segments: vec![],
            files: None,
            opened: None,
            before_start: vec![],
            fresh: vec![],
            fresh_status: None,
            counts: Counts::default(),
            stray: 0,
            refused: vec![],
            last_t_us: Default::default(),
            stopped: None,
            asked: false,
            gaps: Gaps::default(),
            bytes_in: 0,
            arrival: None,
            markers: 0,
            skin: None,
        })
    }

    /// A recording that joins a device's run: `start` is the run's start
    /// frame, and `seq` the number of the last frame before the bytes
    /// this session will be given (which begin at a frame's start). The
    /// start frame is written again, numbered `seq`, so that the set's
    /// stream reads alone: no frame before it counts as lost.
    pub fn join(
        dir: &Path,
        earlier: Earlier,
        start: &Start,
        seq: u32,
        host_utc_us: Option<i64>,
    ) -> Result<Self> {
        let mut s = Self::new(dir, earlier)?;
        let mut out = [0u8; link::MAX_FRAME];
        let frame = link::Frame {
            seq,
            body: Body::Start(*start),
        };
        let bytes =
            link::encode(&frame, &mut out).map_err(|e| anyhow::anyhow!("the start frame again: {e}"))?;
        s.push_at(bytes, host_utc_us)?;
        Ok(s)
    }

    /// The first start frame has arrived: the folder made ready (an
    /// earlier session's files taken away where the user asked), marked
    /// [`INCOMPLETE`] until the session ends, and its files created.
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
        let marker = dir.join(INCOMPLETE);
        std::fs::write(
            &marker,
            "a session is writing here; if none is, it was killed, crashed or ran out of disk: its files hold every record up to its last flush (a second before it stopped, at most)\n",
        )
        .with_context(|| format!("writing {}", marker.display()))?;
        let csv = LineFile::create(dir.join(RECORDS_CSV), records_csv::HEADER)?;
        // Created anew, never through a link an earlier run left.
        let raw = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(dir.join(STREAM_BIN))
            .with_context(|| format!("creating {}", dir.join(STREAM_BIN).display()))?;
        let data = DatasetWriter::create(dir, false, Roles::default())?;
        let interpolated = LineFile::create(dir.join(INTERPOLATED_CSV), interpolated::HEADER)?;
        let arrivals = LineFile::create(dir.join(ARRIVALS_CSV), &format!("{ARRIVALS_COLUMNS}\n"))?;
        let markers = LineFile::create(dir.join(MARKERS_CSV), markers::HEADER)?;
        self.opened = Some(chrono::Utc::now());
        Ok(Files {
            csv,
            csv_pending: 0,
            csv_written: 0,
            raw: std::io::BufWriter::new(raw),
            data,
            interpolated,
            arrivals,
            markers,
        })
    }

    /// Take `bytes` as they arrived, at a time not known (a recorded
    /// stream); the records they completed ([`Session::fresh`]).
    pub fn push(&mut self, bytes: &[u8]) -> Result<usize> {
        self.push_at(bytes, None)
    }

    /// Take `bytes` as they arrived at host UTC `host_utc_us` (µs since
    /// the Unix epoch, where known): the records they complete carry it,
    /// the segment's clock fit takes the latest of them, and the arrival
    /// is kept in [`ARRIVALS_CSV`]. The records they completed
    /// ([`Session::fresh`]).
    pub fn push_at(&mut self, bytes: &[u8], host_utc_us: Option<i64>) -> Result<usize> {
        self.fresh.clear();
        self.fresh_status = None;
        self.arrival = host_utc_us;
        let had_files = self.files.is_some();
        self.decode(bytes)?;
        self.bytes_in += bytes.len() as u64;
        self.arrived()?;
        match &mut self.files {
            Some(files) => {
                if !had_files {
                    files.raw.write_all(&std::mem::take(&mut self.before_start))?;
                }
                files.raw.write_all(bytes).context("keeping the raw stream")?;
                if files.csv.pending().len() > PENDING_MAX || files.data.pending() > PENDING_MAX {
                    self.flush()?;
                }
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
        Ok(self.fresh.len())
    }

    /// The records of this push arrived: the arrival kept, and the
    /// latest record of the running segment given to its clock fit.
    fn arrived(&mut self) -> Result<()> {
        let (Some(at), Some(files), false) = (self.arrival, &mut self.files, self.fresh.is_empty()) else {
            return Ok(());
        };
        let line = files.arrivals.pending();
        host_sim::numfmt::int(line, self.bytes_in);
        line.push(b',');
        host_sim::numfmt::int(line, at);
        line.push(b'\n');
        let segment = self.segments.len() as u32;
        let latest = self
            .fresh
            .iter()
            .filter(|a| a.segment == segment)
            .map(|a| a.record.t_us)
            .max();
        if let (Some(t_us), Some(seg)) = (latest, self.segments.last_mut()) {
            seg.clock.add(t_us as f64 * 1e-6, at as f64 * 1e-6);
        }
        Ok(())
    }

    /// A marker from the user (`source`: `stdin`, `dashboard`…) at host
    /// UTC `host_utc_us`: written to [`MARKERS_CSV`] with the device's
    /// time the running segment's clock fit gives it. Refused before the
    /// start frame (no data set yet).
    pub fn mark(&mut self, host_utc_us: i64, source: &str, text: &str) -> Result<markers::Marker> {
        let Some(files) = &mut self.files else {
            bail!("no start frame yet: nothing is recorded, so the marker has no data set to go in");
        };
        let segment = self.segments.len() as u32;
        let device_t_us = self
            .segments
            .last()
            .and_then(|s| s.clock.line())
            .map(|l| (l.device_of(host_utc_us as f64 * 1e-6) * 1e6).round() as i64);
        let m = markers::Marker {
            host_utc_us,
            segment,
            device_t_us,
            source: source.to_string(),
            text: text.to_string(),
        };
        m.line(files.markers.pending())?;
        self.markers += 1;
        Ok(m)
    }

    /// Markers written so far.
    pub fn markers(&self) -> u64 {
        self.markers
    }

    /// The skin whose sensors this board's are: their names in the
    /// manifest, and the sensors the device lacks or adds said.
    pub fn set_skin(&mut self, skin: std::sync::Arc<crate::skin::Board>) {
        self.skin = Some(skin);
    }

    /// The skin's sensors on this board, if described.
    pub fn skin(&self) -> Option<&crate::skin::Board> {
        self.skin.as_deref()
    }

    /// The frames `bytes` complete, taken in.
    fn decode(&mut self, bytes: &[u8]) -> Result<()> {
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
            if let Body::Start(s) = frame.body {
                self.started(s, frame.seq)?;
                continue;
            }
            let Some(seg) = self.segments.last_mut() else {
                self.stray += 1;
                continue;
            };
            if !seg.take_seq(frame.seq) {
                continue;
            }
            match frame.body {
                Body::Record(r) if seg.end.is_none() => self.record(frame.seq, r)?,
                Body::End(e) if seg.end.is_none() => seg.end = Some(e),
                Body::Applied(a) if seg.end.is_none() => seg.applied.push((frame.seq, a)),
                Body::Status(s) if seg.end.is_none() => {
                    match &mut seg.cpu {
                        Some(c) => c.add(&s),
                        None => seg.cpu = Some(Cpu::new(&s)),
                    }
                    self.fresh_status = Some(s);
                }
                _ => self.stray += 1,
            }
        }
        Ok(())
    }

    /// A start frame: the stream's first, or the device's again after a
    /// restart (a new segment: its records' times and numbers start
    /// over; a restarted device sends the same frame). Of another
    /// wire version: refused when it is the first (nothing came before
    /// it), else the session stops, keeping what came before.
    fn started(&mut self, s: Start, seq: u32) -> Result<()> {
        if s.version != link::VERSION {
            let why = format!(
                "the stream is of wire version {} and this tool reads version {}: update the host tools",
                s.version,
                link::VERSION
            );
            if self.segments.is_empty() {
                bail!("{why}");
            }
            self.stopped = Some(format!(
                "the device restarted and {why}; the records before are kept"
            ));
            return Ok(());
        }
        match &mut self.files {
            None => self.files = Some(self.open_files()?),
            Some(files) => {
                files.data.restart();
                self.last_t_us.clear();
                self.gaps.restart();
            }
        }
        // The device's power-up self-test, and a sensor the skin names
        // that the device lacks, or one it reports that the skin does
        // not name: said at once.
        eprintln!("{}", crate::self_test::line(&s.self_test, s.sensors));
        if let Some(skin) = &self.skin {
            for line in skin.mismatch(s.sensors, s.device_id) {
                eprintln!("{line}");
            }
        }
        self.segments.push(Segment::new(s, seq));
        Ok(())
    }

    /// Record `r` (frame `seq`): kept and written, or set aside.
    fn record(&mut self, seq: u32, r: Record) -> Result<()> {
        let segment = self.segments.len() as u32;
        if let Some(seg) = self.segments.last_mut() {
            seg.arrived += 1;
        }
        if !self.take(&r) {
            return Ok(());
        }
        if let Some(seg) = self.segments.last_mut() {
            seg.records += 1;
        }
        self.counts.record(segment, &r);
        if let Some(files) = &mut self.files {
            records_csv::line(files.csv.pending(), segment, seq, &r, self.arrival);
            files.csv_pending += 1;
            for row in records_csv::rows(&r) {
                files.data.push(&row)?;
            }
            self.gaps.record(segment, seq, &r, files.interpolated.pending());
        }
        self.fresh.push(Arrived {
            segment,
            seq,
            host_utc_us: self.arrival,
            record: r,
        });
        Ok(())
    }

    /// Whether record `r` can be the device's: of a sensor the start
    /// frame counts, and later than its sensor's last record in this
    /// segment. Counted where it is set aside.
    fn take(&mut self, r: &Record) -> bool {
        let sensors = self.segments.last().map_or(0, |s| s.start.sensors);
        if r.sensor >= sensors {
            self.counts.set_aside.beyond_sensors += 1;
            return false;
        }
        if self.last_t_us.get(&r.sensor).is_some_and(|&last| r.t_us <= last) {
            self.counts.set_aside.not_later += 1;
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

    /// The user asked to stop (Ctrl-C): the set ends with what arrived,
    /// complete ([`Outcome::Stopped`]), not cut short.
    pub fn ask_stop(&mut self) {
        self.asked = true;
    }

    /// The start frame of the segment running, once received.
    pub fn start(&self) -> Option<&Start> {
        self.segments.last().map(|s| &s.start)
    }

    /// The device's runs so far: one per start frame.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// The records the last [`Session::push`] completed (those kept).
    pub fn fresh(&self) -> &[Arrived] {
        &self.fresh
    }

    /// The latest status frame the last [`Session::push`] completed, if
    /// one.
    pub fn fresh_status(&self) -> Option<link::Status> {
        self.fresh_status
    }

    /// The link's counts so far, as the session judges them: lost and
    /// repeated frames by the sequence numbers of each segment.
    pub fn stats(&self) -> link::Stats {
        let mut stats = self.decoder.stats();
        stats.lost = self.segments.iter().map(Segment::lost).sum();
        stats.repeated += self.segments.iter().map(|s| s.duplicates).sum::<u64>();
        stats
    }

    /// The first frames refused ([`REFUSED_SHOWN`] at most): the byte of
    /// the stream that closed each (1-based), and why.
    pub fn refused(&self) -> &[(u64, link::Error)] {
        &self.refused
    }

    /// The end frame of the segment running, once received.
    pub fn end(&self) -> Option<&link::End> {
        self.segments.last().and_then(|s| s.end.as_ref())
    }

    /// The folder it writes into.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Write every record received so far: `records.csv`, the data
    /// set's files (whole lines each) and the raw stream (a reader may
    /// be watching; a session killed after this loses nothing before).
    pub fn flush(&mut self) -> Result<()> {
        let Some(files) = &mut self.files else {
            return Ok(());
        };
        files.raw.flush().context("keeping the raw stream")?;
        files.csv.flush(true)?;
        files.csv_written += std::mem::take(&mut files.csv_pending);
        files.interpolated.flush(true)?;
        files.arrivals.flush(true)?;
        files.markers.flush(true)?;
        files.data.flush()
    }

    /// How much of `records.csv` is written: records, and bytes.
    pub fn on_disk(&self) -> crate::dashboard::OnDisk {
        self.files
            .as_ref()
            .map_or_else(Default::default, |f| crate::dashboard::OnDisk {
                records: f.csv_written,
                bytes: f.csv.written_bytes(),
            })
    }

    /// Per sensor so far: the share of its records valid, and the faults
    /// that stood on the others.
    pub fn availability(&self) -> &std::collections::BTreeMap<u8, instrument::availability::Availability> {
        &self.counts.availability
    }

    /// Per sensor so far: its records not valid given a value in
    /// `interpolated.csv`.
    pub fn interpolated(&self) -> &std::collections::BTreeMap<u8, u64> {
        self.gaps.given()
    }

    /// What the session has received so far.
    pub fn summary(&self) -> Summary {
        let stats = self.stats();
        let restarts = self.segments.len().saturating_sub(1) as u32;
        Summary {
            firmware: self.start().map(|s| s.firmware_str().to_string()),
            bytes: stats.bytes,
            records: self.counts.records,
            flagged: self.counts.flagged,
            link: stats,
            dropped: self.end().map(|e| e.dropped),
            set_aside: self.counts.set_aside,
            restarts,
            end_mismatch: self.segments.last().and_then(Segment::end_mismatch),
            sensors: self.counts.sensors(),
            rate: self.counts.rate(),
            cpu: self.segments.iter().fold(None, |a, g| Cpu::merge(a, g.cpu)),
            availability: self.counts.availability.clone(),
            interpolated: self.gaps.given().clone(),
        }
    }

    /// The stream is over: every file written, a sensor held still taken
    /// out of the traces (its calibration point), the manifest written,
    /// and the [`INCOMPLETE`] marker taken away, or given the reason
    /// where the stream did not end with its end frame.
    pub fn finish(mut self) -> Result<Finished> {
        let summary = self.summary();
        let outcome = match (&self.stopped, self.end()) {
            _ if self.files.is_none() => Outcome::Incomplete(
                "no start frame: nothing from the device; nothing written".into(),
            ),
            (Some(why), _) => Outcome::Incomplete(why.clone()),
            (None, Some(_)) => Outcome::Complete,
            (None, None) if self.asked => Outcome::Stopped,
            (None, None) => Outcome::Incomplete(format!(
                "the stream stopped after {} records without its end frame (a crash, a hang, the link was cut, or it was stopped)",
                summary.records
            )),
        };
        let Some(mut files) = self.files.take() else {
            return Ok(Finished {
                outcome,
                summary,
                written: recording::Written::default(),
            });
        };
        files.raw.flush().context("keeping the raw stream")?;
        files.csv.flush(false)?;
        files.interpolated.flush(false)?;
        files.arrivals.flush(false)?;
        files.markers.flush(false)?;
        let written = files.data.finish()?;
        let finished = Finished {
            outcome,
            summary,
            written,
        };
        crate::manifest::write(&self, &finished)?;
        let marker = self.dir.join(INCOMPLETE);
        match &finished.outcome {
            Outcome::Incomplete(why) => std::fs::write(&marker, format!("{why}\n")),
            Outcome::Complete | Outcome::Stopped => std::fs::remove_file(&marker),
        }
        .with_context(|| format!("writing {}", marker.display()))?;
        Ok(finished)
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
/// its marker, its manifest, its data set's files.
fn session_file(name: &str) -> bool {
    name == RECORDS_CSV
        || name == INTERPOLATED_CSV
        || name == ARRIVALS_CSV
        || name == MARKERS_CSV
        || name == STREAM_BIN
        || name == INCOMPLETE
        || name == crate::MANIFEST
        || recording::is_dataset_file(name)
}
