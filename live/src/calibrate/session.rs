//! A calibration session with a device: its records as they arrive and
//! its clock, the guided steps (open fixture, holds, sweeps), and the
//! set stored at the end.

use super::*;
use anyhow::{bail, Context, Result};
use instrument::stored::Stored;

/// The records in a recorded stream (frames that fail their check are
/// passed over, as `live` counts them).
pub fn records_of(bytes: &[u8]) -> Vec<link::Record> {
    let mut dec = link::Decoder::new();
    bytes
        .iter()
        .filter_map(|&b| match dec.push(b) {
            Some(Ok(link::Frame {
                body: link::Body::Record(r),
                ..
            })) => Some(r),
            _ => None,
        })
        .collect()
}

/// A device's records as they arrive, and its clock (the newest record's
/// time).
pub(crate) struct Clock<S> {
    port: S,
    dec: link::Decoder,
    enc: link::Encoder,
    records: Vec<link::Record>,
    /// The device's replies to requests sent through the clock.
    replies: Vec<link::Reply>,
    raw: Vec<u8>,
    /// The newest record's time, s since the device's start.
    now_s: f64,
    timeout: std::time::Duration,
}

impl<S: std::io::Read> Clock<S> {
    fn new(port: S, timeout: std::time::Duration) -> Self {
        Self {
            port,
            dec: link::Decoder::new(),
            enc: link::Encoder::new(),
            records: vec![],
            replies: vec![],
            raw: vec![],
            now_s: f64::NEG_INFINITY,
            timeout,
        }
    }

    /// One read: the bytes' records taken, and whether the read filled
    /// its buffer (more is waiting). An error if the device closed the
    /// link or sent nothing for the timeout.
    fn pump(&mut self, quiet_since: &mut std::time::Instant) -> Result<bool> {
        let mut chunk = [0u8; 4096];
        match self.port.read(&mut chunk) {
            Ok(0) => bail!(
                "the device closed the link at {:.2} s of its clock",
                self.now_s.max(0.0)
            ),
            Ok(n) => {
                *quiet_since = std::time::Instant::now();
                self.raw.extend_from_slice(&chunk[..n]);
                for &b in &chunk[..n] {
                    match self.dec.push(b) {
                        Some(Ok(link::Frame {
                            body: link::Body::Record(r),
                            ..
                        })) => {
                            self.now_s = self.now_s.max(r.t_us as f64 * 1e-6);
                            self.records.push(r);
                        }
                        Some(Ok(link::Frame {
                            body: link::Body::Reply(r),
                            ..
                        })) => self.replies.push(r),
                        _ => {}
                    }
                }
                Ok(n == chunk.len())
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                if quiet_since.elapsed() > self.timeout {
                    bail!("no records from the device in {:?}", self.timeout);
                }
                Ok(false)
            }
            Err(e) => Err(e).context("reading from the device"),
        }
    }

    /// Read until the device's clock has passed `t_s`.
    fn until(&mut self, t_s: f64) -> Result<()> {
        let mut quiet = std::time::Instant::now();
        while self.now_s <= t_s {
            self.pump(&mut quiet)?;
        }
        Ok(())
    }

    /// Send `req` (its reply, when it comes, joins `replies`).
    fn request(&mut self, req: link::Request) -> Result<()>
    where
        S: std::io::Write,
    {
        let mut out = [0u8; link::MAX_FRAME];
        let bytes = self
            .enc
            .frame(link::Body::Request(req), &mut out)
            .map_err(|e| anyhow::anyhow!("encoding a request: {e}"))?;
        self.port.write_all(bytes).context("writing to the device")
    }

    /// Read what is waiting, so that the clock is the device's now.
    fn catch_up(&mut self) -> Result<()> {
        let mut quiet = std::time::Instant::now();
        while self.pump(&mut quiet)? || self.now_s == f64::NEG_INFINITY {}
        Ok(())
    }
}

/// Read a recorded stream's worth of records from a device until its
/// clock has passed `until_s`. The records, and the raw bytes read.
pub fn collect(
    port: &mut impl std::io::Read,
    until_s: f64,
    timeout: std::time::Duration,
) -> Result<(Vec<link::Record>, Vec<u8>)> {
    let mut clock = Clock::new(port, timeout);
    clock.until(until_s)?;
    Ok((clock.records, clock.raw))
}

/// A calibration done on a device.
#[derive(Debug)]
pub struct Done {
    /// The holds the fit used.
    pub holds: Vec<Hold>,
    /// The set stored.
    pub set: Stored,
    /// Its generation on the device.
    pub generation: u32,
    /// Each sensor's outcome.
    pub outcomes: Vec<Outcome>,
    /// The raw bytes of the records the fit used.
    pub stream: Vec<u8>,
    /// What the device said of the steps' sweeps: acknowledged, or why
    /// not (measured at the policy's tones then).
    pub sweeps: Vec<String>,
    /// The open fixture's span, if one was measured.
    pub open: Option<Span>,
}

/// Fit the records the clock read, write the set down the link, and stop
/// the device if asked.
pub(crate) fn finish<S: std::io::Read + std::io::Write>(
    clock: Clock<S>,
    holds: Vec<Hold>,
    opts: &Options,
    stop: bool,
) -> Result<Done> {
    let timeout = clock.timeout;
    let mut dev = crate::config::Device::new(clock.port, timeout);
    let base = dev.read()?.map_or_else(Stored::uncalibrated, |(s, _)| s);
    let (set, outcomes) = calibrate(&clock.records, &holds, &base, opts);
    if !outcomes.iter().any(|o| matches!(o, Outcome::Fitted(_))) {
        bail!("no sensor could be calibrated:\n{}", report(&holds, &outcomes));
    }
    let generation = dev.write(&set)?;
    if stop {
        dev.stop()?;
    }
    let sweeps = clock
        .replies
        .iter()
        .map(|r| match r {
            link::Reply::Refused { reason, .. } => {
                format!("sweep refused: {}", crate::config::reason_text(*reason))
            }
            _ => "swept".to_string(),
        })
        .collect();
    Ok(Done {
        holds,
        set,
        generation,
        outcomes,
        stream: clock.raw,
        sweeps,
        open: opts.open,
    })
}

/// Calibrate the device at the other end of `port` while it runs through
/// `holds` (spans of its clock): its records until the last hold ends,
/// each sensor fitted, the set written down the link (the device checks
/// it and stores it; it measures with it from its next block, the
/// multiplexed board from its next start), and, with
/// `stop`, the device stopped.
pub fn on_device<S: std::io::Read + std::io::Write>(
    port: S,
    holds: &[Hold],
    opts: &Options,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<Done> {
    let mut clock = Clock::new(port, timeout);
    clock.until(holds.iter().map(|h| h.to_s).fold(0.0, f64::max))?;
    finish(clock, holds.to_vec(), opts, stop)
}

/// When a guided step's hold begins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ready {
    /// Now (the user pressed Enter).
    Now,
    /// At this time of the device's clock, s (a stage that moves on a
    /// schedule).
    At(f64),
}

/// A step of a guided calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Every sensor unplugged, its cable left on the front end (the open
    /// fixture: first, if asked for).
    Open,
    /// The skin held at this stretch, mm (sensors plugged in).
    Stretch(f64),
}

/// The longest hold or settling a guided calibration takes, s (an hour:
/// a sensor's drift over longer says nothing of its stretch).
pub const HOLD_MAX_S: f64 = 3600.0;

/// A guided calibration: the stretches to hold in turn, how long each
/// move settles and each hold is measured.
#[derive(Clone, Debug)]
pub struct Guide {
    /// Measure an open fixture first ([`Step::Open`]).
    pub open: bool,
    /// Stretches, mm, in the order held (0 first).
    pub at_mm: Vec<f64>,
    /// Left out after each move, s.
    pub settle_s: f64,
    /// Measured at each stretch, s.
    pub hold_s: f64,
    /// Ask the device to sweep its tone pairs over each hold (a
    /// calibration step: every sensor measured at every tone of the
    /// comb); a device without tone pairs refuses and measures at its
    /// policy's tone.
    pub sweep: bool,
}

/// Blocks per pair of a sweep over `span_s` of the array's clock
/// (`link::Request::Sweep`: four pairs) in blocks of `block_s`
/// ([`block_s_of`]), at most the link's limit.
pub fn sweep_blocks(span_s: f64, block_s: f64) -> u16 {
    let pairs = instrument::sweep::PAIRS.len() as f64;
    ((span_s / (pairs * block_s)).ceil() as u16).clamp(1, link::SWEEP_MAX_BLOCKS)
}

/// A device's block period, s, from its records: the shortest time
/// between two records of one sensor (4 ms blocks give 0.004, 1 ms
/// blocks 0.001; a device reporting one block in n gives n blocks);
/// `None` before a sensor has two.
pub fn block_s_of(records: &[link::Record]) -> Option<f64> {
    let mut last = std::collections::HashMap::new();
    let mut best: Option<u64> = None;
    for r in records {
        if let Some(t0) = last.insert(r.sensor, r.t_us) {
            if r.t_us > t0 {
                let d = r.t_us - t0;
                best = Some(best.map_or(d, |b| b.min(d)));
            }
        }
    }
    best.map(|us| us as f64 * 1e-6)
}

/// Calibrate the device at the other end of `port`, step by step: for
/// each step of `guide` (the open fixture if asked, then each stretch),
/// `ready(k, step, device_now_s)` says when it is in place (after asking
/// the user, or from a schedule); it is measured from then plus the
/// settling for `hold_s` of the device's clock. Then as [`on_device`]:
/// fitted (with the open fixture's span), written, stopped if asked.
pub fn guided<S: std::io::Read + std::io::Write>(
    port: S,
    guide: &Guide,
    ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
    opts: &Options,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<Done> {
    let mut clock = Clock::new(port, timeout);
    let (holds, open) = gather(&mut clock, guide, ready)?;
    let opts = Options {
        open: open.or(opts.open),
        ..*opts
    };
    finish(clock, holds, &opts, stop)
}

/// A device measured again, step by step as [`guided`] (no sweep: the
/// device reads as it will in use), nothing written, stopped after if
/// `stop`: each sensor's stretch at each hold ([`verify`]), the holds,
/// and the raw stream.
pub fn verify_guided<S: std::io::Read + std::io::Write>(
    port: S,
    guide: &Guide,
    ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<(Vec<Hold>, Vec<Check>, Vec<u8>)> {
    let mut clock = Clock::new(port, timeout);
    let guide = Guide {
        sweep: false,
        open: false,
        ..guide.clone()
    };
    let (holds, _) = gather(&mut clock, &guide, ready)?;
    let checks = verify(&clock.records, &holds);
    if stop {
        crate::config::Device::new(clock.port, timeout).stop()?;
    }
    Ok((holds, checks, clock.raw))
}

/// The holds of a guided run and the open fixture's span, the clock
/// reading through them.
pub(crate) fn gather<S: std::io::Read + std::io::Write>(
    clock: &mut Clock<S>,
    guide: &Guide,
    mut ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
) -> Result<(Vec<Hold>, Option<Span>)> {
    if guide.at_mm.len() < 2 {
        bail!("a calibration needs two stretches at least");
    }
    if !(guide.hold_s > 0.0 && guide.hold_s <= HOLD_MAX_S) {
        bail!(
            "a hold lasts more than 0 s and {HOLD_MAX_S} s at most, not {} s",
            guide.hold_s
        );
    }
    if !(guide.settle_s >= 0.0 && guide.settle_s <= HOLD_MAX_S) {
        bail!("the settling lasts 0 to {HOLD_MAX_S} s, not {} s", guide.settle_s);
    }
    let mut holds = vec![];
    let mut open = None;
    let steps = guide
        .open
        .then_some(Step::Open)
        .into_iter()
        .chain(guide.at_mm.iter().map(|&s| Step::Stretch(s)));
    for (k, step) in steps.enumerate() {
        clock.catch_up()?;
        let t0 = match ready(k, step, clock.now_s)? {
            Ready::Now => clock.now_s,
            Ready::At(t) => t.max(clock.now_s),
        };
        if guide.sweep {
            clock.until(t0)?;
            // The device's blocks, as its records are spaced (an array
            // device in 4 ms blocks, unless it said otherwise).
            let block_s = block_s_of(&clock.records)
                .unwrap_or(instrument::array::Layout::BLOCK_4MS.block_us() as f64 * 1e-6);
            clock.request(link::Request::Sweep {
                blocks_per_pair: sweep_blocks(guide.settle_s + guide.hold_s, block_s),
            })?;
        }
        let (from_s, to_s) = (t0 + guide.settle_s, t0 + guide.settle_s + guide.hold_s);
        clock.until(to_s)?;
        match step {
            Step::Open => open = Some((from_s, to_s)),
            Step::Stretch(stretch_mm) => holds.push(Hold {
                stretch_mm,
                from_s,
                to_s,
                sensor: None,
            }),
        }
    }
    Ok((holds, open))
}
