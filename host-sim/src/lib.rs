//! Desktop side of the DE sensing-skin front end: the same `dsp-core` code
//! the boards run, driven from the command line and from tests.
//!
//! * [`meter`]: what a series Cs–Rs meter reads on a line, and the inverse.
//! * [`si`]: SI-prefixed numbers for the command line.

pub mod meter;
pub mod si;
