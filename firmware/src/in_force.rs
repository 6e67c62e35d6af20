//! The set a device measures with, replaced while it runs: the settings
//! every sensor shares ([`Common`] or [`ToneCommon`]), the sensors built
//! in place, and the stored set's generation. When the host stores a new
//! set, the application takes it at the next block ([`InForce::apply`])
//! and sends the [`link::Applied`] frame that says so between the last
//! record measured with the old set and the first with the new one.

use embedded_storage::nor_flash::NorFlash;
use instrument::array::SENSORS as ARRAY_SENSORS;
use instrument::calib::POINTS;
use instrument::channel::{Common, Settings};
use instrument::digest::Digestible;
use instrument::frames;
use instrument::sensor::Sensors;
use instrument::store::{Corruption, Store};
use instrument::stored::Stored;
use instrument::tones::{ToneCommon, ToneSettings};

/// The settings sensors share, of an application with `S` sensors.
pub trait Shared<const S: usize>: Copy {
    /// The settings these make with the sensors.
    type Settings<'a>: Digestible;

    /// The settings of these and `sensors`.
    fn with(self, sensors: &Sensors<POINTS, S>) -> Self::Settings<'_>;

    /// Take what the stored set `set` holds of these (its policy and
    /// decimation).
    fn take(&mut self, set: &Stored);
}

impl<const S: usize> Shared<S> for Common {
    type Settings<'a> = Settings<'a, POINTS, S>;

    fn with(self, sensors: &Sensors<POINTS, S>) -> Settings<'_, POINTS, S> {
        Common::with(self, sensors)
    }

    fn take(&mut self, set: &Stored) {
        self.policy = set.policy;
        self.record_every = set.record_every;
    }
}

impl Shared<ARRAY_SENSORS> for ToneCommon {
    type Settings<'a> = ToneSettings<'a, POINTS>;

    fn with(self, sensors: &Sensors<POINTS, ARRAY_SENSORS>) -> ToneSettings<'_, POINTS> {
        ToneCommon::with(self, sensors)
    }

    fn take(&mut self, set: &Stored) {
        self.policy = set.policy;
        self.record_every = set.record_every;
    }
}

/// Why a stored set was not applied; the one in force stays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NotApplied {
    /// The store holds no set, or its flash cannot be read.
    Unreadable,
    /// The set breaks a rule of [`Stored::check`] (a store refuses such a
    /// set, so only a flash changed behind its back holds one).
    Refused,
}

/// The settings in force: what the sensors share, the sensors (built where
/// they stay), the stored set's generation (0: none stored).
pub struct InForce<C, const S: usize> {
    common: C,
    sensors: &'static mut Sensors<POINTS, S>,
    generation: u32,
}

impl<C: Shared<S>, const S: usize> InForce<C, S> {
    /// In force from start: `common`, `sensors`, of stored generation
    /// `generation`.
    pub fn new(common: C, sensors: &'static mut Sensors<POINTS, S>, generation: u32) -> Self {
        Self {
            common,
            sensors,
            generation,
        }
    }

    /// The settings to measure a block with.
    pub fn settings(&self) -> C::Settings<'_> {
        self.common.with(self.sensors)
    }

    /// The sensors.
    pub fn sensors(&self) -> &Sensors<POINTS, S> {
        self.sensors
    }

    /// The stored set's generation (0: none stored).
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// The stream's start frame of device `device_id`, with the set in
    /// force.
    pub fn start_frame(
        &self,
        firmware: &str,
        device_id: u32,
        sensors: usize,
        sample_rate_hz: u32,
    ) -> link::Start {
        let settings = self.settings();
        let calibration = self.sensors.calibration();
        frames::start(
            firmware,
            device_id,
            self.generation,
            &settings,
            &calibration,
            sensors,
            sample_rate_hz,
        )
    }

    /// Take stored set `set` of generation `generation`: its sensors
    /// rebuilt in place, its policy and decimation. The frame that says so,
    /// the device's time `t_us` (the last block acquired) in it; a set its
    /// check refuses is not taken.
    pub fn apply(&mut self, generation: u32, set: &Stored, t_us: u64) -> Result<link::Applied, NotApplied> {
        set.check().map_err(|_| NotApplied::Refused)?;
        // A set that passed its check has no lead ratio beyond the model.
        self.sensors.load(set).map_err(|_| NotApplied::Refused)?;
        self.common.take(set);
        self.generation = generation;
        let settings = self.settings();
        Ok(frames::applied(
            generation,
            &settings,
            &self.sensors.calibration(),
            t_us,
        ))
    }

    /// [`InForce::apply`] of the set `store` holds. Not inlined: a board
    /// takes its set at start through it too, one copy of the code.
    #[inline(never)]
    pub fn apply_stored<F: NorFlash>(
        &mut self,
        store: &mut Store<F>,
        t_us: u64,
    ) -> Result<link::Applied, NotApplied>
    where
        F::Error: Corruption,
    {
        match store.load() {
            Ok(Some(l)) => self.apply(l.generation, &l.set, t_us),
            _ => Err(NotApplied::Unreadable),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use instrument::channel::Settings;
    use instrument::digest::Digest;
    use instrument::ranging::Ranging;
    use instrument::sensor::Sensor;
    use instrument::store::{RamFlash, SLOT_BYTES};
    use std::boxed::Box;
    use std::vec;

    fn in_force() -> InForce<Common, 8> {
        let sensors = Box::leak(Box::new(Sensors::all(Sensor::uncalibrated(200e-12))));
        let common = Settings::new(Ranging::DEFAULT.front_ends(1.0), Ranging::DEFAULT, &*sensors).common();
        InForce::new(common, sensors, 0)
    }

    #[test]
    fn a_stored_set_is_taken_whole_and_said_so() {
        let mut f = in_force();
        let before = Digest::of(&f.settings());
        let mut set = Stored::uncalibrated();
        set.record_every = 3;
        set.sensors[2].parasitic_farad = 7e-12;
        set.sensors[5].calibrated = true;
        let mut mem = vec![0xFF; 2 * SLOT_BYTES as usize];
        let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
        assert_eq!(store.save(&set).unwrap(), 1);
        let applied = f.apply_stored(&mut store, 1234).unwrap();
        assert_eq!(applied.generation, 1);
        assert_eq!(applied.t_us, 1234);
        assert_eq!(f.generation(), 1);
        let settings = f.settings();
        assert_eq!(settings.record_every, 3);
        assert_eq!(settings.sensors.of(2).fixture.parallel_farad, 7e-12);
        assert!(settings.sensors.of(5).calibrated);
        assert_eq!(applied.settings_digest, Digest::of(&settings));
        assert_ne!(applied.settings_digest, before);
        assert_eq!(
            applied.calibration_digest,
            Digest::of(&settings.sensors.calibration())
        );
        // The start frame of a device started with it says the same.
        let start = f.start_frame("test", 7, 8, 1000);
        assert_eq!((start.generation, start.device_id), (1, 7));
        assert_eq!(start.settings_digest, applied.settings_digest);
    }

    #[test]
    fn a_set_that_breaks_a_rule_or_none_leaves_the_one_in_force() {
        let mut f = in_force();
        let before = Digest::of(&f.settings());
        let mut mem = vec![0xFF; 2 * SLOT_BYTES as usize];
        let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
        assert_eq!(f.apply_stored(&mut store, 0), Err(NotApplied::Unreadable));
        let mut bad = Stored::uncalibrated();
        bad.sensors[4].lead_ratio = 80.0;
        assert_eq!(f.apply(7, &bad, 0), Err(NotApplied::Refused));
        assert_eq!(f.generation(), 0);
        assert_eq!(Digest::of(&f.settings()), before);
    }
}
