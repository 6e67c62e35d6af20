//! One hidden effect per data set, drawn over its physical range, for
//! checking an analysis that is not told which.
//!
//! Each family names the catalogue ids (`instrument::effects`, as plain
//! strings: this crate does not link the catalogue) an analysis may answer
//! with. The shapes are this bench's own, not the catalogue's: an
//! exponential resistance or stretch profile where the catalogue has a
//! linear mode, a sine bulge where it has a parabola, windows centred as
//! well as trailing, a first-order meter average and a lock-in's filter
//! of several sections, per-tab contacts that differ.

use crate::bench::ROW_S;
use crate::meter::{Dynamics, Meter};
use crate::sensor::{Bump, ColeCole, Effects};
use rand::Rng;

/// A family of effects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Tab contact resistance, 1 kΩ–3 MΩ per tab (silver paint to a dry
    /// press contact).
    Contact,
    /// Cable and fixture capacitance, 0.3–40 pF (a short lead to a metre
    /// of coax).
    Parasitic,
    /// Exponential resistance profile along the sensor, end-to-end ratio
    /// e^|κ| up to 20.
    ResistanceProfile,
    /// Exponential stretch profile, far end to read end up to e^2.5.
    StretchTilt,
    /// Sine-shaped stretch bulge, middle over ends (clamps holding the
    /// ends, m > 0) or necking at the ends (m < 0), |m| ≤ 0.9.
    StretchBulge,
    /// Leakage through the dielectric, 2–300 nS.
    Leakage,
    /// The meter's averaging window, 20 ms (one row) to 1 s, trailing or
    /// centred.
    Window,
    /// The meter's first-order average, τ 10 ms–0.5 s.
    FirstOrder,
    /// A lock-in's output filter: 2–4 first-order sections in cascade
    /// (12–24 dB/octave, the slopes lock-in amplifiers offer), τ 5–150 ms
    /// each.
    Cascade,
    /// A meter reporting the mean of its last 2–16 readings (one per
    /// row), 0–3 rows late: a digital meter's or logger's averaging.
    MovingMean,
    /// A meter reporting an exponentially weighted mean of its readings
    /// (weight of the newest 0.05–0.7), 0–3 rows late: a digital filter.
    Ewma,
    /// The capacitance channel's time offset, 5 ms–0.5 s either way.
    Offset,
    /// Tab leads, 5–80 % of each electrode's resistance.
    Leads,
    /// Dispersive film conductivity, τ 2–300 µs.
    FilmDispersion,
    /// A sine-squared bump of stretch along the sensor (a fingertip or
    /// an edge pressed into the skin, a fold): 0.2–2 times the mean
    /// stretch more, or 0.2–0.8 less, centred 0.1–0.9 along, 25–100 % of
    /// the length wide at its foot (12–50 % at half height).
    StretchBump,
    /// A sine-squared bump of the film's resistance (a thin or cracked patch:
    /// 0.2–6 times the mean more; a thick one: 0.2–0.8 less), placed and
    /// sized as [`Family::StretchBump`].
    ResistanceBump,
    /// Outside the catalogue: dielectric relaxation (Cole–Cole).
    Relaxation,
    /// Outside the catalogue: a blocking (capacitive) contact at the tabs.
    BlockingContact,
}

impl Family {
    /// The families an analysis is expected to name.
    pub const IN_LIBRARY: [Family; 16] = [
        Family::Contact,
        Family::Parasitic,
        Family::ResistanceProfile,
        Family::StretchTilt,
        Family::StretchBulge,
        Family::Leakage,
        Family::Window,
        Family::FirstOrder,
        Family::MovingMean,
        Family::Ewma,
        Family::Offset,
        Family::Leads,
        Family::FilmDispersion,
        Family::StretchBump,
        Family::ResistanceBump,
        Family::Cascade,
    ];

    /// The families outside the catalogue.
    pub const OUTSIDE: [Family; 2] = [Family::Relaxation, Family::BlockingContact];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Family::Contact => "contact",
            Family::Parasitic => "parasitic",
            Family::ResistanceProfile => "resistance_profile",
            Family::StretchTilt => "stretch_tilt",
            Family::StretchBulge => "stretch_bulge",
            Family::Leakage => "leakage",
            Family::Window => "window",
            Family::FirstOrder => "first_order",
            Family::Cascade => "cascade",
            Family::MovingMean => "moving_mean",
            Family::Ewma => "ewma",
            Family::Offset => "offset",
            Family::Leads => "leads",
            Family::FilmDispersion => "film_dispersion",
            Family::StretchBump => "stretch_bump",
            Family::ResistanceBump => "resistance_bump",
            Family::Relaxation => "relaxation",
            Family::BlockingContact => "blocking_contact",
        }
    }

    /// The catalogue ids that name it right (empty: outside the
    /// catalogue, to be reported as unexplained). An answer of several
    /// ids is right when all of them are in this list.
    pub fn catalogue_ids(self) -> &'static [&'static str] {
        match self {
            Family::Contact => &["contact_resistance"],
            Family::Parasitic => &["parasitic_capacitance"],
            // A profile along the sensor, whichever shape names it.
            Family::ResistanceProfile => &["resistance_gradient", "resistance_bulge", "resistance_bump"],
            Family::StretchTilt => &["nonuniform_stretch", "stretch_bulge", "stretch_bump"],
            Family::StretchBulge => &["stretch_bulge", "nonuniform_stretch", "stretch_bump"],
            Family::Leakage => &["dielectric_leakage"],
            // A meter's averaging, whichever kernel names it.
            Family::Window | Family::FirstOrder | Family::Cascade | Family::MovingMean | Family::Ewma => {
                &["meter_lag", "meter_response", "meter_mean", "meter_ewma"]
            }
            Family::Offset => &["time_offset"],
            Family::Leads => &["lead_resistance"],
            Family::FilmDispersion => &["electrode_dispersion"],
            // A profile along the sensor, whichever shape names it: a
            // wide bump is a mode to the data.
            Family::StretchBump => &["stretch_bump", "stretch_bulge", "nonuniform_stretch"],
            Family::ResistanceBump => &["resistance_bump", "resistance_bulge", "resistance_gradient"],
            Family::Relaxation | Family::BlockingContact => &[],
        }
    }

    /// Is an answer naming `ids` right? (Outside the catalogue: only
    /// "unexplained" is, which the caller checks.)
    pub fn named_right(self, ids: &[&str]) -> bool {
        let ok = self.catalogue_ids();
        !ids.is_empty() && ids.iter().all(|id| ok.contains(id))
    }

    /// [`Family::named_right`] for a set recorded by `meter` every
    /// `row_s`: a meter kernel whose own centroid
    /// ([`Dynamics::kernel_centroid_s`]: T/2 of a window, τ, (N − 1)/2 or
    /// (1 − w)/w readings, without its delay) is under one row interval
    /// is resolved from nothing but a delay, so `time_offset` names it
    /// right too.
    pub fn named_right_at(self, ids: &[&str], meter: &Meter, row_s: f64) -> bool {
        let kernel = match self {
            Family::Window | Family::FirstOrder | Family::Cascade | Family::MovingMean | Family::Ewma => {
                meter.dynamics.kernel_centroid_s(row_s)
            }
            _ => f64::INFINITY,
        };
        self.named_right(ids) || (kernel < row_s && ids == ["time_offset"])
    }

    /// A random strength over the family's physical range: the effects
    /// and the meter of one data set, and the value drawn (SI; for a
    /// window, negative when centred; for a discrete meter, its kernel's
    /// centroid at the bench's 20 ms rows, s).
    pub fn draw(self, rng: &mut impl Rng) -> (Effects, Meter, f64) {
        let mut fx = Effects::default();
        let mut meter = Meter::BENCH;
        let v = match self.draw_meter(rng, &mut meter) {
            Some(v) => v,
            None => self.draw_effects(rng, &mut fx),
        };
        (fx, meter, v)
    }

    /// [`Self::draw`] for a family of the meter's: its value, `None`
    /// for a family of the sensor's effects.
    fn draw_meter(self, rng: &mut impl Rng, meter: &mut Meter) -> Option<f64> {
        let v;
        match self {
            Family::Window => {
                // One sample to seconds: as far as the bench's shortest
                // trace (21.6 s) holds a window (a fifth of it left out:
                // offsets and windows to 1.44 s).
                let length_s = log_uniform(rng, 0.02, 1.4);
                let centred = rng.gen::<bool>();
                meter.dynamics = Dynamics::Window { length_s, centred };
                v = if centred { -length_s } else { length_s };
            }
            Family::FirstOrder => {
                v = log_uniform(rng, 0.01, 0.7);
                meter.dynamics = Dynamics::FirstOrder { tau_s: v };
            }
            Family::Cascade => {
                v = log_uniform(rng, 5e-3, 0.15);
                meter.dynamics = Dynamics::Cascade {
                    tau_s: v,
                    sections: rng.gen_range(2..=4),
                };
            }
            Family::MovingMean => {
                meter.dynamics = Dynamics::MovingMean {
                    readings: rng.gen_range(2..=16),
                    delay: rng.gen_range(0..=3),
                };
                v = meter.dynamics.centroid_s(ROW_S);
            }
            Family::Ewma => {
                meter.dynamics = Dynamics::Ewma {
                    weight: log_uniform(rng, 0.05, 0.7),
                    delay: rng.gen_range(0..=3),
                };
                v = meter.dynamics.centroid_s(ROW_S);
            }
            Family::Offset => {
                v = random_sign(rng) * log_uniform(rng, 5e-3, 1.4);
                meter.offset_s = v;
            }
            _ => return None,
        }
        Some(v)
    }

    /// [`Self::draw`] for a family of the sensor's effects: its value.
    fn draw_effects(self, rng: &mut impl Rng, fx: &mut Effects) -> f64 {
        let v;
        match self {
            Family::Contact => {
                v = log_uniform(rng, 1e3, 3e6);
                fx.contact_ohm = v;
            }
            Family::Parasitic => {
                v = log_uniform(rng, 0.3e-12, 40e-12);
                fx.parasitic_f = v;
            }
            Family::ResistanceProfile => {
                v = random_sign(rng) * log_uniform(rng, 0.1, 3.0);
                fx.resistance_kappa = v;
            }
            Family::StretchTilt => {
                v = random_sign(rng) * log_uniform(rng, 0.1, 2.5);
                fx.stretch_kappa = v;
            }
            Family::StretchBulge => {
                v = random_sign(rng) * log_uniform(rng, 0.05, 0.9);
                fx.stretch_bulge = v;
            }
            Family::Leakage => {
                v = log_uniform(rng, 2e-9, 300e-9);
                fx.leakage_s = v;
            }
            Family::Leads => {
                v = rng.gen_range(0.05..0.8);
                fx.lead_fraction = v;
            }
            Family::FilmDispersion => {
                v = log_uniform(rng, 2e-6, 300e-6);
                fx.film_tau_s = v;
            }
            Family::StretchBump | Family::ResistanceBump => {
                let up = if self == Family::StretchBump { 2.0 } else { 6.0 };
                v = if rng.gen::<bool>() {
                    log_uniform(rng, 0.2, up)
                } else {
                    -log_uniform(rng, 0.2, 0.8)
                };
                let (centre, width) = (rng.gen_range(0.1..0.9), log_uniform(rng, 0.25, 1.0));
                let bump = Bump {
                    amplitude: v,
                    start: centre - 0.5 * width,
                    end: centre + 0.5 * width,
                };
                if self == Family::StretchBump {
                    fx.stretch_bump = bump;
                } else {
                    fx.resistance_bump = bump;
                }
            }
            Family::Relaxation => {
                v = rng.gen_range(0.01..0.06);
                fx.dielectric = ColeCole {
                    delta: v,
                    tau_s: 1.0 / (2.0 * std::f64::consts::PI * log_uniform(rng, 800.0, 4000.0)),
                    alpha: 0.7,
                };
            }
            Family::BlockingContact => {
                v = log_uniform(rng, 2e-9, 20e-9);
                fx.contact_ohm = log_uniform(rng, 50e3, 500e3);
                fx.contact_cap_f = v;
            }
            _ => unreachable!("a family of the meter's"),
        }
        v
    }
}

/// A draw log-uniform between `lo` and `hi`.
fn log_uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    lo * (hi / lo).powf(rng.gen::<f64>())
}

/// +1 or −1, evenly.
fn random_sign(rng: &mut impl Rng) -> f64 {
    if rng.gen::<bool>() {
        1.0
    } else {
        -1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for f in Family::IN_LIBRARY.iter().chain(&Family::OUTSIDE) {
            for _ in 0..200 {
                let (fx, m, v) = f.draw(&mut rng);
                assert!(v.is_finite() && v != 0.0, "{}", f.name());
                assert!(fx.lead_fraction < 0.8 && fx.stretch_bulge.abs() <= 0.9);
                assert!(m.offset_s.abs() <= 1.4);
            }
            assert_eq!(f.catalogue_ids().is_empty(), Family::OUTSIDE.contains(f));
        }
        assert!(Family::Window.named_right(&["meter_lag"]));
        let with = |dynamics| Meter {
            dynamics,
            ..Meter::BENCH
        };
        let window = |length_s| {
            with(Dynamics::Window {
                length_s,
                centred: true,
            })
        };
        assert!(Family::Window.named_right_at(&["time_offset"], &window(0.03), 0.02));
        assert!(!Family::Window.named_right_at(&["time_offset"], &window(0.05), 0.02));
        let fo = with(Dynamics::FirstOrder { tau_s: 0.015 });
        assert!(Family::FirstOrder.named_right_at(&["time_offset"], &fo, 0.02));
        // Read as a delay alone, or not: four sections of 5.3 ms (21 ms
        // late, 10.6 ms wide) are, of 12 ms not; two readings three rows
        // late are, four readings not.
        let delay_only =
            |family: Family, dynamics| family.named_right_at(&["time_offset"], &with(dynamics), 0.02);
        for (family, dynamics, delay) in [
            (
                Family::Cascade,
                Dynamics::Cascade {
                    tau_s: 0.0053,
                    sections: 4,
                },
                true,
            ),
            (
                Family::Cascade,
                Dynamics::Cascade {
                    tau_s: 0.012,
                    sections: 4,
                },
                false,
            ),
            (
                Family::MovingMean,
                Dynamics::MovingMean {
                    readings: 2,
                    delay: 3,
                },
                true,
            ),
            (
                Family::MovingMean,
                Dynamics::MovingMean {
                    readings: 4,
                    delay: 0,
                },
                false,
            ),
        ] {
            assert_eq!(delay_only(family, dynamics), delay, "{dynamics:?}");
        }
        assert!(!Family::Offset.named_right_at(&["meter_lag"], &fo, 0.02));
        assert!(!Family::Window.named_right(&["meter_lag", "time_offset"]));
        assert!(!Family::Contact.named_right(&[]));
    }
}
