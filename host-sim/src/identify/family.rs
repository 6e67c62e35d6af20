//! Families of equivalent descriptions: models the library writes in
//! different terms that describe one physical thing.
//!
//! - The meter's averaging: a mean of N readings taken every dt is a
//!   window of about N·dt; an exponential mean of memory m per reading is
//!   a first-order response of τ = −dt/ln m.
//! - A profile along the sensor: a bump centred on it and about as wide
//!   is its symmetric mode, the bulge, by another name.
//!
//! The report names the family of what it names, and says when a
//! competitor is the same thing in the other member's terms.

use super::{Fit, KERNELS};
use crate::model::Effect;

/// A bump this close to the middle (ξ) …
const CENTRED: f64 = 0.1;
/// … and at least this wide (a fraction of the sensor) is a bulge.
const WIDE: f64 = 0.8;

/// The family of `f`'s named effects and what the model is in its
/// other members' terms (None: a model of no family).
pub fn note(f: &Fit) -> Option<String> {
    let dt = f.search.row_s;
    let p = |e| f.params.get(e);
    let has = |e| f.effects.contains(&e);
    if has(Effect::MeterMean) && dt > 0.0 {
        return Some(format!(
            "the meter's averaging: a mean of {:.2} readings {:.0} ms apart is a window of about {:.0} ms",
            p(Effect::MeterMean),
            dt * 1e3,
            p(Effect::MeterMean) * dt * 1e3
        ));
    }
    if has(Effect::MeterEwma) && dt > 0.0 && p(Effect::MeterEwma) > 0.0 && p(Effect::MeterEwma) < 1.0 {
        return Some(format!(
            "the meter's averaging: an exponential mean of memory {:.3} per reading {:.0} ms apart is a first-order response of τ = {:.1} ms",
            p(Effect::MeterEwma),
            dt * 1e3,
            tau_of(p(Effect::MeterEwma), dt) * 1e3
        ));
    }
    if has(Effect::MeterLag) && dt > 0.0 {
        return Some(format!(
            "the meter's averaging: a window of {:.0} ms is a mean of about {:.1} readings {:.0} ms apart",
            p(Effect::MeterLag) * 1e3,
            p(Effect::MeterLag) / dt,
            dt * 1e3
        ));
    }
    if has(Effect::MeterResponse) && dt > 0.0 && !f.fitted.contains(&Effect::MeterOrder) {
        return Some(format!(
            "the meter's averaging: a first-order response of τ = {:.1} ms is an exponential mean of memory {:.3} per reading {:.0} ms apart",
            p(Effect::MeterResponse) * 1e3,
            (-dt / p(Effect::MeterResponse)).exp(),
            dt * 1e3
        ));
    }
    if f.effects.iter().any(|e| KERNELS.contains(e)) {
        return Some("the meter's averaging".to_string());
    }
    for (bump, what, bulge) in [
        (Effect::StretchBump, "stretch", Effect::StretchBulge),
        (Effect::ResistanceBump, "resistance", Effect::ResistanceBulge),
    ] {
        if has(bump) {
            let (c, w) = (p(Effect::BumpCentre), p(Effect::BumpWidth));
            return Some(if is_bulge(c, w) {
                format!(
                    "the {what} profile: a bump centred at {c:.2} and {w:.2} of the sensor wide is its symmetric mode, a bulge ({}) by another name; its shape lies between the two",
                    bulge.id()
                )
            } else {
                format!("the {what} profile: a localized bump")
            });
        }
    }
    for (bulge, what) in [
        (Effect::StretchBulge, "stretch"),
        (Effect::ResistanceBulge, "resistance"),
    ] {
        if has(bulge) && f.fitted.contains(&Effect::BulgePower) {
            return Some(format!(
                "the {what} profile: a symmetric bulge of power {:.2}, (4ξ(1 − ξ))^k, from the parabola (k = 1) through sin(πξ) (about 1.2) to a sin²(πξ)-like bell (about 2.4)",
                p(Effect::BulgePower)
            ));
        }
    }
    None
}

/// A bump at centre `c` of width `w` is the symmetric mode.
pub fn is_bulge(c: f64, w: f64) -> bool {
    (c - 0.5).abs() <= CENTRED && w >= WIDE
}

/// The time constant of an exponential mean of memory `m` per reading
/// `dt` apart, s.
pub fn tau_of(m: f64, dt: f64) -> f64 {
    -dt / m.ln()
}

/// Whether `a` and `b` are one thing in two members' terms: both the
/// meter's averaging, or a bulge and a bump as wide as the sensor of the
/// same quantity.
pub fn same_family(a: &Fit, b: &Fit) -> bool {
    let kernel = |f: &Fit| f.effects.iter().any(|e| KERNELS.contains(e));
    let profile = |f: &Fit, bulge: Effect, bump: Effect| {
        f.effects.contains(&bulge)
            || (f.effects.contains(&bump)
                && is_bulge(f.params.get(Effect::BumpCentre), f.params.get(Effect::BumpWidth)))
    };
    (kernel(a) && kernel(b))
        || [
            (Effect::StretchBulge, Effect::StretchBump),
            (Effect::ResistanceBulge, Effect::ResistanceBump),
        ]
        .iter()
        .any(|&(bulge, bump)| profile(a, bulge, bump) && profile(b, bulge, bump))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exponential mean's τ against the f64 reference: the response
    /// e^(−dt/τ) per reading gives back the memory, over 0.01…0.99.
    #[test]
    fn an_exponential_mean_is_a_first_order_response() {
        let dt = 0.02;
        for k in 1..100 {
            let m = k as f64 / 100.0;
            let tau = tau_of(m, dt);
            assert!(((-dt / tau).exp() - m).abs() < 1e-12, "{m}");
        }
        assert!(is_bulge(0.497, 0.94) && !is_bulge(0.3, 0.94) && !is_bulge(0.5, 0.5));
    }
}
