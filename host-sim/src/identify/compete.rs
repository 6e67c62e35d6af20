//! Competing explanations: other models the data allow as well as the
//! accepted one, and what measurement would tell them apart.
//!
//! A model competes when it explains the data (within
//! [`super::Options::explained`] of the noise seen through it), the rows
//! resolve it, its BIC is within [`super::Options::bic_margin`] of the
//! accepted model's, and it is neither a part nor an extension of it (the
//! same effects with other shape parameters, a response with its order
//! and without, do compete).
//! For models with a property of the sensor, the static sweep each
//! predicts is compared over 100 Hz–100 kHz at the calibration's
//! stretches: the frequency and stretch where they differ most, against
//! the noise floor. Meter kernels alone differ only in time: a recording
//! whose rows are finer than the kernels would separate them.
//!
//! A model named with a remainder has competitors too: the others, under
//! the same rules, that take as much of the misfit
//! ([`super::Options::named_share`]) instead of explaining it.

use super::{Fit, Report};
use crate::model::{Effect, Prepared};
use std::fmt::Write as _;

/// Another explanation the data allow as well as the accepted one.
#[derive(Clone, Debug)]
pub struct Competitor {
    /// Its fit.
    pub fit: Fit,
    /// Its BIC less the accepted model's (< the margin).
    pub delta_bic: f64,
    /// What measurement would separate it from the accepted model.
    pub separation: String,
    /// One thing in another member's terms ([`super::family`]): a mean
    /// of N readings beside a window, a bulge beside a bump as wide as
    /// the sensor.
    pub same_family: bool,
}

/// The frequencies a separating sweep is sought at, Hz.
const SWEEP_HZ: [f64; 13] = [
    100.0, 150.0, 200.0, 500.0, 1e3, 2e3, 3e3, 5e3, 1e4, 2e4, 3e4, 5e4, 1e5,
];

/// A difference a sweep resolves: this many times the noise floor.
const RESOLVED: f64 = 3.0;

/// The competitors of `report`'s accepted (or named) model on `prep`'s
/// data.
pub fn competitors(prep: &Prepared, report: &Report) -> Vec<Competitor> {
    let Some(acc) = report.named_fit() else {
        return vec![];
    };
    let opts = &report.options;
    let base = report.baseline();
    // As good a description: one that explains, or, beside a model named
    // with a remainder, one that takes as much.
    let as_good = |f: &Fit| {
        if report.accepted.is_some() {
            opts.explains(f)
        } else {
            super::Options::share_taken(f, base) >= opts.named_share
        }
    };
    // A part or an extension of it. The same effects with a shape
    // parameter and without (a response's order) are another shape,
    // which competes where the parameter is resolved from the value that
    // reduces it to the model without (2σ: an order resolved from one;
    // else it is the simpler model again, one parameter more).
    let within = |a: &[Effect], b: &[Effect]| a.iter().all(|e| b.contains(e));
    let resolved_shape = |f: &Fit| -> Vec<Effect> {
        f.fitted
            .iter()
            .copied()
            .filter(|e| {
                e.reduces_at()
                    .is_some_and(|v0| (f.params.get(*e) - v0).abs() > 2.0 * f.sigma_of(*e))
            })
            .collect()
    };
    let nested = |f: &Fit| {
        let other_shape = within(&f.effects, &acc.effects)
            && within(&acc.effects, &f.effects)
            && (resolved_shape(f) != resolved_shape(acc));
        !other_shape && (within(&f.effects, &acc.effects) || within(&acc.effects, &f.effects))
    };
    report
        .singles
        .iter()
        .chain(&report.pairs)
        .filter(|f| !nested(f) && f.unresolved.is_none() && as_good(f) && f.bic - acc.bic < opts.bic_margin)
        .map(|f| {
            let same_family = super::family::same_family(acc, f);
            let mut separation = separation(prep, acc, f, report.noise_floor_pf);
            if same_family {
                let note = super::family::note(f).unwrap_or_default();
                separation = format!("the same thing in other terms ({note}); {separation}");
            }
            Competitor {
                fit: f.clone(),
                delta_bic: f.bic - acc.bic,
                separation,
                same_family,
            }
        })
        .collect()
}

/// What would separate `a` from `b`, both of which explain these data.
pub fn separation(prep: &Prepared, a: &Fit, b: &Fit, noise_pf: f64) -> String {
    let sensor = |f: &Fit| f.effects.iter().any(|e| e.is_static());
    if !sensor(a) && !sensor(b) {
        return "both are the meter's averaging in time, equal on these rows: a recording with rows finer \
                than the kernels (a faster meter), across a step in stretch, would separate them"
            .to_string();
    }
    let cal = prep.calibration_points();
    let (Some(lo), Some(hi)) = (
        cal.iter().min_by(|x, y| x.1.total_cmp(&y.1)),
        cal.iter().max_by(|x, y| x.1.total_cmp(&y.1)),
    ) else {
        return "no calibration to predict a sweep from".to_string();
    };
    let points: Vec<(f64, f64, f64)> = [*lo, *hi]
        .iter()
        .flat_map(|&(r, s)| SWEEP_HZ.iter().map(move |&f| (r, s, f)))
        .collect();
    let (pa, pb) = match (
        prep.predict_points(a.line, a.params, &points),
        prep.predict_points(b.line, b.params, &points),
    ) {
        (Ok(pa), Ok(pb)) => (pa, pb),
        _ => return "their static sweeps could not be predicted".to_string(),
    };
    let best = points
        .iter()
        .zip(pa.iter().zip(&pb))
        .map(|(p, (x, y))| (p, (x - y).abs()))
        .filter(|(_, d)| d.is_finite())
        .max_by(|x, y| x.1.total_cmp(&y.1));
    match best {
        Some((&(_, s, f), d)) if d >= RESOLVED * noise_pf => {
            let mut out = String::new();
            let _ = write!(
                out,
                "a static sweep would: at {} and {s} mm they differ by {d:.3} pF ({:.0}× the noise floor)",
                hz(f),
                d / noise_pf
            );
            out
        }
        Some((_, d)) => format!(
            "no static sweep from 100 Hz to 100 kHz at the calibration's stretches separates them (at most \
             {d:.3} pF apart); a measured split of each electrode's resistance (tab to far end, the leads \
             apart from the film) would"
        ),
        None => "their static sweeps could not be predicted".to_string(),
    }
}

/// A frequency for a sentence.
fn hz(f: f64) -> String {
    if f >= 1e3 {
        format!("{} kHz", f / 1e3)
    } else {
        format!("{f} Hz")
    }
}
