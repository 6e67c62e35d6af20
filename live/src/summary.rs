//! What a session received, in numbers: counted as records arrive (a
//! few numbers per sensor, whatever the session's length).

use instrument::availability::Availability;
use std::collections::BTreeMap;

/// Records that decoded but that the stream's own terms rule out: set
/// aside (not written), counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SetAside {
    /// Of a sensor beyond the count the start frame gave.
    pub beyond_sensors: u64,
    /// Not after its sensor's previous record in time (time going
    /// backwards).
    pub not_later: u64,
}

impl SetAside {
    /// How many in all.
    pub fn total(&self) -> u64 {
        self.beyond_sensors + self.not_later
    }
}

/// A sensor's records in one segment: how many, the first and last
/// time, µs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Span {
    pub n: usize,
    pub first_us: u64,
    pub last_us: u64,
}

/// The counts a session keeps as records arrive.
#[derive(Clone, Debug, Default)]
pub(crate) struct Counts {
    pub records: usize,
    pub flagged: usize,
    /// Per segment and sensor.
    pub spans: BTreeMap<(u32, u8), Span>,
    pub set_aside: SetAside,
    /// Per sensor, over the session.
    pub availability: BTreeMap<u8, Availability>,
}

impl Counts {
    /// Count record `r` of `segment`, kept.
    pub fn record(&mut self, segment: u32, r: &link::Record) {
        self.records += 1;
        let flags = instrument::faults::Flags(r.flags);
        if !flags.valid() {
            self.flagged += 1;
        }
        self.availability.entry(r.sensor).or_default().count(flags);
        self.spans
            .entry((segment, r.sensor))
            .and_modify(|s| {
                s.n += 1;
                s.last_us = r.t_us;
            })
            .or_insert(Span {
                n: 1,
                first_us: r.t_us,
                last_us: r.t_us,
            });
    }

    /// Sensors heard from.
    pub fn sensors(&self) -> usize {
        let mut ids: Vec<u8> = self.spans.keys().map(|&(_, s)| s).collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    }

    /// Records per second per sensor (within a segment): least and most.
    pub fn rate(&self) -> (f64, f64) {
        let rates: Vec<f64> = self
            .spans
            .values()
            .filter(|s| s.n > 1 && s.last_us > s.first_us)
            .map(|s| (s.n - 1) as f64 / ((s.last_us - s.first_us) as f64 * 1e-6))
            .collect();
        (
            rates.iter().copied().fold(f64::NAN, f64::min),
            rates.iter().copied().fold(f64::NAN, f64::max),
        )
    }
}

/// How the device's CPU kept up, from its status frames
/// ([`link::Status`]): summed over a segment or a session.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cpu {
    /// The latest status.
    pub last: link::Status,
    /// Status frames received.
    pub reports: u64,
    /// Blocks they counted.
    pub blocks: u64,
    /// The blocks' mean time, in the clock's units.
    pub mean: f64,
    /// The longest a block took.
    pub max: u32,
    /// Blocks that took longer than their period (records flagged `LATE`).
    pub late: u64,
    /// Blocks never processed.
    pub missed: u64,
}

impl Cpu {
    /// From a first status.
    pub fn new(s: &link::Status) -> Self {
        Self {
            last: *s,
            reports: 1,
            blocks: u64::from(s.blocks),
            mean: f64::from(s.mean),
            max: s.max,
            late: u64::from(s.late),
            missed: u64::from(s.missed),
        }
    }

    /// Another status counted in.
    pub fn add(&mut self, s: &link::Status) {
        *self = self.and(Self::new(s));
    }

    /// Two sums counted as one (two segments of a session).
    pub fn merge(a: Option<Self>, b: Option<Self>) -> Option<Self> {
        match (a, b) {
            (Some(a), Some(b)) => Some(a.and(b)),
            (a, b) => a.or(b),
        }
    }

    /// `self` then `b`: counts summed, the mean weighted by blocks, `b`'s
    /// status the latest.
    fn and(mut self, b: Self) -> Self {
        let n = self.blocks + b.blocks;
        if n > 0 {
            self.mean = (self.mean * self.blocks as f64 + b.mean * b.blocks as f64) / n as f64;
        }
        self.blocks = n;
        self.max = self.max.max(b.max);
        self.late += b.late;
        self.missed += b.missed;
        self.reports += b.reports;
        self.last = b.last;
        self
    }

    /// A time as a share of a block's period, %.
    pub fn share(&self, t: f64) -> f64 {
        100.0 * t / f64::from(self.last.period.max(1))
    }

    /// What the clock counts, in words.
    pub fn unit(&self) -> &'static str {
        match self.last.clock {
            link::Clock::Cycles => "cycles",
            link::Clock::Instructions => "instructions (QEMU)",
        }
    }

    /// One clause for a terminal.
    pub fn line(&self) -> String {
        format!(
            "device CPU: a block takes {:.1} % of its period on average, {:.1} % at most ({:.0} / {} of {} {}); {} late, {} missed",
            self.share(self.mean),
            self.share(f64::from(self.max)),
            self.mean,
            self.max,
            self.last.period,
            self.unit(),
            self.late,
            self.missed
        )
    }
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
    /// The link's counts: frames decoded, refused, lost (numbers never
    /// seen), repeated (a frame again, dropped).
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
    /// Times the device restarted (a start frame again): the session's
    /// segments less one.
    pub restarts: u32,
    /// Where the end frame's count of records sent disagrees with what
    /// arrived: how.
    pub end_mismatch: Option<String>,
    /// How the device's CPU kept up (its status frames), if it said.
    pub cpu: Option<Cpu>,
    /// Per sensor: the share of its records valid, and the faults that
    /// stood on the others.
    pub availability: BTreeMap<u8, Availability>,
    /// Per sensor: its records not valid given a value from their valid
    /// neighbours (`interpolated.csv`).
    pub interpolated: BTreeMap<u8, u64>,
}

impl Summary {
    /// Mean bytes on the wire per record.
    pub fn bytes_per_record(&self) -> f64 {
        self.bytes as f64 / self.records.max(1) as f64
    }

    /// One line for a terminal.
    pub fn line(&self) -> String {
        format!(
            "{} records from {} sensors ({:.1}–{:.1} records/s each), {} flagged ({} interpolated){}; {:.1} bytes per record; frames: {} refused, {} lost, {} repeated{}",
            self.records,
            self.sensors,
            self.rate.0,
            self.rate.1,
            self.flagged,
            self.interpolated.values().sum::<u64>(),
            self.least_valid().map_or(String::new(), |(s, a)| format!(
                " (the least valid: sensor {s}, {:.1} %)",
                100.0 * a.share().unwrap_or(0.0)
            )),
            self.bytes_per_record(),
            self.link.bad,
            self.link.lost,
            self.link.repeated,
            self.dropped.map_or(String::new(), |d| format!("; {d} dropped on the device"))
        ) + &self.remarks()
    }

    /// The sensor with the least share of its records valid, and that
    /// share.
    pub fn least_valid(&self) -> Option<(u8, &Availability)> {
        self.availability
            .iter()
            .filter(|(_, a)| a.share().is_some())
            .min_by(|a, b| {
                a.1.share()
                    .partial_cmp(&b.1.share())
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .map(|(&s, a)| (s, a))
    }

    /// A line per sensor: the share of its records valid, and why the
    /// others were not (`sensor 3: 88.1 % valid (1980 of 2250); not:
    /// MODEL 200, UNCERTAIN 70`).
    pub fn availability_lines(&self) -> Vec<String> {
        self.availability
            .iter()
            .map(|(s, a)| {
                let why = if a.invalid() > 0 {
                    let filled = self.interpolated.get(s).copied().unwrap_or(0);
                    format!("; not: {}; {filled} of them interpolated", a.why())
                } else {
                    String::new()
                };
                format!("sensor {s}: {a}{why}")
            })
            .collect()
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
            out += &format!(
                "; {} records not later than their sensor's last set aside (time went backwards)",
                a.not_later
            );
        }
        if self.restarts > 0 {
            out += &format!(
                "; the device restarted {} time(s): {} segments",
                self.restarts,
                self.restarts + 1
            );
        }
        if let Some(m) = &self.end_mismatch {
            out += &format!("; {m}");
        }
        if let Some(c) = &self.cpu {
            out += &format!("; {}", c.line());
        }
        out
    }
}

/// A sensor's availability as the manifest (`records.per_sensor`) and
/// the dashboard (event `valid`) give it: its records, how many valid,
/// the share valid, the count of each fault flag among the others (and
/// the same in words, most frequent first: `MODEL 40, DISTURBED 23`, `–`
/// for none), and how many of those `interpolated.csv` gives a value.
pub(crate) fn availability_json(sensor: u8, a: &Availability, interpolated: u64) -> serde_json::Value {
    serde_json::json!({
        "sensor": sensor,
        "records": a.records,
        "valid": a.valid,
        "share_valid": a.share(),
        "not_valid_by_fault": a
            .reasons()
            .map(|(n, k)| (n.to_string(), serde_json::json!(k)))
            .collect::<serde_json::Map<_, _>>(),
        "why": a.why().to_string(),
        "interpolated": interpolated,
    })
}
