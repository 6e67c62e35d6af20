//! `live config`: the settings a device keeps ([`Stored`]) by name, as
//! `name = value` lines, read from and written to a flash image (QEMU's
//! settings file, `skin-qemu flash=PATH`) with the device's own store
//! ([`instrument::store`]). A value is checked with the device's rules
//! before anything is written; a refused set leaves the file as it was;
//! the file is replaced whole (written beside it, then renamed).

use anyhow::{anyhow, bail, Context, Result};
use instrument::store::{RamFlash, Store, REGION_BYTES, SLOT_BYTES};
use instrument::stored::{SensorSettings, Stored, SENSORS_MAX};
use std::path::Path;

/// Every setting: its name (`N` a sensor, 0 … 15), unit and range, as
/// `--help` lists them.
pub const SETTINGS: [(&str, &str, &str); 16] = [
    ("record_every", "blocks per record", "1 … 250"),
    (
        "policy.x_limit",
        "x = 2π·f·R̂·C at the remembered peak",
        "0.5 … 16",
    ),
    ("policy.hysteresis", "relative margin to switch up", "0 … 0.5"),
    ("policy.decay_per_s", "fraction of the peak per second", "0 … 10"),
    ("policy.hold_s", "s between switches up", "0 … 60"),
    (
        "policy.settle_blocks",
        "blocks discarded after a switch",
        "0 … 16",
    ),
    (
        "policy.tones",
        "lowest,highest index into the frequency set",
        "lowest first, within the set",
    ),
    ("sensor.N.in_use", "read or left out", "true, false"),
    ("sensor.N.nominal_c_farad", "F, at rest", "1e-12 … 1e-8"),
    (
        "sensor.N.nominal_r_ohm",
        "Ω, both electrodes end to end, at rest",
        "1e3 … 1e8",
    ),
    ("sensor.N.lead_ratio", "tab leads per line resistance", "0 … 50"),
    ("sensor.N.contact_ohm", "Ω in series", "0 … 1e7"),
    (
        "sensor.N.parasitic_farad",
        "F in parallel at the meter",
        "0 … 1e-9",
    ),
    (
        "sensor.N.table",
        "11 points C:stretch (F:mm), space-separated",
        "ascending in both",
    ),
    (
        "sensor.N.calibrated",
        "the table was measured on this sensor",
        "true, false",
    ),
    ("(N)", "a sensor", "0 … 15"),
];

/// The settings as `--help` shows them.
pub fn help() -> String {
    let mut s = String::from("Settings (name, unit, range):\n");
    for (name, unit, range) in SETTINGS {
        s.push_str(&format!("  {name:<26} {unit}; {range}\n"));
    }
    s
}

/// A number as `config` writes it: plain where that is short, else with
/// an exponent; either way it reads back to the same `f32`.
fn number(v: f32) -> String {
    let a = v.abs();
    match a == 0.0 || (1e-3..1e6).contains(&a) {
        true => format!("{v}"),
        false => format!("{v:e}"),
    }
}

/// Every setting of `set`, by name, in order.
pub fn entries(set: &Stored) -> Vec<(String, String)> {
    let p = &set.policy;
    let mut out = vec![
        ("record_every".to_string(), set.record_every.to_string()),
        ("policy.x_limit".into(), number(p.x_limit)),
        ("policy.hysteresis".into(), number(p.hysteresis)),
        ("policy.decay_per_s".into(), number(p.decay_per_s)),
        ("policy.hold_s".into(), number(p.hold_s)),
        ("policy.settle_blocks".into(), p.settle_blocks.to_string()),
        ("policy.tones".into(), format!("{},{}", p.tones.0, p.tones.1)),
    ];
    for (k, s) in set.sensors.iter().enumerate() {
        let at = |f: &str| format!("sensor.{k}.{f}");
        let table: Vec<String> = s
            .table
            .iter()
            .map(|&(c, mm)| format!("{}:{}", number(c), number(mm)))
            .collect();
        out.extend([
            (at("in_use"), s.in_use.to_string()),
            (at("nominal_c_farad"), number(s.nominal_c_farad)),
            (at("nominal_r_ohm"), number(s.nominal_r_ohm)),
            (at("lead_ratio"), number(s.lead_ratio)),
            (at("contact_ohm"), number(s.contact_ohm)),
            (at("parasitic_farad"), number(s.parasitic_farad)),
            (at("table"), table.join(" ")),
            (at("calibrated"), s.calibrated.to_string()),
        ]);
    }
    out
}

fn float(name: &str, v: &str) -> Result<f32> {
    v.trim()
        .parse::<f32>()
        .map_err(|_| anyhow!("{name} = {v}: not a number"))
}

fn boolean(name: &str, v: &str) -> Result<bool> {
    match v.trim() {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => bail!("{name} = {v}: true or false"),
    }
}

fn integer<T: std::str::FromStr>(name: &str, v: &str) -> Result<T> {
    v.trim()
        .parse::<T>()
        .map_err(|_| anyhow!("{name} = {v}: not a whole number in range"))
}

/// Set `name` of `set` to `value` (the rules are checked on the whole set
/// after, [`Stored::check`]).
pub fn assign(set: &mut Stored, name: &str, value: &str) -> Result<()> {
    let p = &mut set.policy;
    match name {
        "record_every" => set.record_every = integer(name, value)?,
        "policy.x_limit" => p.x_limit = float(name, value)?,
        "policy.hysteresis" => p.hysteresis = float(name, value)?,
        "policy.decay_per_s" => p.decay_per_s = float(name, value)?,
        "policy.hold_s" => p.hold_s = float(name, value)?,
        "policy.settle_blocks" => p.settle_blocks = integer(name, value)?,
        "policy.tones" => {
            let (lo, hi) = value
                .split_once(',')
                .ok_or_else(|| anyhow!("{name} = {value}: two indices, lowest,highest"))?;
            p.tones = (integer(name, lo)?, integer(name, hi)?);
        }
        _ => {
            let rest = name
                .strip_prefix("sensor.")
                .ok_or_else(|| anyhow!("{name}: no such setting (`live config get` lists them)"))?;
            let (k, field) = rest
                .split_once('.')
                .ok_or_else(|| anyhow!("{name}: sensor.N.<setting>"))?;
            let k: usize = k
                .parse()
                .ok()
                .filter(|&k| k < SENSORS_MAX)
                .ok_or_else(|| anyhow!("{name}: sensors are 0 … {}", SENSORS_MAX - 1))?;
            sensor(&mut set.sensors[k], name, field, value)?;
        }
    }
    Ok(())
}

fn sensor(s: &mut SensorSettings, name: &str, field: &str, value: &str) -> Result<()> {
    match field {
        "in_use" => s.in_use = boolean(name, value)?,
        "nominal_c_farad" => s.nominal_c_farad = float(name, value)?,
        "nominal_r_ohm" => s.nominal_r_ohm = float(name, value)?,
        "lead_ratio" => s.lead_ratio = float(name, value)?,
        "contact_ohm" => s.contact_ohm = float(name, value)?,
        "parasitic_farad" => s.parasitic_farad = float(name, value)?,
        "calibrated" => s.calibrated = boolean(name, value)?,
        "table" => {
            let points: Vec<&str> = value.split_whitespace().collect();
            if points.len() != s.table.len() {
                bail!("{name}: {} points C:stretch, not {}", s.table.len(), points.len());
            }
            for (slot, p) in s.table.iter_mut().zip(points) {
                let (c, mm) = p
                    .split_once(':')
                    .ok_or_else(|| anyhow!("{name}: '{p}' is not C:stretch"))?;
                *slot = (float(name, c)?, float(name, mm)?);
            }
        }
        _ => bail!("{name}: no such setting (`live config get` lists them)"),
    }
    Ok(())
}

/// The set stored in the flash image at `path` and its generation; None
/// if the image holds none (a new device).
pub fn read_image(path: &Path) -> Result<Option<(Stored, u32)>> {
    let mut image = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    if image.len() != REGION_BYTES {
        bail!(
            "{}: {} bytes, not a settings flash image ({REGION_BYTES} bytes)",
            path.display(),
            image.len()
        );
    }
    let mut store = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES).map_err(|e| anyhow!("{e:?}"))?;
    let loaded = store.load().map_err(|e| anyhow!("{}: {e:?}", path.display()))?;
    Ok(loaded.map(|l| (l.set, l.generation)))
}

/// Store `set` in the flash image at `path` (created erased if missing),
/// as the device would: the rules checked first, then written to the
/// slot not in force; the file replaced whole. The new generation.
pub fn write_image(path: &Path, set: &Stored) -> Result<u32> {
    set.check().map_err(|r| anyhow!("refused: {r}"))?;
    let mut image = match std::fs::read(path) {
        Ok(b) if b.len() == REGION_BYTES => b,
        Ok(b) => bail!(
            "{}: {} bytes, not a settings flash image ({REGION_BYTES} bytes)",
            path.display(),
            b.len()
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => vec![0xFF; REGION_BYTES],
        Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
    };
    let generation = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES)
        .map_err(|e| anyhow!("{e:?}"))?
        .save(set)
        .map_err(|e| anyhow!("{}: {e:?}", path.display()))?;
    let tmp = path.with_extension("bin.new");
    std::fs::write(&tmp, &image).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("replacing {}", path.display()))?;
    Ok(generation)
}

/// A device on the link: requests down, replies up (records passed over).
pub struct Device<S> {
    port: S,
    encoder: link::Encoder,
    decoder: link::Decoder,
    buf: std::collections::VecDeque<u8>,
    timeout: std::time::Duration,
}

impl<S: std::io::Read + std::io::Write> Device<S> {
    /// The device at the other end of `port` (reads on it time out, so
    /// that a silent device is an error, not a hang).
    pub fn new(port: S, timeout: std::time::Duration) -> Self {
        Self {
            port,
            encoder: link::Encoder::new(),
            decoder: link::Decoder::new(),
            buf: std::collections::VecDeque::new(),
            timeout,
        }
    }

    fn send(&mut self, req: link::Request) -> Result<u32> {
        let mut out = [0u8; link::MAX_FRAME];
        let seq = self.encoder.next_seq();
        let bytes = self
            .encoder
            .frame(link::Body::Request(req), &mut out)
            .map_err(|e| anyhow!("encoding a request: {e}"))?;
        self.port.write_all(bytes).context("writing to the device")?;
        Ok(seq)
    }

    /// The next reply to request `seq`.
    fn reply(&mut self, seq: u32) -> Result<link::Reply> {
        let start = std::time::Instant::now();
        let mut chunk = [0u8; 4096];
        loop {
            while let Some(b) = self.buf.pop_front() {
                if let Some(Ok(link::Frame {
                    body: link::Body::Reply(r),
                    ..
                })) = self.decoder.push(b)
                {
                    let to = match r {
                        link::Reply::Ack { to, .. }
                        | link::Reply::Refused { to, .. }
                        | link::Reply::Chunk { to, .. } => to,
                    };
                    if to == seq {
                        return Ok(r);
                    }
                }
            }
            if start.elapsed() > self.timeout {
                bail!("no reply from the device in {:?}", self.timeout);
            }
            match self.port.read(&mut chunk) {
                Ok(0) => bail!("the device closed the link"),
                Ok(n) => self.buf.extend(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => return Err(e).context("reading from the device"),
            }
        }
    }

    /// The set stored on the device and its generation; None on a new
    /// device.
    pub fn read(&mut self) -> Result<Option<(Stored, u32)>> {
        let seq = self.send(link::Request::ReadSettings)?;
        let mut bytes = vec![];
        loop {
            match self.reply(seq)? {
                link::Reply::Chunk { chunk, .. } => {
                    if usize::from(chunk.offset) != bytes.len() {
                        bail!("the device's pieces came out of order");
                    }
                    bytes.extend_from_slice(chunk.data());
                }
                link::Reply::Ack { generation, .. } => {
                    return match Stored::from_bytes(&bytes) {
                        Some(Ok(set)) => Ok(Some((set, generation))),
                        Some(Err(r)) => bail!("the device's set breaks a rule: {r}"),
                        None => bail!("the device's set is not of this layout (update the host tools?)"),
                    };
                }
                link::Reply::Refused {
                    reason: link::Reason::NothingStored,
                    ..
                } => return Ok(None),
                link::Reply::Refused { reason, .. } => {
                    bail!("the device refused to read: {}", reason_text(reason))
                }
            }
        }
    }

    /// Store `set` on the device; its generation.
    pub fn write(&mut self, set: &Stored) -> Result<u32> {
        set.check().map_err(|r| anyhow!("refused: {r}"))?;
        let mut reqs = vec![];
        instrument::commands::upload(set, |r| reqs.push(r));
        for req in reqs {
            let seq = self.send(req)?;
            match self.reply(seq)? {
                link::Reply::Ack { generation, .. } if matches!(req, link::Request::Commit { .. }) => {
                    return Ok(generation)
                }
                link::Reply::Ack { .. } => {}
                link::Reply::Refused { reason, .. } => bail!("the device refused: {}", reason_text(reason)),
                link::Reply::Chunk { .. } => bail!("the device answered a write with a read"),
            }
        }
        bail!("the set's upload had no commit")
    }

    /// Ask the device to stop measuring (its stream's end frame follows).
    pub fn stop(&mut self) -> Result<()> {
        let seq = self.send(link::Request::Stop)?;
        match self.reply(seq)? {
            link::Reply::Ack { .. } => Ok(()),
            other => bail!("the device did not stop: {other:?}"),
        }
    }
}

/// A refusal in words.
pub fn reason_text(reason: link::Reason) -> String {
    use instrument::stored::{Refused, Rule};
    match reason {
        link::Reason::Setting { sensor, rule } => match Rule::from_code(rule) {
            Some(rule) => Refused {
                sensor: (sensor != 255).then_some(sensor),
                rule,
            }
            .to_string(),
            None => format!("rule {rule} (a newer firmware's?)"),
        },
        link::Reason::OutOfOrder => "a piece came out of order".into(),
        link::Reason::TooLong => "more bytes than a set can have".into(),
        link::Reason::Mismatch => "the pieces do not match the commit's length and CRC".into(),
        link::Reason::Malformed => "not a set of the device's layout".into(),
        link::Reason::Flash => "the device's flash failed (its set in force is kept)".into(),
        link::Reason::NothingStored => "nothing is stored".into(),
        link::Reason::OutOfRange => "a value outside the request's range".into(),
        link::Reason::Unsupported => "this device does not do that (a sweep on a device of one tone)".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_setting_reads_back_as_it_was_written() {
        let mut set = Stored::uncalibrated();
        set.sensors[3].parasitic_farad = 4.7e-12;
        set.sensors[3].lead_ratio = 0.6415;
        set.policy.tones = (1, 3);
        let mut again = Stored::uncalibrated();
        for (name, value) in entries(&set) {
            assign(&mut again, &name, &value).unwrap();
        }
        assert_eq!(again, set);
        assert_eq!(entries(&set).len(), 7 + 8 * SENSORS_MAX);
    }

    #[test]
    fn bad_names_and_values_say_which_and_why() {
        let mut set = Stored::uncalibrated();
        let err = |n: &str, v: &str, s: &mut Stored| assign(s, n, v).unwrap_err().to_string();
        assert!(err("sensor.16.lead_ratio", "1", &mut set).contains("sensors are 0 … 15"));
        assert!(err("sensor.2.colour", "1", &mut set).contains("no such setting"));
        assert!(err("policy.x_limit", "four", &mut set).contains("not a number"));
        assert!(err("sensor.0.in_use", "yes", &mut set).contains("true or false"));
        assert!(err("sensor.0.table", "1e-10:0", &mut set).contains("11 points"));
        assert!(err("record_every", "300", &mut set).contains("not a whole number"));
    }
}
