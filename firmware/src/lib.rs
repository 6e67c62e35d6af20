//! The DE sensing-skin firmware: hardware-free logic (this library, tested
//! on the host) and the RTIC applications in `src/bin/` (target only).
//!
//! | module | what it does |
//! |---|---|
//! | [`config`] | sample rate, block, channels, the excitation frequency set |
//! | [`policy`] | adaptive excitation frequency from the measured resistance peaks |
//! | [`calib`] | stretch from capacitance through a calibration table in flash |
//! | [`faults`] | fault flags: clipping, open, short, out of range, settling, held |
//! | [`mux`] | the analog multiplexer's address lines (embedded-hal `OutputPin`) |
//! | [`channel`] | one sensor channel: demodulated block → record |
//! | `scenario` | (feature `qemu`) the simulated skin and front end of the QEMU runs |
//! | `qemu` | (QEMU target) the one place that owns logging, panic, faults and exit |
//!
//! Everything here is `no_std`, allocation-free and free of hardware, in
//! the style of quartiq's stabilizer: the binaries only move samples.
#![no_std]
#![deny(missing_docs)]
#![deny(unsafe_code)]

#[cfg(all(target_os = "none", feature = "board"))]
pub mod board;
pub mod calib;
pub mod channel;
pub mod config;
pub mod faults;
#[cfg(target_os = "none")]
pub mod log;
pub mod mux;
pub mod policy;
#[cfg(all(target_os = "none", feature = "qemu"))]
pub mod qemu;
#[cfg(feature = "qemu")]
pub mod scenario;
