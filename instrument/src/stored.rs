//! The settings a device keeps in flash: each sensor's calibration and
//! wiring, the tone policy and its limits, the record rate. Versioned,
//! serialised with postcard, and checked as a whole before it is used or
//! stored ([`Stored::check`]): a value outside its range, a table that
//! does not ascend, or a value that is not finite is refused by name, and
//! the set in force is kept. [`crate::store`] keeps it in flash.
//!
//! Ranges come from the sensors and the instrument, not from our
//! generator: a DE sensor of a few mm² to a few cm² is 1 pF–10 nF with
//! electrodes of 1 kΩ–100 MΩ ([`SensorSettings`]); leads are at most
//! [`LEAD_MAX`] line resistances; a fixture adds at most 1 nF and 10 MΩ.

use crate::calib::POINTS;
use crate::config::PERIODS;
use crate::policy::Policy;
use dsp_core::invert::LEAD_MAX;
use serde::{Deserialize, Serialize};

/// The version of the stored layout; a device reads a set of version 1
/// as this one (each sensor's film as its material's: [`SensorSettings::loss_tangent`]
/// None) and refuses any other.
pub const FORMAT_VERSION: u16 = 2;

/// Sensors a set describes (the array's sixteen; the multiplexed board
/// uses the first eight).
pub const SENSORS_MAX: usize = 16;

/// The most bytes a set takes serialised (checked by a test against the
/// longest set).
pub const MAX_BYTES: usize = 2048;

/// One sensor: what it is, how it is wired, how its C reads as stretch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorSettings {
    /// Read, or left out (an empty socket).
    pub in_use: bool,
    /// Capacitance at rest, F (1 pF … 10 nF).
    pub nominal_c_farad: f32,
    /// Electrode resistance (both electrodes, end to end) at rest, Ω
    /// (1 kΩ … 100 MΩ).
    pub nominal_r_ohm: f32,
    /// Series resistance of the read end's tab leads per line resistance,
    /// ℓ (0 … [`LEAD_MAX`]; 0: no leads).
    pub lead_ratio: f32,
    /// Contact resistance in series (both tabs), Ω (0 … 10 MΩ).
    pub contact_ohm: f32,
    /// Parasitic capacitance in parallel at the meter (cable, fixture), F
    /// (0 … 1 nF).
    pub parasitic_farad: f32,
    /// The stretch calibration: (C in F, stretch in mm), ascending in both.
    pub table: [(f32, f32); POINTS],
    /// The table was measured on this sensor; false: stretch is not
    /// calibrated (records say so) and the table is not used.
    pub calibrated: bool,
    /// The loss tangent tan δ of this sensor's film as its calibration
    /// measured it (0 … 0.1), the line's fit's prior mean in place of its
    /// material's (`dsp_core::dielectric::Dielectric`, whose spread it
    /// keeps); None: the material's.
    pub loss_tangent: Option<f32>,
}

/// [`SensorSettings`] as version 1 stored it: without
/// [`SensorSettings::loss_tangent`].
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
struct SensorSettingsV1 {
    in_use: bool,
    nominal_c_farad: f32,
    nominal_r_ohm: f32,
    lead_ratio: f32,
    contact_ohm: f32,
    parasitic_farad: f32,
    table: [(f32, f32); POINTS],
    calibrated: bool,
}

impl From<SensorSettingsV1> for SensorSettings {
    fn from(s: SensorSettingsV1) -> Self {
        Self {
            in_use: s.in_use,
            nominal_c_farad: s.nominal_c_farad,
            nominal_r_ohm: s.nominal_r_ohm,
            lead_ratio: s.lead_ratio,
            contact_ohm: s.contact_ohm,
            parasitic_farad: s.parasitic_farad,
            table: s.table,
            calibrated: s.calibrated,
            loss_tangent: None,
        }
    }
}

/// Everything a device keeps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stored {
    /// [`FORMAT_VERSION`].
    pub version: u16,
    /// One record per sensor every this many blocks (1 … 250).
    pub record_every: u8,
    /// The tone policy and its limits.
    pub policy: Policy,
    /// Each sensor.
    pub sensors: [SensorSettings; SENSORS_MAX],
}

/// A rule a set must keep: the setting it is about and what it asks.
/// Its number ([`Rule::code`]) is what a device's refusal carries over
/// the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Rule {
    /// The layout's version.
    Version,
    /// `record_every`.
    RecordEvery,
    /// `policy.x_limit`.
    XLimit,
    /// `policy.hysteresis`.
    Hysteresis,
    /// `policy.decay_per_s`.
    DecayPerS,
    /// `policy.hold_s`.
    HoldS,
    /// `policy.settle_blocks`.
    SettleBlocks,
    /// `policy.tones`.
    Tones,
    /// A sensor's `nominal_c_farad`.
    NominalC,
    /// A sensor's `nominal_r_ohm`.
    NominalR,
    /// A sensor's `lead_ratio`.
    LeadRatio,
    /// A sensor's `contact_ohm`.
    ContactOhm,
    /// A sensor's `parasitic_farad`.
    ParasiticFarad,
    /// A sensor's table: each point's range.
    TableRange,
    /// A sensor's table: its order.
    TableOrder,
    /// A sensor's `loss_tangent`.
    LossTangent,
}

impl Rule {
    /// Every rule, by code.
    pub const ALL: [Rule; 16] = [
        Rule::Version,
        Rule::RecordEvery,
        Rule::XLimit,
        Rule::Hysteresis,
        Rule::DecayPerS,
        Rule::HoldS,
        Rule::SettleBlocks,
        Rule::Tones,
        Rule::NominalC,
        Rule::NominalR,
        Rule::LeadRatio,
        Rule::ContactOhm,
        Rule::ParasiticFarad,
        Rule::TableRange,
        Rule::TableOrder,
        Rule::LossTangent,
    ];

    /// Its number on the link.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The rule of number `code`.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// The setting, as `config` names it.
    pub fn field(self) -> &'static str {
        match self {
            Rule::Version => "version",
            Rule::RecordEvery => "record_every",
            Rule::XLimit => "policy.x_limit",
            Rule::Hysteresis => "policy.hysteresis",
            Rule::DecayPerS => "policy.decay_per_s",
            Rule::HoldS => "policy.hold_s",
            Rule::SettleBlocks => "policy.settle_blocks",
            Rule::Tones => "policy.tones",
            Rule::NominalC => "nominal_c_farad",
            Rule::NominalR => "nominal_r_ohm",
            Rule::LeadRatio => "lead_ratio",
            Rule::ContactOhm => "contact_ohm",
            Rule::ParasiticFarad => "parasitic_farad",
            Rule::TableRange | Rule::TableOrder => "table",
            Rule::LossTangent => "loss_tangent",
        }
    }

    /// What it asks.
    pub fn text(self) -> &'static str {
        match self {
            Rule::Version => "a layout this firmware does not read",
            Rule::RecordEvery => "must be 1 … 250 blocks",
            Rule::XLimit => "must be 0.5 … 16",
            Rule::Hysteresis => "must be 0 … 0.5",
            Rule::DecayPerS => "must be 0 … 10 per s",
            Rule::HoldS => "must be 0 … 60 s",
            Rule::SettleBlocks => "must be 0 … 16",
            Rule::Tones => "must be two indices of the frequency set, lowest first",
            Rule::NominalC => "must be 1 pF … 10 nF",
            Rule::NominalR => "must be 1 kΩ … 100 MΩ",
            Rule::LeadRatio => "must be 0 … 50 line resistances",
            Rule::ContactOhm => "must be 0 … 10 MΩ",
            Rule::ParasiticFarad => "must be 0 … 1 nF",
            Rule::TableRange => "C must be 1 pF … 100 nF and stretch within ±1 m",
            Rule::TableOrder => "must ascend in C and in stretch",
            Rule::LossTangent => "must be 0 … 0.1, or none (the material's)",
        }
    }
}

/// Why a set was refused: the rule it breaks, and the sensor for a
/// sensor's setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Refused {
    /// The sensor, for a sensor's setting.
    pub sensor: Option<u8>,
    /// The rule.
    pub rule: Rule,
}

impl core::fmt::Display for Refused {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if let Some(s) = self.sensor {
            write!(f, "sensor {s} ")?;
        }
        write!(f, "{}: {}", self.rule.field(), self.rule.text())
    }
}

/// `v` finite and within `lo..=hi`, or refused.
fn within(v: f32, lo: f32, hi: f32, sensor: Option<u8>, rule: Rule) -> Result<(), Refused> {
    match v.is_finite() && (lo..=hi).contains(&v) {
        true => Ok(()),
        false => Err(Refused { sensor, rule }),
    }
}

/// Refused by `rule`, for no sensor.
fn refused(rule: Rule) -> Refused {
    Refused { sensor: None, rule }
}

impl SensorSettings {
    /// A sensor nothing is known of: in use, the reference sensor's
    /// nominal values, no leads, no wiring, its film its material's,
    /// stretch not calibrated (the table a placeholder: C over its
    /// plausible span, stretch zero…one millimetre, never used while
    /// `calibrated` is false).
    pub const fn unknown(nominal_c_farad: f32, nominal_r_ohm: f32) -> Self {
        let mut table = [(0.0, 0.0); POINTS];
        let mut k = 0;
        while k < POINTS {
            let u = k as f32 / (POINTS - 1) as f32;
            table[k] = (nominal_c_farad * (1.0 + u), u);
            k += 1;
        }
        Self {
            in_use: true,
            nominal_c_farad,
            nominal_r_ohm,
            lead_ratio: 0.0,
            contact_ohm: 0.0,
            parasitic_farad: 0.0,
            table,
            calibrated: false,
            loss_tangent: None,
        }
    }

    /// Check sensor `s`'s values.
    pub fn check(&self, s: u8) -> Result<(), Refused> {
        let at = Some(s);
        within(self.nominal_c_farad, 1e-12, 1e-8, at, Rule::NominalC)?;
        within(self.nominal_r_ohm, 1e3, 1e8, at, Rule::NominalR)?;
        within(self.lead_ratio, 0.0, LEAD_MAX, at, Rule::LeadRatio)?;
        within(self.contact_ohm, 0.0, 1e7, at, Rule::ContactOhm)?;
        within(self.parasitic_farad, 0.0, 1e-9, at, Rule::ParasiticFarad)?;
        if let Some(t) = self.loss_tangent {
            within(t, 0.0, 0.1, at, Rule::LossTangent)?;
        }
        for &(c, mm) in &self.table {
            within(c, 1e-12, 1e-7, at, Rule::TableRange)?;
            within(mm, -1e3, 1e3, at, Rule::TableRange)?;
        }
        if !self.table.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1) {
            return Err(Refused {
                sensor: at,
                rule: Rule::TableOrder,
            });
        }
        Ok(())
    }
}

impl Policy {
    /// Check the policy's values.
    pub fn check(&self) -> Result<(), Refused> {
        within(self.x_limit, 0.5, 16.0, None, Rule::XLimit)?;
        within(self.hysteresis, 0.0, 0.5, None, Rule::Hysteresis)?;
        within(self.decay_per_s, 0.0, 10.0, None, Rule::DecayPerS)?;
        within(self.hold_s, 0.0, 60.0, None, Rule::HoldS)?;
        if self.settle_blocks > 16 {
            return Err(refused(Rule::SettleBlocks));
        }
        let (lo, hi) = self.tones;
        if !(lo <= hi && usize::from(hi) < PERIODS.len()) {
            return Err(refused(Rule::Tones));
        }
        Ok(())
    }
}

/// [`Stored::uncalibrated`]'s sensor.
static UNKNOWN: SensorSettings = SensorSettings::unknown(
    crate::design::SENSOR_C_REST_FARAD as f32,
    crate::design::SENSOR_R_REST_OHM as f32,
);

impl Stored {
    /// A set for sensors nothing is known of
    /// ([`SensorSettings::unknown`] with the reference sensor's nominal
    /// values), every sensor in use, the default policy, a record every
    /// block.
    ///
    /// One sensor laid out at compile time (a static) and copied sixteen
    /// times by a loop: built in place, the sixteen sensors' constants
    /// took kilobytes of stores in every image that reads a stored set,
    /// and a whole set as a static as much again of flash.
    #[inline(never)]
    pub fn uncalibrated() -> Self {
        // Opaque, so that the copies are not folded back into a set's
        // worth of constants.
        let s = *core::hint::black_box(&UNKNOWN);
        Self {
            version: FORMAT_VERSION,
            record_every: 1,
            policy: Policy::DEFAULT,
            sensors: [s; SENSORS_MAX],
        }
    }

    /// Check the whole set: the first setting out of its range, by name.
    pub fn check(&self) -> Result<(), Refused> {
        if self.version != FORMAT_VERSION {
            return Err(refused(Rule::Version));
        }
        if self.record_every == 0 || self.record_every > 250 {
            return Err(refused(Rule::RecordEvery));
        }
        self.policy.check()?;
        for (s, sensor) in self.sensors.iter().enumerate() {
            sensor.check(s as u8)?;
        }
        Ok(())
    }

    /// Serialise into `out` (at least [`MAX_BYTES`]); the bytes written.
    pub fn to_bytes<'a>(&self, out: &'a mut [u8]) -> Option<&'a mut [u8]> {
        postcard::to_slice(self, out).ok()
    }

    /// Read a set from `bytes` and check it: None if it does not parse,
    /// the refusal if it parses and breaks a rule.
    pub fn from_bytes(bytes: &[u8]) -> Option<Result<Self, Refused>> {
        let mut set = Self::uncalibrated();
        set.parse(bytes)?;
        Some(set.check().map(|()| set))
    }

    /// [`Stored::from_bytes`] into `self`, in place (a device keeps one
    /// set on its stack, not three): true if `bytes` hold a set that
    /// passes its check; `self` is then that set, and otherwise anything.
    pub fn read_from(&mut self, bytes: &[u8]) -> bool {
        self.parse(bytes).is_some() && self.check().is_ok()
    }

    /// Read the serialised set `bytes` into `self`, piece by piece (the
    /// layout postcard gives the whole: the fields in order, a fixed
    /// array as its elements), so that a device parses it with one set on
    /// its stack rather than serde's copies of sixteen sensors (7 KiB).
    /// Bytes after the set are no set: None. A set of version 1 is read
    /// as this version's ([`FORMAT_VERSION`]).
    fn parse(&mut self, bytes: &[u8]) -> Option<()> {
        let ((version, record_every, policy), mut rest) =
            postcard::take_from_bytes::<(u16, u8, Policy)>(bytes).ok()?;
        (self.version, self.record_every, self.policy) = (version, record_every, policy);
        for sensor in self.sensors.iter_mut() {
            let (s, r) = if version == 1 {
                let (s, r) = postcard::take_from_bytes::<SensorSettingsV1>(rest).ok()?;
                (s.into(), r)
            } else {
                postcard::take_from_bytes::<SensorSettings>(rest).ok()?
            };
            *sensor = s;
            rest = r;
        }
        if version == 1 {
            self.version = FORMAT_VERSION;
        }
        rest.is_empty().then_some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    fn longest() -> Stored {
        let mut s = Stored::uncalibrated();
        for (k, sensor) in s.sensors.iter_mut().enumerate() {
            sensor.calibrated = true;
            sensor.lead_ratio = 0.64;
            sensor.contact_ohm = 1234.5;
            sensor.parasitic_farad = 12e-12 + k as f32 * 1e-13;
            sensor.loss_tangent = Some(1.5e-3 + k as f32 * 1e-4);
        }
        s.record_every = 250;
        s
    }

    #[test]
    fn a_set_round_trips_and_fits_its_bound() {
        let s = longest();
        assert_eq!(s.check(), Ok(()));
        let mut buf = [0u8; MAX_BYTES];
        let n = s.to_bytes(&mut buf).unwrap().len();
        assert!(n <= MAX_BYTES && n > 16 * POINTS * 8, "{n} bytes");
        assert_eq!(Stored::from_bytes(&buf[..n]), Some(Ok(s)));
        assert_eq!(Stored::from_bytes(&buf[..n - 1]), None, "cut short");
        let mut longer = buf[..n].to_vec();
        for tail in [0u8, 0xFF] {
            longer.push(tail);
            assert_eq!(Stored::from_bytes(&longer), None, "trailing bytes");
        }
        // The piecewise parse reads what serde's derive reads.
        let derived: Stored = postcard::from_bytes(&buf[..n]).unwrap();
        assert_eq!(derived, s);
        let mut other = longest();
        other.sensors[9].table[4].1 = 0.41;
        other.policy.tones = (1, 3);
        let m = other.to_bytes(&mut buf).unwrap().len();
        assert_eq!(Stored::from_bytes(&buf[..m]), Some(Ok(other)));
    }

    #[test]
    fn every_rule_refuses_by_name() {
        let base = Stored::uncalibrated();
        assert_eq!(base.check(), Ok(()));
        let mut cases: std::vec::Vec<(Stored, &str)> = std::vec::Vec::new();
        let mut s = base;
        s.version = 3;
        cases.push((s, "version: a layout"));
        let mut s = base;
        s.record_every = 0;
        cases.push((s, "record_every:"));
        let mut s = base;
        s.policy.x_limit = f32::NAN;
        cases.push((s, "policy.x_limit:"));
        let mut s = base;
        s.policy.tones = (3, 1);
        cases.push((s, "policy.tones:"));
        let mut s = base;
        s.policy.settle_blocks = 17;
        cases.push((s, "policy.settle_blocks:"));
        let mut s = base;
        s.sensors[5].nominal_c_farad = 0.0;
        cases.push((s, "sensor 5 nominal_c_farad:"));
        let mut s = base;
        s.sensors[15].nominal_r_ohm = 1e9;
        cases.push((s, "sensor 15 nominal_r_ohm:"));
        let mut s = base;
        s.sensors[0].lead_ratio = -0.1;
        cases.push((s, "sensor 0 lead_ratio:"));
        let mut s = base;
        s.sensors[2].contact_ohm = f32::INFINITY;
        cases.push((s, "sensor 2 contact_ohm:"));
        let mut s = base;
        s.sensors[3].parasitic_farad = 2e-9;
        cases.push((s, "sensor 3 parasitic_farad:"));
        for t in [-1e-4, 0.2, f32::NAN] {
            let mut s = base;
            s.sensors[4].loss_tangent = Some(t);
            cases.push((s, "sensor 4 loss_tangent:"));
        }
        let mut s = base;
        s.sensors[7].table.swap(3, 4);
        cases.push((s, "sensor 7 table: must ascend"));
        let mut s = base;
        s.sensors[7].table[10].1 = s.sensors[7].table[9].1;
        cases.push((s, "sensor 7 table: must ascend"));
        for (s, want) in cases {
            let why = s.check().unwrap_err().to_string();
            assert!(why.starts_with(want), "{why} (wanted {want})");
            // Refused on the way in too.
            let mut buf = [0u8; MAX_BYTES];
            let n = s.to_bytes(&mut buf).unwrap().len();
            assert!(matches!(Stored::from_bytes(&buf[..n]), Some(Err(_))));
        }
    }

    /// A set version 1 wrote (before each sensor's film was stored) is
    /// read as this version's, every sensor's film its material's; a
    /// set of an unknown version is refused.
    #[test]
    fn a_set_of_version_1_reads_with_the_materials_film() {
        let mut want = longest();
        for s in want.sensors.iter_mut() {
            s.loss_tangent = None;
        }
        // Version 1's bytes: each sensor's as now but for its last field,
        // a film of none (one byte, 0).
        let mut old = std::vec::Vec::new();
        let mut buf = [0u8; MAX_BYTES];
        let head = (1u16, want.record_every, want.policy);
        old.extend_from_slice(postcard::to_slice(&head, &mut buf).unwrap());
        for s in &want.sensors {
            let b = postcard::to_slice(s, &mut buf).unwrap();
            assert_eq!(b.last(), Some(&0));
            old.extend_from_slice(&b[..b.len() - 1]);
        }
        assert_eq!(Stored::from_bytes(&old), Some(Ok(want)));
        assert_eq!(Stored::from_bytes(&old[..old.len() - 1]), None, "cut short");
        old[0] = 3;
        let read = Stored::from_bytes(&old);
        assert!(
            matches!(
                read,
                None | Some(Err(Refused {
                    rule: Rule::Version,
                    ..
                }))
            ),
            "version 3 is no layout this firmware reads: {read:?}"
        );
    }

    #[test]
    fn a_rule_crosses_the_link_as_its_code() {
        for (k, r) in Rule::ALL.iter().enumerate() {
            assert_eq!(usize::from(r.code()), k);
            assert_eq!(Rule::from_code(r.code()), Some(*r));
        }
        assert_eq!(Rule::from_code(Rule::ALL.len() as u8), None);
    }
}
