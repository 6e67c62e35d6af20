//! A second simulator of the DE sensor bench, written apart from
//! `skin-sim` as a check on it and on `host-sim`'s analysis.
//!
//! What differs from `skin-sim`, on purpose:
//!
//! | | `skin-sim` | `rig-sim` |
//! |---|---|---|
//! | line | its own discretisation | symmetric T cells, each at its own local stretch ([`sensor`]) |
//! | film dynamics | its own | damage driven by the strain rate, more on release, exponential healing ([`bench::Film`]) |
//! | meter | admittance averaging | vector (impedance) averaging: instant, trailing or centred windows, first order ([`meter`]) |
//! | noise | its own | white floor + relative noise growing at low frequency + AR(1) drift, rounding to the meter's digits ([`meter::Noise`]) |
//! | rig | the paper's trapezoid | trapezoidal velocity (finite acceleration) ([`motion`]) |
//! | effect shapes | linear and parabolic modes | exponential and sine profiles, per-tab contacts that differ, blocking contacts, Cole–Cole relaxation ([`hidden`]) |
//!
//! The only things shared are the interchange format
//! (`docs/data-format.md`) and the catalogue's effect ids as strings.

pub mod bench;
pub mod hidden;
pub mod meter;
pub mod motion;
pub mod sensor;

pub use bench::Bench;
pub use hidden::Family;
