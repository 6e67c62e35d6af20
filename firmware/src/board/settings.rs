//! The multiplexed board's settings at start: the set stored in flash
//! and a request side that answers from it (the `store` feature), or
//! sensors nothing was measured on and no requests (`skin-board`).

use crate::board::pac;
use core::mem::MaybeUninit;
use instrument::calib::POINTS;
use instrument::channel::Settings;
use instrument::design;
use instrument::ranging::Ranging;
use instrument::sensor::Sensors;

pub use stored::{load, Requests, RING, SENSORS};

/// The board's settings for `sensors`: its front end's ranges, the
/// default policy and thresholds.
fn board_settings<const S: usize>(sensors: &'static Sensors<POINTS, S>) -> Settings<'static, POINTS, S> {
    Settings::new(
        Ranging::DEFAULT.front_ends(design::V_GAIN as f32),
        Ranging::DEFAULT,
        sensors,
    )
}

/// The sensors' settings and the host's requests: the set stored in
/// flash and a request side that answers from it (the `store` feature),
/// or sensors nothing was measured on and no requests.
#[cfg(feature = "store")]
mod stored {
    use super::*;
    use crate::board::flash::SettingsFlash;
    use crate::board::link::{self, RX_BYTES};
    use crate::board::setup::LinkPort;
    use instrument::commands::Commands;
    use instrument::config::CHANNELS;
    use instrument::store::{Store, SLOT_BYTES};

    /// A sensor's settings each.
    pub const SENSORS: usize = CHANNELS;
    /// The receive ring's bytes.
    pub const RING: usize = RX_BYTES;
    /// The request side over the board's flash.
    pub type Requests = crate::board::requests::Requests<SettingsFlash>;

    /// The set stored in flash (with none, sensors nothing was measured
    /// on) and its generation, its sensors built into `slot`, and the request side over
    /// `ring`, which DMA2 channel 2 fills from now on; `None` if the
    /// flash's slots do not hold or a set's lead ratio is beyond the
    /// line model (logged).
    pub fn load(
        flash: pac::FLASH,
        slot: &'static mut MaybeUninit<Sensors<POINTS, SENSORS>>,
        ring: &'static mut [u8; RING],
        port: &LinkPort,
    ) -> Option<(Settings<'static, POINTS, SENSORS>, u32, Requests)> {
        let Ok(mut store) = Store::new(SettingsFlash::new(flash), 0, SLOT_BYTES) else {
            defmt::println!("settings: the slots do not fit the flash");
            return None;
        };
        // The stored set; with none, sensors nothing was measured on.
        let (generation, set) = crate::settings_log::in_force(&mut store);
        let Ok(sensors) = crate::settings_log::sensors_in(slot, &set) else {
            defmt::println!("settings: a tab-lead ratio beyond the line model");
            return None;
        };
        let settings = Settings {
            policy: set.policy,
            record_every: set.record_every,
            ..board_settings(sensors)
        };
        link::receive(&port.dma, port.rdr, ring.as_ptr() as u32);
        Some((settings, generation, Requests::new(ring, Commands::new(), store)))
    }
}

/// The sensors' settings and the host's requests: the set stored in
/// flash and a request side that answers from it (the `store` feature),
/// or sensors nothing was measured on and no requests.
#[cfg(not(feature = "store"))]
mod stored {
    use super::*;
    use crate::board::setup::LinkPort;
    use crate::link_out::FrameWriter;
    use instrument::commands::Action;
    use instrument::sensor::Sensor;

    /// One sensor's settings, every channel's.
    pub const SENSORS: usize = 1;
    /// No receive ring.
    pub const RING: usize = 0;

    /// No requests are read.
    pub struct Requests;

    impl Requests {
        /// Never a request.
        pub fn answer<const N: usize>(
            &mut self,
            _: u16,
            _: &mut FrameWriter<'_, N>,
            _: impl FnMut(),
        ) -> Option<Action> {
            None
        }
    }

    /// Every sensor read as one nothing was measured on; no requests.
    pub fn load(
        _: pac::FLASH,
        slot: &'static mut MaybeUninit<Sensors<POINTS, SENSORS>>,
        _: &'static mut [u8; RING],
        _: &LinkPort,
    ) -> Option<(Settings<'static, POINTS, SENSORS>, u32, Requests)> {
        let sensors = slot.write(Sensors::all(Sensor::uncalibrated(
            design::SENSOR_C_REST_FARAD as f32,
        )));
        Some((board_settings(sensors), 0, Requests))
    }
}
