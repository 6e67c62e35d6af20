//! What a device says of its stored settings at start (`settings: none
//! stored`, or the generation and digest of the set in force: the digest
//! a host computes of the same set with `instrument::digest`), and the
//! sensors it builds from them.

use embedded_storage::nor_flash::NorFlash;
use instrument::digest::Digest;
use instrument::store::{Corruption, Loaded, Store, StoreError};
use instrument::stored::Stored;

/// Log the set in force, as [`instrument::store::Store::load`] found it.
pub fn announce<E>(loaded: &Result<Option<Loaded>, StoreError<E>>) {
    match loaded {
        Ok(Some(l)) => defmt::println!(
            "settings: generation {=u32} digest {=u32:#010x}",
            l.generation,
            Digest::of(&l.set)
        ),
        Ok(None) => defmt::println!("settings: none stored"),
        Err(_) => defmt::println!("settings: the flash cannot be read"),
    }
}

/// The set in force at start: the one `store` holds, or with none (or a
/// flash that cannot be read) the set of sensors nothing was measured on;
/// either logged; with its generation (0: none stored).
pub fn in_force<F: NorFlash>(store: &mut Store<F>) -> (u32, Stored)
where
    F::Error: Corruption,
{
    let loaded = store.load();
    announce(&loaded);
    match loaded {
        Ok(Some(l)) => (l.generation, l.set),
        _ => {
            defmt::println!("settings: measuring uncalibrated (no leads, no wiring, stretch not calibrated)");
            (0, Stored::uncalibrated())
        }
    }
}

/// Log a set applied while the device runs, or why it was not.
pub fn applied(result: &Result<link::Applied, crate::in_force::NotApplied>) {
    match result {
        Ok(a) => defmt::println!(
            "settings: generation {=u32} digest {=u32:#010x} in force from {=u64} us",
            a.generation,
            a.settings_digest,
            a.t_us
        ),
        Err(crate::in_force::NotApplied::Unreadable) => {
            defmt::println!("settings: the new set cannot be read back, the one in force stays")
        }
        Err(crate::in_force::NotApplied::Refused) => {
            defmt::println!("settings: the new set breaks a rule, the one in force stays")
        }
    }
}

/// The sensors of stored set `set`, built where they stay (`slot`, a
/// static): sixteen are 10 KiB, and a frame of its own keeps their
/// building off the stack of the caller (an RTIC `init` that also reads
/// the flash). An error for a lead ratio beyond the line model (a set
/// that passed its check has none).
#[inline(never)]
pub fn sensors_in<const S: usize>(
    slot: &'static mut core::mem::MaybeUninit<instrument::sensor::Sensors<{ instrument::calib::POINTS }, S>>,
    set: &instrument::stored::Stored,
) -> Result<
    &'static mut instrument::sensor::Sensors<{ instrument::calib::POINTS }, S>,
    dsp_core::tline::ModelError,
> {
    use instrument::sensor::{Sensor, Sensors};
    let sensors = slot.write(Sensors::all(Sensor::uncalibrated(0.0)));
    sensors.load(set)?;
    Ok(sensors)
}
