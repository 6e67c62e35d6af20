//! Each sensor as the instrument measures it: its line model (with its
//! tab leads), the wiring in front of it, the capacitance it rests at, its
//! film's loss where it was measured, and its stretch calibration if it
//! has one. Built from a stored set
//! ([`crate::stored::Stored`]) or, for the simulators and benches, in
//! code.
//!
//! A sensor nothing was measured on is read honestly: the line with no
//! leads, no wiring, and stretch reported as not calibrated
//! ([`Flags::UNCALIBRATED`](crate::faults::Flags::UNCALIBRATED)): a
//! record's C and R are the line's, never bent by another sensor's
//! constants.

use crate::calib::{CalTable, POINTS};
use crate::config::PERIODS;
use crate::faults::Flags;
use crate::policy::Policy;
use crate::stored::{SensorSettings, Stored, FORMAT_VERSION, SENSORS_MAX};
use dsp_core::dielectric::Dielectric;
use dsp_core::fixture::Fixture;
use dsp_core::tline::{LineModel, ModelError};
use dsp_core::track::Tracker;

/// The line tracker every sensor is read with: the continuous line over
/// x ≤ [`Tracker::X_MAX`].
pub fn tracker() -> Tracker {
    match tracker_with_leads(0.0) {
        Ok(t) => t,
        Err(_) => unreachable!("the continuous model without leads is always valid"),
    }
}

/// The tracker for a sensor with tab leads of `lead_ratio` times the
/// line's resistance at the read end (`EffectSet::lead_ratio` of its
/// calibration, always within range); an error for a ratio outside
/// 0..=`dsp_core::invert::LEAD_MAX`.
pub fn tracker_with_leads(lead_ratio: f32) -> Result<Tracker, ModelError> {
    Tracker::with_leads(LineModel::Continuous, Tracker::X_MAX, lead_ratio)
}

/// One sensor.
#[derive(Clone, Copy, Debug)]
pub struct Sensor<const N: usize> {
    /// Read, or left out (an empty socket): a sensor not in use gives no
    /// records.
    pub in_use: bool,
    /// The line model with this sensor's tab leads, and its tracking.
    pub tracker: Tracker,
    /// Wiring de-embedded before the line (contacts, parasitic
    /// capacitance).
    pub fixture: Fixture,
    /// Capacitance at rest, F: the tracker's prior.
    pub rest_farad: f32,
    /// The stretch calibration (C in F → stretch in mm); used only when
    /// `calibrated`.
    pub table: CalTable<N>,
    /// The table was measured on this sensor.
    pub calibrated: bool,
    /// This sensor's film as measured: its loss tangent
    /// ([`SensorSettings::loss_tangent`]) with [`FILM_DRIFT`] for its
    /// spread; None: the material's, as the settings give it.
    pub film: Option<Dielectric>,
}

/// How far a film's tan δ may move from what its calibration measured
/// (1σ): temperature and stretch move a silicone's by about as much as
/// its material spreads from film to film (`Dielectric::SILICONE`'s
/// spread), so a measured film keeps that spread and only its mean moves.
pub const FILM_DRIFT: f32 = Dielectric::SILICONE.spread;

impl<const N: usize> Sensor<N> {
    /// The film the line is fitted on: this sensor's where it was
    /// measured, else `material`. A film's tan δ spreads over 1–5·10⁻³
    /// from sensor to sensor; a fit whose prior sits away from it pays
    /// the distance in χ² (2.6 at 1.6σ), which the model check's history
    /// then takes for an error it must bound.
    #[inline(always)]
    pub fn film<'a>(&'a self, material: &'a Dielectric) -> &'a Dielectric {
        self.film.as_ref().unwrap_or(material)
    }

    /// A sensor whose film was measured at loss tangent `t` (None: its
    /// material's): the fit's prior centred there, [`FILM_DRIFT`] wide.
    pub fn with_loss_tangent(self, t: Option<f32>) -> Self {
        Self {
            film: t.map(|loss_tangent| Dielectric {
                loss_tangent,
                spread: FILM_DRIFT,
            }),
            ..self
        }
    }

    /// Stretch (mm) for capacitance `c` (F): None while the sensor has no
    /// calibration of its own.
    pub fn stretch(&self, c: f32) -> Option<f32> {
        self.calibrated.then(|| self.table.stretch(c))
    }

    /// The record's stretch and status flags for line capacitance `c`
    /// (F): the table's stretch, or 0 with [`Flags::UNCALIBRATED`]; with
    /// [`Flags::OFF_TABLE`] where `c` lies beyond the table's span by
    /// more than `margin` (relative).
    pub fn read(&self, c: f32, margin: f32) -> (f32, u16) {
        match self.stretch(c) {
            None => (0.0, Flags::UNCALIBRATED),
            Some(s) if self.table.covers(c, margin) => (s, 0),
            Some(s) => (s, Flags::OFF_TABLE),
        }
    }
}

impl Sensor<POINTS> {
    /// A sensor calibrated by `table` (its rest capacitance the table's
    /// first point), with tab leads of `lead_ratio` line resistances and
    /// `fixture` in front of it; an error for a lead ratio beyond the line
    /// model's range.
    pub fn calibrated(
        table: CalTable<POINTS>,
        lead_ratio: f32,
        fixture: Fixture,
    ) -> Result<Self, ModelError> {
        Ok(Self {
            in_use: true,
            tracker: tracker_with_leads(lead_ratio)?,
            fixture,
            rest_farad: table.rest_capacitance(),
            table,
            calibrated: true,
            film: None,
        })
    }

    /// A sensor nothing was measured on, resting near `nominal_farad`:
    /// the line without leads or wiring, stretch not calibrated.
    pub fn uncalibrated(nominal_farad: f32) -> Self {
        Self {
            in_use: true,
            tracker: tracker(),
            fixture: Fixture::NONE,
            rest_farad: nominal_farad,
            table: CalTable {
                points: SensorSettings::unknown(nominal_farad, 1e6).table,
            },
            calibrated: false,
            film: None,
        }
    }

    /// The sensor a stored sensor setting describes (checked by
    /// [`Stored::check`]: an error only for a lead ratio the check would
    /// refuse).
    pub fn of(s: &SensorSettings) -> Result<Self, ModelError> {
        Ok(Self {
            in_use: s.in_use,
            tracker: tracker_with_leads(s.lead_ratio)?,
            fixture: Fixture {
                parallel_farad: s.parasitic_farad,
                series_ohm: s.contact_ohm,
            },
            rest_farad: s.nominal_c_farad,
            table: CalTable { points: s.table },
            calibrated: s.calibrated,
            film: None,
        }
        .with_loss_tangent(s.loss_tangent))
    }

    /// This sensor as a stored setting, its electrode resistance at rest
    /// `nominal_r_ohm`.
    pub fn settings(&self, nominal_r_ohm: f32) -> SensorSettings {
        SensorSettings {
            in_use: self.in_use,
            nominal_c_farad: self.rest_farad,
            nominal_r_ohm,
            lead_ratio: self.tracker.inverter().lead_ratio(),
            contact_ohm: self.fixture.series_ohm,
            parasitic_farad: self.fixture.parallel_farad,
            table: self.table.points,
            calibrated: self.calibrated,
            loss_tangent: self.film.map(|f| f.loss_tangent),
        }
    }
}

/// The sensors of an instrument: `S` of them, sensor `s` described by
/// entry `min(s, S − 1)`. An instrument short of memory keeps one entry
/// for all its sensors (`S` = 1).
#[derive(Clone, Copy, Debug)]
pub struct Sensors<const N: usize, const S: usize> {
    each: [Sensor<N>; S],
}

impl<const N: usize, const S: usize> Sensors<N, S> {
    /// Needs one entry at least.
    const ONE: () = assert!(S >= 1, "an instrument describes one sensor at least");

    /// Every sensor as `sensor`.
    pub fn all(sensor: Sensor<N>) -> Self {
        let () = Self::ONE;
        Self { each: [sensor; S] }
    }

    /// Sensor `s` as `f(s)`.
    pub fn from_fn(f: impl FnMut(usize) -> Sensor<N>) -> Self {
        let () = Self::ONE;
        Self {
            each: core::array::from_fn(f),
        }
    }

    /// Sensor `s`'s description.
    pub fn of(&self, s: u8) -> &Sensor<N> {
        let () = Self::ONE;
        &self.each[usize::from(s).min(S - 1)]
    }

    /// Sensor `s`'s description, to change.
    pub fn of_mut(&mut self, s: u8) -> &mut Sensor<N> {
        let () = Self::ONE;
        &mut self.each[usize::from(s).min(S - 1)]
    }

    /// The entries.
    pub fn iter(&self) -> impl Iterator<Item = &Sensor<N>> {
        self.each.iter()
    }

    /// The calibration of every sensor (which are calibrated, and their
    /// tables): what a start frame's calibration digest is of.
    pub fn calibration(&self) -> Calibration<'_, N, S> {
        Calibration(self)
    }
}

impl<const S: usize> Sensors<POINTS, S> {
    /// The sensors of stored set `set` (sensor `s` from `set.sensors[s]`;
    /// `S` ≤ [`SENSORS_MAX`]); an error for a lead ratio beyond the line
    /// model's range (a set that passed [`Stored::check`] has none).
    pub fn of_stored(set: &Stored) -> Result<Self, ModelError> {
        let mut sensors = Self::all(Sensor::uncalibrated(set.sensors[0].nominal_c_farad));
        sensors.load(set)?;
        Ok(sensors)
    }

    /// Take stored set `set` in place, entry by entry (a device builds
    /// its sensors where they stay: 16 of them are 10 KiB); on an error
    /// (a lead ratio beyond the model, which [`Stored::check`] refuses)
    /// the entries before the faulty one are the set's, the rest as they
    /// were.
    pub fn load(&mut self, set: &Stored) -> Result<(), ModelError> {
        const { assert!(S <= SENSORS_MAX) };
        for (e, s) in self.each.iter_mut().zip(set.sensors.iter()) {
            *e = Sensor::of(s)?;
        }
        Ok(())
    }
}

/// The sensors' calibration alone (see [`Sensors::calibration`]).
#[derive(Clone, Copy, Debug)]
pub struct Calibration<'a, const N: usize, const S: usize>(pub &'a Sensors<N, S>);

impl Stored {
    /// The set an instrument runs with: each of its sensors (entry
    /// `min(s, S − 1)` for sensor `s`), the first `sensors` in use and the
    /// rest not, nominal R `r_ohm`, its policy.
    pub fn of_sensors<const S: usize>(
        sensors: &Sensors<POINTS, S>,
        policy: &Policy,
        r_ohm: f32,
        in_use: usize,
    ) -> Self {
        let p = policy;
        Self {
            version: FORMAT_VERSION,
            record_every: 1,
            policy: Policy {
                // Within the set, as the check asks.
                tones: {
                    let (lo, hi) = p.limits(PERIODS.len());
                    (lo as u8, hi as u8)
                },
                ..*p
            },
            sensors: core::array::from_fn(|s| SensorSettings {
                in_use: s < in_use,
                ..sensors.of(s as u8).settings(r_ohm)
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::REFERENCE;

    #[test]
    fn an_uncalibrated_sensor_reads_no_stretch_and_no_leads() {
        let s = Sensor::uncalibrated(150e-12);
        assert_eq!(s.stretch(160e-12), None);
        assert_eq!(s.tracker.inverter().lead_ratio(), 0.0);
        assert_eq!(s.fixture, Fixture::NONE);
        assert_eq!(s.rest_farad, 150e-12);
        let c = Sensor::calibrated(REFERENCE, 0.64, Fixture::NONE).unwrap();
        let want = REFERENCE.stretch(REFERENCE.points[4].0);
        assert_eq!(c.stretch(REFERENCE.points[4].0), Some(want));
        assert_eq!(c.tracker.inverter().lead_ratio(), 0.64);
        assert!(Sensor::calibrated(REFERENCE, 51.0, Fixture::NONE).is_err());
    }

    #[test]
    fn a_reading_beyond_the_table_is_marked_off_it() {
        let s = Sensor::calibrated(REFERENCE, 0.0, Fixture::NONE).unwrap();
        let (lo, hi) = (REFERENCE.points[0].0, REFERENCE.points[POINTS - 1].0);
        let m = 0.008;
        assert_eq!(s.read(lo, m), (0.0, 0));
        assert_eq!(s.read(lo * 0.995, m).1, 0, "within the margin");
        assert_eq!(s.read(lo * 0.99, m).1, Flags::OFF_TABLE);
        assert_eq!(s.read(hi * 1.005, m).1, 0);
        assert_eq!(s.read(hi * 1.01, m).1, Flags::OFF_TABLE);
        assert_eq!(s.read(f32::NAN, m).1, Flags::OFF_TABLE);
        assert_eq!(Sensor::uncalibrated(lo).read(lo, m), (0.0, Flags::UNCALIBRATED));
        assert!(!Flags(Flags::OFF_TABLE).stretch_valid() && Flags(Flags::OFF_TABLE).valid());
        assert!(!Flags(Flags::UNCALIBRATED).stretch_valid() && Flags(0).stretch_valid());
    }

    #[test]
    fn a_stored_set_gives_each_sensor_its_own() {
        let mut set = Stored::uncalibrated();
        set.sensors[3].lead_ratio = 0.5;
        set.sensors[3].contact_ohm = 2e3;
        set.sensors[3].table = REFERENCE.points;
        set.sensors[3].calibrated = true;
        set.sensors[5].in_use = false;
        assert_eq!(set.check(), Ok(()));
        let sensors: Sensors<POINTS, 16> = Sensors::of_stored(&set).unwrap();
        assert!(sensors.of(3).calibrated && sensors.of(3).tracker.inverter().lead_ratio() == 0.5);
        assert_eq!(sensors.of(3).fixture.series_ohm, 2e3);
        assert!(!sensors.of(5).in_use);
        assert!(!sensors.of(4).calibrated && sensors.of(4).tracker.inverter().lead_ratio() == 0.0);
        // Round trip through the stored form.
        for s in 0..16u8 {
            let back = sensors.of(s).settings(set.sensors[usize::from(s)].nominal_r_ohm);
            assert_eq!(back, set.sensors[usize::from(s)]);
        }
        // One entry for all.
        let one: Sensors<POINTS, 1> = Sensors::of_stored(&set).unwrap();
        assert!(core::ptr::eq(one.of(0), one.of(15)));
        // A lead ratio beyond the model: an error, not a sensor.
        set.sensors[7].lead_ratio = 60.0;
        assert!(Sensors::<POINTS, 16>::of_stored(&set).is_err());
    }
}
