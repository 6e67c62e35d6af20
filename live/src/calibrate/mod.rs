//! `live calibrate`: each sensor's line, its tab leads and its wiring
//! fitted from the records a device took while the skin was held at known
//! stretches, and its stretch table from the same fit.
//!
//! # What is fitted
//! For each sensor, from the measured impedances Z (the records' two
//! tones, Ω, before any de-embedding) within each hold:
//!
//! ```text
//! Z = 1 / (1/(Z_line(R, C) + ℓ·R + R_s) + jω·C_p),   Z_line = R·coth(γ)/γ,  γ = √(jωRC)
//! ```
//!
//! the uniform line of the firmware (`dsp_core::tline`), its tab leads ℓ
//! (line resistances in series at the read end), a series contact R_s
//! and a parasitic capacitance C_p at the meter: the three the device
//! keeps per sensor (`instrument::stored::SensorSettings`). C is one
//! unknown per hold (it follows stretch alone); R one per part of a hold
//! ([`Options::parts`]) and pair of tones (a sweep measures each pair at
//! its own time), since the electrodes' resistance still recovers from
//! the move before it. The fit is weighted least squares
//! (Levenberg–Marquardt) on each part's mean impedance per tone, with the
//! scatter of its records as σ, floored at [`SIGMA_FLOOR`] of |Z|.
//!
//! # What the data cannot tell apart
//! Leads and contact are both a series resistance: only the way the
//! series part follows the line's resistance from hold to hold tells
//! them apart (leads scale with R, a contact does not). The report gives
//! each fitted value with its 1σ and the correlation of the pair, and
//! names the pair as unresolved where they trade against each other;
//! the fit's C is what the table is built on either way.
//!
//! # When a sensor is refused
//! A fit that does not explain its data (χ²/dof above [`CHI2_MAX`]), a
//! C that does not ascend with stretch, a hold with too few usable
//! records, or values outside the device's ranges: that sensor keeps what
//! the device held, and the report says why.

mod fit;
mod holds;
mod report;
mod session;
#[cfg(test)]
mod tests;

pub use fit::*;
pub use holds::*;
pub use report::*;
pub use session::*;

use instrument::stored::{Stored, SENSORS_MAX};

/// Every sensor of `base` in use, fitted from `records`; the set to store
/// (each fitted sensor from its fit, the others as `base` has them), and
/// each sensor's outcome.
pub fn calibrate(
    records: &[link::Record],
    holds: &[Hold],
    base: &Stored,
    opts: &Options,
) -> (Stored, Vec<Outcome>) {
    let mut set = *base;
    let mut outcomes = vec![];
    for s in 0..SENSORS_MAX {
        if !base.sensors[s].in_use {
            outcomes.push(Outcome::NotInUse);
            continue;
        }
        let mine: Vec<&link::Record> = records.iter().filter(|r| usize::from(r.sensor) == s).collect();
        // Its own stretches where the holds give each sensor its own.
        let holds = &for_sensor(holds, s as u8);
        if holds.len() < 2 {
            outcomes.push(Outcome::Refused(format!(
                "{} holds for it in the holds file: a calibration needs two stretches at least",
                holds.len()
            )));
            continue;
        }
        let outcome = match fit_sensor(s as u8, &mine, holds, opts) {
            Ok(fit) => {
                let mut trial = set;
                trial.sensors[s] = fit.settings(holds);
                match trial.check() {
                    Ok(()) => {
                        set = trial;
                        Outcome::Fitted(fit)
                    }
                    Err(r) => Outcome::Refused(format!("the fit breaks the device's rule: {r}")),
                }
            }
            Err(why) => Outcome::Refused(why),
        };
        outcomes.push(outcome);
    }
    (set, outcomes)
}
