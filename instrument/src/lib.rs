//! The DE sensing-skin instrument, free of hardware: what the firmware
//! runs, the simulators drive and the host tools read back, defined once.
//!
//! | module | what it holds |
//! |---|---|
//! | [`effects`] | the catalogue of non-ideal effects of a sensor, its wiring and its recording: ids, units, ranges, how each enters the physics (`skin-spec`) |
//! | [`digest`] | digests of settings and calibrations (a start frame's): CRC-32 over the values' bits |
//! | [`design`] | the front end's design parameters: rates, gains, ADC and DAC scales, the reference sensor (`skin-spec`) |
//! | [`config`] | block, slot, channels, the excitation frequency set and each frequency's second tone (`skin-spec`) |
//! | [`policy`] | adaptive excitation frequency from the measured resistance peaks |
//! | [`ranging`] | auto-ranging of the transimpedance stage from the current of the last block (`skin-spec`) |
//! | [`calib`] | stretch from capacitance through a calibration table in flash (`skin-spec`) |
//! | [`faults`] | fault flags: clipping, open, short, out of range, settling, held |
//! | [`availability`] | a sensor's records: the share valid, and the faults that stood on the others |
//! | [`busy`] | how the CPU keeps up: each block's time from acquisition to last record, late and missed blocks, a status frame a second |
//! | [`mux`] | the analog multiplexer's address lines (embedded-hal `OutputPin`) |
//! | [`sensor`] | each sensor as measured: its line (tab leads), its wiring, its rest capacitance, its stretch table if it has one |
//! | [`joint`] | the line of a block's two tones, tracked, and what its model check vouches for, alone and over the calm blocks before it (both front ends) |
//! | [`decide`] | what every channel decides once its tones are read: the line, its flags, the policy's next step (both front ends) |
//! | [`channel`] | one sensor channel of the multiplexer: a block's two tones → a line-corrected record with its model check |
//! | [`commands`] | the device's side of the link's requests: read and write the stored settings, start, stop, sweep; each acknowledged or refused |
//! | [`stored`] | the settings a device keeps: each sensor's calibration and wiring, the policy, the record rate; checked as a whole |
//! | [`store`] | those settings in flash, two slots (A/B): a power cut leaves the old set or the new |
//! | [`sequencer`] | the slot sequence: slot → channel, the frequency of the slot after next, record times |
//! | [`wire`] | the record wire format: its writer (defmt) and its parser |
//! | [`frames`] | records as frames of the record link (`link`), and the digests of a start frame |
//! | [`array`](mod@array) | the simultaneous front end: one comb excitation, a transimpedance stage per sensor, five scanning ADCs (`skin-spec`) |
//! | [`tones`] | one sensor of the array: two tones of a block → a line-corrected record with its model check |
//! | [`avoid`] | an array channel moving its tones off one an interferer occupies, and back |
//! | [`mains`] | the array's reader following mains hum, taken out of every input |
//! | [`sideband`] | the sideband of the tone an array channel avoids, fitted beside the comb, and what it still leaks, bounded |
//! | [`spread`] | what an interferer near a tone of the comb does to every tone a record fits at once |
//! | [`reader`] | every sensor of the array from one block: the comb on each input, then each sensor's record |
//! | [`selftest`] | the array's power-up self-test: the reference network and every path held to the firmware's constants; the records of a failing path refused |
//! | [`sweep`] | a calibration step's sweep: every sensor's records step through each tone pair, then the policy again |
//!
//! The firmware (board and QEMU) runs this code; host-sim's time-domain
//! chain runs the same [`channel::Channel`] on the simulated skin. It is
//! `no_std`, allocation-free and free of hardware, in the style of quartiq's
//! stabilizer: the binaries only move samples. Units SI (Ω, F, S, Hz, s)
//! unless a name says otherwise.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

#[cfg(test)]
extern crate std;

// What the simulated skin shares with the instrument lives below both, in
// `skin-spec`; it is part of the instrument's API under the same names.
pub use skin_spec::{array, calib, config, design, effects, ranging};

pub mod availability;
pub mod avoid;
pub mod busy;
pub mod channel;
pub mod commands;
pub mod decide;
pub mod digest;
pub mod faults;
pub mod frames;
pub mod joint;
pub mod mains;
pub mod mux;
pub mod policy;
pub mod reader;
pub mod selftest;
pub mod sensor;
pub mod sequencer;
pub mod sideband;
pub mod spread;
pub mod store;
pub mod stored;
pub mod sweep;
pub mod tones;
pub mod wire;
