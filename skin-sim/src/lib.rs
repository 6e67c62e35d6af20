//! A simulated dielectric-elastomer sensing skin: one place for the physics,
//! `no_std` and allocation-free so that the firmware's QEMU build can feed
//! its ADC from the same sensor the desktop tools use.
//!
//! | module | what it models |
//! |---|---|
//! | [`profile`] | stretch against time: the paper's trapezoids, ramps, steps, tables |
//! | [`stairs`] | a calibration run: the skin held at 0, 3, …, 30 mm in turn, and the spans the host fits |
//! | [`electrode`] | electrode resistance: static stretch dependence, rate-dependent peaks, transients at rest, slow settling |
//! | [`sensor`] | the sensor on a fine grid ([`sensor::SEGMENTS`] segments), its impedance read from one end, optional non-ideal effects |
//! | [`frontend`] | excitation, transimpedance stage and ADC: blocks of paired samples |
//! | [`array`](mod@array) | the array's front end: one comb excitation, a transimpedance stage per sensor, five scanning ADCs |
//! | [`rng`] | a small deterministic PRNG with Gaussian samples |
//!
//! Units: SI (Ω, F, Hz, s), except stretch in mm as in the paper.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod array;
pub mod electrode;
pub mod frontend;
pub mod profile;
pub mod rng;
pub mod sensor;
pub mod stairs;

pub use num_complex::Complex64;
