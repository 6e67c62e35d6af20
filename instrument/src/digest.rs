//! Digests of settings and calibrations, as a start frame carries them: a
//! CRC-32 (ISO-HDLC) over the values field by field, in declaration
//! order, every `f32` as its IEEE-754 bits and every integer as
//! little-endian bytes. The same on the host and the device by
//! construction, and with no float formatting on the device (which would
//! cost the board image some 25 KiB of flash).
//!
//! A derived table (the inverter's grid) is not digested: what it is
//! derived from is (the line model, its bound, the leads).

use crate::calib::CalTable;
use crate::channel::Settings;
use crate::faults::Thresholds;
use crate::policy::Policy;
use crate::ranging::Ranging;
use crate::sensor::{Calibration, Sensor, Sensors};
use crate::stored::{SensorSettings, Stored};
use crate::tones::ToneSettings;
use dsp_core::demod::FrontEnd;
use dsp_core::fixture::Fixture;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::track::Tracker;
use dsp_core::Complex32;

/// A digest under way.
pub struct Digest(crc::Digest<'static, u32, link::CrcTable>);

impl Default for Digest {
    fn default() -> Self {
        Self(link::CRC.digest())
    }
}

impl Digest {
    /// The digest of `value`.
    pub fn of(value: &impl Digestible) -> u32 {
        let mut d = Self::default();
        value.feed(&mut d);
        d.finish()
    }

    /// Take `bytes`. Not inlined: a digest is taken once, at start, and
    /// each field's call stays a call (inlined, the CRC's loop would be
    /// repeated at every field: 4 KiB more flash on the board).
    #[inline(never)]
    pub fn bytes(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    /// The digest so far.
    pub fn finish(self) -> u32 {
        self.0.finalize()
    }
}

/// What a digest can be taken of.
pub trait Digestible {
    /// Feed the value to `d`.
    fn feed(&self, d: &mut Digest);
}

impl Digestible for f32 {
    fn feed(&self, d: &mut Digest) {
        d.bytes(&self.to_bits().to_le_bytes());
    }
}

impl Digestible for u8 {
    fn feed(&self, d: &mut Digest) {
        d.bytes(&[*self]);
    }
}

/// A tag (0: none, 1: some), then the value.
impl<T: Digestible> Digestible for Option<T> {
    fn feed(&self, d: &mut Digest) {
        match self {
            None => d.bytes(&[0]),
            Some(v) => {
                d.bytes(&[1]);
                v.feed(d);
            }
        }
    }
}

impl Digestible for bool {
    fn feed(&self, d: &mut Digest) {
        d.bytes(&[u8::from(*self)]);
    }
}

impl Digestible for u16 {
    fn feed(&self, d: &mut Digest) {
        d.bytes(&self.to_le_bytes());
    }
}

impl Digestible for u32 {
    fn feed(&self, d: &mut Digest) {
        d.bytes(&self.to_le_bytes());
    }
}

impl<T: Digestible, const N: usize> Digestible for [T; N] {
    fn feed(&self, d: &mut Digest) {
        self.iter().for_each(|v| v.feed(d));
    }
}

impl<A: Digestible, B: Digestible> Digestible for (A, B) {
    fn feed(&self, d: &mut Digest) {
        self.0.feed(d);
        self.1.feed(d);
    }
}

impl<T: Digestible + ?Sized> Digestible for &T {
    fn feed(&self, d: &mut Digest) {
        (**self).feed(d);
    }
}

/// Feed each field of a value, in order.
macro_rules! fields {
    ($d:expr, $($v:expr),+ $(,)?) => {{
        $( $v.feed($d); )+
    }};
}

impl Digestible for Complex32 {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.re, self.im);
    }
}

impl Digestible for LineModel {
    fn feed(&self, d: &mut Digest) {
        match self {
            LineModel::Ladder(n) => fields!(d, 0u8, *n),
            LineModel::Continuous => 1u8.feed(d),
        }
    }
}

impl Digestible for Inverter {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.model(), self.x_max(), self.lead_ratio());
    }
}

impl Digestible for Tracker {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.inverter(), self.band());
    }
}

impl Digestible for FrontEnd {
    fn feed(&self, d: &mut Digest) {
        self.gain.feed(d);
    }
}

impl Digestible for Fixture {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.parallel_farad, self.series_ohm);
    }
}

impl Digestible for Policy {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.x_limit,
            self.hysteresis,
            self.decay_per_s,
            self.hold_s,
            self.settle_blocks,
            self.tones
        );
    }
}

impl Digestible for Thresholds {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.open_counts,
            self.no_excitation_counts,
            self.short_ohm,
            self.r_max_ohm,
            self.residual_counts,
            self.residual_rel,
            self.near_counts,
            self.near_rel,
            self.c_tolerance,
            self.noise_counts,
        );
    }
}

impl Digestible for Ranging {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.ranges_ohm, self.half_scale, self.target, self.down);
    }
}

impl<const N: usize> Digestible for CalTable<N> {
    fn feed(&self, d: &mut Digest) {
        self.points.feed(d);
    }
}

/// A sensor: how it is read, then its calibration.
impl<const N: usize> Digestible for Sensor<N> {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.in_use,
            self.tracker,
            self.fixture,
            self.rest_farad,
            self.calibrated,
            self.table,
            self.film.map(|f| f.loss_tangent),
            self.film.map(|f| f.spread),
        );
    }
}

/// Every entry, in order.
impl<const N: usize, const S: usize> Digestible for Sensors<N, S> {
    fn feed(&self, d: &mut Digest) {
        for s in self.iter() {
            s.feed(d);
        }
    }
}

/// Every entry's calibration (whether it has one, and its table), each
/// after its entry number.
impl<const N: usize, const S: usize> Digestible for Calibration<'_, N, S> {
    fn feed(&self, d: &mut Digest) {
        for (k, s) in self.0.iter().enumerate() {
            fields!(d, k as u8, s.calibrated, s.table);
        }
    }
}

impl<const N: usize, const S: usize> Digestible for Settings<'_, N, S> {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.policy,
            self.thresholds,
            self.front_ends,
            self.ranging,
            self.sensors,
            self.record_every,
        );
    }
}

impl<const N: usize> Digestible for ToneSettings<'_, N> {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.policy,
            self.thresholds,
            self.front_end,
            self.sensors,
            self.chi2_flag,
            self.chi2_pair_flag,
            self.record_every,
        );
    }
}

impl Digestible for SensorSettings {
    fn feed(&self, d: &mut Digest) {
        fields!(
            d,
            self.in_use,
            self.nominal_c_farad,
            self.nominal_r_ohm,
            self.lead_ratio,
            self.contact_ohm,
            self.parasitic_farad,
            self.table,
            self.calibrated,
            self.loss_tangent,
        );
    }
}

/// A stored set, as a device keeps it.
impl Digestible for Stored {
    fn feed(&self, d: &mut Digest) {
        fields!(d, self.version, self.record_every, self.policy, self.sensors);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{POINTS, REFERENCE};

    fn sensors(cal: &CalTable<POINTS>) -> Sensors<POINTS, 8> {
        Sensors::all(Sensor::calibrated(*cal, 0.0, Fixture::NONE).unwrap())
    }

    fn settings(sensors: &Sensors<POINTS, 8>) -> Settings<'_, POINTS, 8> {
        Settings::new(
            [FrontEnd::transimpedance(1e5, true); crate::design::RANGES],
            Ranging::DEFAULT,
            sensors,
        )
    }

    /// The digest of the settings on `sensors` changed by `f`.
    fn with(sensors: &Sensors<POINTS, 8>, f: impl FnOnce(&mut Settings<'_, POINTS, 8>)) -> u32 {
        let mut s = settings(sensors);
        f(&mut s);
        Digest::of(&s)
    }

    #[test]
    fn a_digest_is_the_crc_of_the_bits_in_order() {
        // CRC-32/ISO-HDLC of the bytes 00 00 80 3F (1.0f32) then 07.
        let mut d = Digest::default();
        fields!(&mut d, 1.0f32, 7u8);
        assert_eq!(d.finish(), link::CRC.checksum(&[0x00, 0x00, 0x80, 0x3F, 0x07]));
    }

    #[test]
    fn every_setting_and_every_calibration_point_changes_the_digest() {
        let reference = sensors(&REFERENCE);
        let base = Digest::of(&settings(&reference));
        assert_eq!(base, Digest::of(&settings(&reference)), "deterministic");
        let mut changed = std::vec![
            with(&reference, |s| s.policy.x_limit *= 1.0 + f32::EPSILON),
            with(&reference, |s| s.policy.tones.1 = 3),
            with(&reference, |s| s.thresholds.noise_counts += 1.0),
            with(&reference, |s| s.ranging.ranges_ohm[3] *= 2.0),
        ];
        let sensor_changes: [fn(&mut Sensors<POINTS, 8>); 5] = [
            |x| x.of_mut(2).fixture.series_ohm = 1.0,
            |x| x.of_mut(0).tracker = x.of(0).tracker.with_band(0.8, 1.5),
            |x| x.of_mut(7).tracker = crate::sensor::tracker_with_leads(0.5).unwrap(),
            |x| x.of_mut(7).in_use = false,
            |x| x.of_mut(1).calibrated = false,
        ];
        for f in sensor_changes {
            let mut x = reference;
            f(&mut x);
            changed.push(Digest::of(&settings(&x)));
        }
        let mut x = reference;
        x.of_mut(1).calibrated = false;
        changed.push(Digest::of(&x.calibration()));
        let base_cal = Digest::of(&reference.calibration());
        for k in 0..POINTS {
            let mut cal = REFERENCE;
            cal.points[k].1 += 0.01;
            let x = sensors(&cal);
            changed.push(Digest::of(&settings(&x)));
            let c = Digest::of(&x.calibration());
            assert_ne!(c, base_cal);
            changed.push(c);
        }
        assert!(changed.iter().all(|&c| c != base));
        changed.sort_unstable();
        changed.dedup();
        assert_eq!(changed.len(), 10 + 2 * POINTS, "all different");
    }

    #[test]
    fn which_sensor_holds_a_table_changes_the_calibration_digest() {
        let plain = Sensors::<POINTS, 16>::all(Sensor::uncalibrated(200e-12));
        let base = Digest::of(&plain.calibration());
        let own = Sensor::calibrated(REFERENCE, 0.0, Fixture::NONE).unwrap();
        let mut five = plain;
        *five.of_mut(5) = own;
        let mut six = plain;
        *six.of_mut(6) = own;
        let (d5, d6) = (Digest::of(&five.calibration()), Digest::of(&six.calibration()));
        assert!(base != d5 && d5 != d6, "which sensor matters too");
    }
}
