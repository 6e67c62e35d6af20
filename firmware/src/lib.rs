//! The DE sensing-skin firmware: the RTIC applications in `src/bin/`
//! (target only) around the hardware-free measurement chain of the
//! `instrument` crate (config, policy, calibration, faults, multiplexer,
//! channel), which the host tools run too.
//!
//! | module | what it does |
//! |---|---|
//! | `scenario` | (feature `qemu`) the simulated skin and front end of the QEMU runs |
//! | `array_skin` | (feature `qemu`) the simulated skin of the array's QEMU runs: sixteen sensors, the comb front end |
//! | `qemu` | (QEMU target) the one place that owns logging, panic, faults and exit |
//! | `qemu_flash` | (QEMU target) the settings' flash in a host file through semihosting: settings survive a restart |
//! | `device_clock` | a device clock offset and drifting from true time: the QEMU images' `offset_us=`, `drift_ppm=` |
//! | `in_force` | the set a device measures with, replaced while it runs when the host stores another (`Applied` frame) |
//! | `hot_ram` | (target) the per-block code's load into zero-wait RAM (the CCM SRAM) at reset |
//! | `power_up` | (target) the array's power-up self-test in an image: its blocks, its log, the start frame after it |
//! | `link_out` | the record link's sending end on the board: frames into a byte queue a DMA channel drains (`bbqueue`); never waits, counts drops |
//! | `settings_log` | (target) what a device says of its stored settings at start |
//! | `records` | the array's record queue between acquisition and logger (`heapless`): never waits, counts drops |
//! | `board` | (feature `board`) the STM32G474's hardware, one module per peripheral; its logging, panics and faults on the target |
#![no_std]
#![deny(missing_docs)]
#![deny(unsafe_code)]

#[cfg(test)]
extern crate std;

#[cfg(feature = "qemu")]
pub mod array_skin;
#[cfg(feature = "board")]
pub mod board;
pub mod device_clock;
#[cfg(target_os = "none")]
pub mod hot_ram;
pub mod in_force;
pub mod link_out;
#[cfg(target_os = "none")]
pub mod power_up;
#[cfg(all(target_os = "none", feature = "qemu"))]
pub mod qemu;
#[cfg(all(target_os = "none", feature = "qemu"))]
pub mod qemu_flash;
pub mod records;
#[cfg(feature = "qemu")]
pub mod scenario;
#[cfg(target_os = "none")]
pub mod settings_log;
#[cfg(all(target_os = "none", feature = "qemu"))]
pub mod stack;

/// The mains frequency the array's images follow hum at, Hz: 50, or 60
/// with the feature `mains-60hz` ([`instrument::reader::ArrayReader::for_mains`]).
pub const MAINS_HZ: u32 = if cfg!(feature = "mains-60hz") { 60 } else { 50 };
