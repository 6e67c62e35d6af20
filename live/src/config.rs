//! `live config`: the settings a device keeps ([`Stored`]) by name, as
//! `name = value` lines, read from and written to a flash image (QEMU's
//! settings file, `skin-qemu flash=PATH`) with the device's own store
//! ([`instrument::store`]). A value is checked with the device's rules
//! before anything is written; a refused set leaves the file as it was;
//! the file is replaced whole (written beside it under a name of its own,
//! then renamed), one writer at a time ([`update_image`]).

use anyhow::{anyhow, bail, Context, Result};
use instrument::store::{RamFlash, SlotState, Store, REGION_BYTES, SLOT_BYTES};
use instrument::stored::{SensorSettings, Stored, SENSORS_MAX};
use std::path::Path;

/// Every setting: its name (`N` a sensor, 0 … 15), unit and range, as
/// `--help` lists them.
pub const SETTINGS: [(&str, &str, &str); 17] = [
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
    (
        "sensor.N.loss_tangent",
        "tan δ of the sensor's film as calibrated; none: its material's",
        "0 … 0.1, none",
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
            (at("loss_tangent"), s.loss_tangent.map_or("none".into(), number)),
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
        "loss_tangent" => {
            s.loss_tangent = match value.trim() {
                "none" => None,
                v => Some(float(name, v)?),
            }
        }
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
/// if the image is erased (a new device). An image that holds data but
/// no set that reads back is an error that says so.
pub fn read_image(path: &Path) -> Result<Option<(Stored, u32)>> {
    refuse_link(path)?;
    let image = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    match load(path, image)? {
        (None, false) => bail!("{}", unreadable_message(path)),
        (loaded, _) => Ok(loaded),
    }
}

fn unreadable_message(path: &Path) -> String {
    let why = slot_report(path).map_or_else(|e| format!("{e:#}"), |r| r.join("; "));
    format!(
        "{}: the image holds data but no set that reads back: {why}",
        path.display()
    )
}

/// Each spoiled slot of the flash image at `path`, named with what is
/// wrong with it (slot A, then B), and which slot is in force if one is:
/// empty where no slot is spoiled.
pub fn spoiled_slots(path: &Path) -> Result<Vec<String>> {
    let states = slot_states(path)?;
    if !states.iter().any(|s| s.spoiled()) {
        return Ok(vec![]);
    }
    slot_report(path)
}

/// Every slot of the image at `path`, in words.
fn slot_report(path: &Path) -> Result<Vec<String>> {
    let states = slot_states(path)?;
    let name = |k: usize| if k == 0 { "A" } else { "B" };
    Ok(states
        .iter()
        .enumerate()
        .map(|(k, s)| match s {
            SlotState::Valid(g) => format!("slot {} holds a valid set (generation {g})", name(k)),
            s if s.spoiled() => format!("slot {} is spoiled: it holds {}", name(k), s.describe()),
            s => format!("slot {} holds {}", name(k), s.describe()),
        })
        .collect())
}

/// What each slot of the image at `path` holds.
fn slot_states(path: &Path) -> Result<[SlotState; 2]> {
    let mut image = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    if image.len() != REGION_BYTES {
        bail!("{}: not a settings flash image", path.display());
    }
    Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES)
        .map_err(|e| anyhow!("{e:?}"))?
        .inspect()
        .map_err(|e| anyhow!("{}: {e:?}", path.display()))
}

/// The set `image` (the flash image at `path`) holds and its
/// generation, and whether it is erased throughout (a new device's).
fn load(path: &Path, mut image: Vec<u8>) -> Result<(Option<(Stored, u32)>, bool)> {
    if image.len() != REGION_BYTES {
        bail!(
            "{}: {} bytes, not a settings flash image ({REGION_BYTES} bytes)",
            path.display(),
            image.len()
        );
    }
    let erased = image.iter().all(|&b| b == 0xFF);
    let mut store = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES).map_err(|e| anyhow!("{e:?}"))?;
    let loaded = store.load().map_err(|e| anyhow!("{}: {e:?}", path.display()))?;
    Ok((loaded.map(|l| (l.set, l.generation)), erased))
}

/// Store `set` in the flash image at `path` (created erased if missing),
/// as the device would: the rules checked first, then written to the
/// slot not in force; the file replaced whole. The new generation.
/// ([`update_image`] with a change that ignores what was there.)
pub fn write_image(path: &Path, set: &Stored) -> Result<u32> {
    update_image(path, Unreadable::Replace, |_| Ok(*set)).map(|(_, g)| g)
}

/// What [`update_image`] does with an image that holds data but no set
/// that reads back (a slot a bit flip or a torn write spoiled).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unreadable {
    /// Refuse: the calibration it held may be recovered yet.
    Refuse,
    /// Store the new set (the change starts from nothing stored).
    Replace,
}

/// Read the set in the flash image at `path`, `change` it and store the
/// result (created erased if missing), as one step: writers to one image
/// wait for each other (an exclusive lock on `path`.lock), and the file
/// must still be what was read when the new one replaces it. The new
/// file is written beside it under a name of its own, then renamed over
/// it; a symbolic link at `path` or at the lock is refused. An image
/// that holds data but no readable set is refused unless `unreadable`
/// says to replace it. The set stored and its generation.
pub fn update_image(
    path: &Path,
    unreadable: Unreadable,
    change: impl FnOnce(Option<Stored>) -> Result<Stored>,
) -> Result<(Stored, u32)> {
    refuse_link(path)?;
    let _lock = lock(path)?;
    let before = read_if_there(path)?;
    let current = match &before {
        None => None,
        Some(image) => match load(path, image.clone())? {
            (None, false) if unreadable == Unreadable::Refuse => bail!(
                "{}: refusing to store a set made from the defaults over it (`live config set --replace-unreadable` does)",
                unreadable_message(path)
            ),
            (loaded, _) => loaded.map(|(s, _)| s),
        },
    };
    let set = change(current)?;
    set.check().map_err(|r| anyhow!("refused: {r}"))?;
    let mut image = before.clone().unwrap_or_else(|| vec![0xFF; REGION_BYTES]);
    let generation = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES)
        .map_err(|e| anyhow!("{e:?}"))?
        .save(&set)
        .map_err(|e| anyhow!("{}: {e:?}", path.display()))?;
    replace(path, &image, before.as_deref())?;
    Ok((set, generation))
}

/// The file at `path`, None where there is none.
fn read_if_there(path: &Path) -> Result<Option<Vec<u8>>> {
    match std::fs::read(path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e).with_context(|| format!("reading {}", path.display())),
    }
}

/// Refuse a symbolic link at `path`: a settings file is written where it
/// is, never through a link planted there.
fn refuse_link(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            bail!("{}: a symbolic link, not a flash image: refused", path.display())
        }
        _ => Ok(()),
    }
}

/// The lock beside `path` (`path`.lock), held exclusively until dropped.
fn lock(path: &Path) -> Result<std::fs::File> {
    let mut name = path.as_os_str().to_owned();
    name.push(".lock");
    let at = std::path::PathBuf::from(name);
    refuse_link(&at)?;
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&at)
        .with_context(|| format!("opening {}", at.display()))?;
    file.lock().with_context(|| format!("locking {}", at.display()))?;
    Ok(file)
}

/// Replace the file at `path` with `image`, if it still holds `before`
/// (None: there was none): written to a new file of its own in the same
/// folder, then renamed over it.
fn replace(path: &Path, image: &[u8], before: Option<&[u8]>) -> Result<()> {
    use std::io::Write as _;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".flash-")
        .tempfile_in(dir)
        .with_context(|| format!("a new file in {}", dir.display()))?;
    tmp.write_all(image)
        .and_then(|()| tmp.as_file().sync_all())
        .with_context(|| format!("writing {}", tmp.path().display()))?;
    if read_if_there(path)?.as_deref() != before {
        bail!(
            "{}: changed while the new set was being written (a device running on it?): nothing stored",
            path.display()
        );
    }
    tmp.persist(path)
        .map_err(|e| anyhow!("replacing {}: {}", path.display(), e.error))?;
    Ok(())
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

    /// Read what the device has sent into the buffer (nothing where the
    /// port's read times out).
    fn fill(&mut self) -> Result<()> {
        let mut chunk = [0u8; 4096];
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
        Ok(())
    }

    /// Wait until the device speaks (any whole frame: its start frame,
    /// a record): a request sent to a device still starting (a board
    /// just reset, an emulator just launched) can be lost before its
    /// UART listens. Frames after the first are kept for the replies.
    pub fn ready(&mut self) -> Result<()> {
        let start = std::time::Instant::now();
        loop {
            while let Some(b) = self.buf.pop_front() {
                if let Some(Ok(_)) = self.decoder.push(b) {
                    return Ok(());
                }
            }
            if start.elapsed() > self.timeout {
                bail!("the device sent nothing whole in {:?}", self.timeout);
            }
            self.fill()?;
        }
    }

    /// The next reply to request `seq`.
    fn reply(&mut self, seq: u32) -> Result<link::Reply> {
        let start = std::time::Instant::now();
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
            self.fill()?;
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
        set.sensors[3].loss_tangent = Some(1.37e-3);
        set.policy.tones = (1, 3);
        let mut again = Stored::uncalibrated();
        for (name, value) in entries(&set) {
            assign(&mut again, &name, &value).unwrap();
        }
        assert_eq!(again, set);
        assert_eq!(entries(&set).len(), 7 + 9 * SENSORS_MAX);
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

    /// Sensor `k`'s parasitic capacitance set to `k` pF.
    fn mark(set: &mut Stored, k: usize) {
        set.sensors[k].parasitic_farad = k as f32 * 1e-12;
    }

    #[test]
    fn writers_to_one_image_wait_for_each_other_and_lose_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flash.bin");
        std::thread::scope(|scope| {
            for k in 0..16 {
                let path = &path;
                scope.spawn(move || {
                    update_image(path, Unreadable::Refuse, |set| {
                        let mut set = set.unwrap_or_else(Stored::uncalibrated);
                        mark(&mut set, k);
                        // Slow enough that unguarded writers overlap.
                        std::thread::sleep(std::time::Duration::from_millis(5));
                        Ok(set)
                    })
                    .unwrap()
                });
            }
        });
        let (set, generation) = read_image(&path).unwrap().unwrap();
        assert_eq!(generation, 16);
        for k in 0..16 {
            assert_eq!(set.sensors[k].parasitic_farad, k as f32 * 1e-12, "sensor {k}");
        }
        // No file of a writer is left behind but the lock.
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["flash.bin", "flash.bin.lock"]);
    }

    #[test]
    fn a_spoiled_slot_is_named_while_the_other_stays_in_force() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flash.bin");
        let mut set = Stored::uncalibrated();
        mark(&mut set, 5);
        write_image(&path, &set).unwrap();
        mark(&mut set, 6);
        write_image(&path, &set).unwrap();
        assert!(spoiled_slots(&path).unwrap().is_empty());
        // The newer set (slot B) gets a bit flipped in its header.
        let mut image = std::fs::read(&path).unwrap();
        image[SLOT_BYTES as usize + 5] ^= 0x01;
        std::fs::write(&path, &image).unwrap();
        // The older set in force: sensor 5 marked, sensor 6 not.
        let (older, generation) = read_image(&path).unwrap().unwrap();
        assert_eq!(older.sensors[5].parasitic_farad, 5e-12);
        assert_ne!(older.sensors[6].parasitic_farad, 6e-12);
        let report = spoiled_slots(&path).unwrap();
        assert_eq!(
            report,
            [
                format!("slot A holds a valid set (generation {generation})").as_str(),
                "slot B is spoiled: it holds a header whose CRC does not match (a flipped bit, or a spoiled write)"
            ]
        );
    }

    #[test]
    fn a_spoiled_image_is_named_and_not_replaced_by_defaults_unasked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flash.bin");
        let mut set = Stored::uncalibrated();
        mark(&mut set, 5);
        write_image(&path, &set).unwrap();
        // One bit flipped in the stored set's body.
        let mut image = std::fs::read(&path).unwrap();
        let at = image.iter().position(|&b| b != 0xFF).unwrap() + 40;
        image[at] ^= 0x10;
        std::fs::write(&path, &image).unwrap();
        let err = read_image(&path).unwrap_err().to_string();
        assert!(err.contains("no set that reads back"), "{err}");
        // Which slot, and which check failed.
        assert!(
            err.contains("slot A is spoiled: it holds a body whose CRC does not match"),
            "{err}"
        );
        assert!(err.contains("slot B holds nothing (erased)"), "{err}");
        let err = update_image(&path, Unreadable::Refuse, |s| {
            Ok(s.unwrap_or_else(Stored::uncalibrated))
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("--replace-unreadable"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), image, "left as it was");
        let (_, generation) = update_image(&path, Unreadable::Replace, |s| {
            assert!(s.is_none());
            Ok(Stored::uncalibrated())
        })
        .unwrap();
        assert!(generation >= 1);
        assert!(read_image(&path).unwrap().is_some());
    }

    #[test]
    fn links_and_a_file_changed_meanwhile_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flash.bin");
        let elsewhere = dir.path().join("elsewhere.bin");
        std::fs::write(&elsewhere, b"keep").unwrap();
        std::os::unix::fs::symlink(&elsewhere, &path).unwrap();
        let err = write_image(&path, &Stored::uncalibrated())
            .unwrap_err()
            .to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert_eq!(std::fs::read(&elsewhere).unwrap(), b"keep");
        std::fs::remove_file(&path).unwrap();
        // The lock's name, planted as a link.
        std::os::unix::fs::symlink(&elsewhere, dir.path().join("flash.bin.lock")).unwrap();
        assert!(write_image(&path, &Stored::uncalibrated()).is_err());
        assert_eq!(std::fs::read(&elsewhere).unwrap(), b"keep");
        std::fs::remove_file(dir.path().join("flash.bin.lock")).unwrap();
        // Another writer (a device running on the image) meanwhile.
        write_image(&path, &Stored::uncalibrated()).unwrap();
        let err = update_image(&path, Unreadable::Refuse, |s| {
            let mut other = Stored::uncalibrated();
            mark(&mut other, 2);
            write_image_unlocked(&path, &other);
            Ok(s.unwrap())
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("changed while"), "{err}");
        assert_eq!(
            read_image(&path).unwrap().unwrap().0.sensors[2].parasitic_farad,
            2e-12
        );
    }

    /// What a device does to its image: a new set stored, no lock taken.
    fn write_image_unlocked(path: &Path, set: &Stored) {
        let mut image = std::fs::read(path).unwrap();
        Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES)
            .unwrap()
            .save(set)
            .unwrap();
        std::fs::write(path, image).unwrap();
    }
}
