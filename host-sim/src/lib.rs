//! Desktop side of the DE sensing-skin front end: the same `dsp-core` code
//! the boards run, driven from the command line and from tests.
//!
//! * [`meter`]: what a series Cs–Rs meter reads on a line, and the inverse.
//! * [`baseline`]: the baseline model of a measured data set and its residual.
//! * [`chain`]: the measurement chain on the simulated sensor (ADC +
//!   demodulator, or an ideal LCR meter).
//! * [`dataset`]: reading measured data sets, with the format's checks.
//! * [`disturbances`]: the disturbance table: each class on both firmware paths.
//! * [`availability`]: the share of a clean skin's records the array keeps valid, across the documented sensors.
//! * [`ceiling`]: the most records any reader of the array could keep valid (the Cramér–Rao bound of C).
//! * [`model`]: the forward model with the candidate effects (f64).
//! * [`numerics`]: the shared numerical helpers (solve, fits, interpolation, statistics).
//! * [`identify`]: trace a residual to an effect by model selection.
//! * [`lsq`]: bounded weighted least squares with its covariance (`identify`, `live calibrate`).
//! * [`experiments`]: the paper's experiments, CSV + SVG + summary.
//! * [`plot`]: SVG figures.
//! * [`recording`]: firmware recordings (the wire format) → data sets.
//! * [`si`]: SI-prefixed numbers for the command line.

pub mod availability;
pub mod baseline;
pub mod ceiling;
pub mod chain;
pub mod dataset;
pub mod disturbances;
pub mod experiments;
pub mod identify;
pub mod interpolate;
pub mod lsq;
pub mod meter;
pub mod model;
pub mod numerics;
pub mod numfmt;
pub mod plot;
pub mod recording;
pub mod si;
