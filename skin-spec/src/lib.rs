//! What the DE sensing-skin instrument and its simulated skin agree on,
//! defined once below both: `instrument` measures with it, `skin-sim`
//! simulates with it, and neither needs the other.
//!
//! | module | what it holds |
//! |---|---|
//! | [`design`] | the front end's design parameters: rates, gains, ADC and DAC scales, the reference sensor |
//! | [`config`] | the multiplexed board's block, slot and channels, the excitation frequency set and each frequency's second tone |
//! | [`ranging`] | the transimpedance stage's ranges, and auto-ranging from the current of the last block |
//! | [`calib`] | stretch from capacitance through a calibration table |
//! | [`effects`] | the catalogue of non-ideal effects of a sensor, its wiring and its recording: ids, units, ranges, how each enters the physics |
//! | [`array`](mod@array) | the simultaneous front end's layout: one comb excitation, a transimpedance stage per sensor, five scanning ADCs |
//! | [`leak`] | how a sinusoid near a tone of the 4 ms comb leaks into every tone's bin at once |
//! | [`truth`] | what the simulated skin truly was during a block |
//!
//! `no_std`, allocation-free and free of hardware. Units SI (Ω, F, S, Hz,
//! s) unless a name says otherwise.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

#[cfg(test)]
extern crate std;

pub mod array;
pub mod calib;
pub mod config;
pub mod design;
pub mod effects;
pub mod leak;
pub mod ranging;
pub mod truth;
