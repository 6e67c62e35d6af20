//! Signal processing for dielectric-elastomer (DE) stretch sensors.
//!
//! A DE sensor is a stretchable capacitor whose carbon-black electrodes have
//! hundreds of kΩ of resistance. Read through the two tabs at one end it is a
//! distributed R-C line, so a meter that assumes a series R-C reads too little
//! capacitance at high excitation frequency, and a resistance peak during
//! fast stretching shows up as a false capacitance dip. This crate holds the
//! real-time pieces that turn paired ADC samples into the line's true C and R:
//!
//! | module | what it does |
//! |---|---|
//! | [`cossin`] | table-based sine/cosine of an `i32` phase (`i32::MIN` = −π), Q31 |
//! | [`osc`] | phase-accumulator excitation oscillator ([`Oscillator`] / [`OscillatorState`]) |
//! | [`demod`] | synchronous I/Q demodulation of (voltage, current) sample pairs, i64 sums |
//! | [`comb`] | demodulation of a comb of tones from one input of a scanned block |
//! | [`hum`] | mains hum followed across blocks and taken out of a comb's sums |
//! | [`sideband`] | a tone's sideband fitted beside a comb: an interferer a fraction of a bin off the tone taken out of the others |
//! | [`lockin`] | one tone through Nuttall's window, with a guard bin either side: far energy rejected, near energy seen |
//! | [`lumped`] | the series Cs–Rs reading an LCR meter reports |
//! | [`tline`] | fixed-point R-C ladder and continuous transmission-line model |
//! | [`fmath`] | f32 square root: one FPU instruction on the target, libm's bits on the host |
//! | [`dielectric`] | the film's dielectric loss, in the line and out of a single tone's inversion |
//! | [`fixture`] | de-embedding contacts and parasitic capacitance found by `identify` |
//! | [`invert`] | true line C and R from one measured impedance |
//! | [`track`] | the line over successive blocks: branch choice, plausibility, holds |
//! | [`twotone`] | the line from two tones at once, and its model-consistency χ² |
//!
//! Everything is `no_std`, allocation-free and deterministic: the fixed-point
//! kernels use integer arithmetic only, and the few `f32` operations at the
//! interfaces are IEEE-754 basic operations (`+ − × ÷ √`), which give the
//! same bits on the host, in QEMU and on a Cortex-M4F.
//!
//! Units: SI base units throughout the public API (Ω, F, Hz, s) unless a name
//! says otherwise. Q formats are stated where integers carry fractions:
//! `Qn` means value = integer · 2⁻ⁿ.
//!
//! ```
//! use dsp_core::{tline::LineModel, lumped::SeriesRc, invert::Inverter};
//! // What a series Cs-Rs meter reads on a 200 pF, 700 kΩ sensor at 6 kHz:
//! let z = LineModel::Continuous.impedance(700e3, 200e-12, 6e3).unwrap();
//! let meter = SeriesRc::from_impedance(z, 6e3).unwrap();
//! assert!(meter.cs_farad < 190e-12); // the lumped meter under-reads
//! // ...and the inversion recovers the line. At ωRC = 5.3 two lines fit
//! // this reading (a second, more resistive line with a larger C), so
//! // `invert` alone says `Ambiguous`; an expected C (the calibration's
//! // rest value) picks the line:
//! let inv = Inverter::new(LineModel::Continuous);
//! assert!(inv.invert(z, 6e3).is_err());
//! let line = inv.invert_near(z, 6e3, 210e-12).unwrap();
//! assert!((line.c_farad / 200e-12 - 1.0).abs() < 1e-3);
//! assert!((line.r_ohm / 700e3 - 1.0).abs() < 1e-3);
//! ```
#![no_std]
#![deny(missing_docs)]
// The only unsafe code is the Cortex-M4 inner loop of `demod::arm` and
// `fmath`'s `vsqrt.f32`.
#![deny(unsafe_code)]

pub use num_complex::Complex;

/// Complex `f32`, the interface type for impedances (Ω) and normalized
/// impedances (dimensionless).
pub type Complex32 = Complex<f32>;

pub mod comb;
pub mod cossin;
pub mod demod;
pub mod dielectric;
mod fixed;
pub mod fixture;
pub mod fmath;
pub mod hum;
pub mod invert;
pub mod lockin;
pub mod lumped;
pub mod osc;
pub mod scan;
pub mod sideband;
pub mod spread;
pub mod tline;
pub mod track;
pub mod twotone;

/// Generated lookup tables (see `build.rs`).
#[allow(clippy::unreadable_literal)]
pub mod tables {
    include!(concat!(env!("OUT_DIR"), "/tables.rs"));
}

pub use osc::{Oscillator, OscillatorState};
