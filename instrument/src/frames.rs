//! Records as frames of the record link ([`link`]): the one conversion
//! each way between the instrument's records and the link's (a start
//! frame's digests: [`crate::digest`]).

use crate::channel::Record;
use crate::digest::{Digest, Digestible};
use crate::faults::Flags;
use crate::tones::ToneRecord;
use dsp_core::lumped::SeriesRc;
use dsp_core::Complex32;
use link::Tone;

/// An array record as a link record. The chosen frequency is the policy's
/// tone, the higher of the two.
pub fn from_tone_record(r: &ToneRecord) -> link::Record {
    let tone = |k: usize| Tone {
        f_hz: r.f_hz[k],
        z_re_ohm: r.z[k].re,
        z_im_ohm: r.z[k].im,
    };
    link::Record {
        t_us: r.t_us,
        sensor: r.sensor,
        tones: [tone(0), tone(1)],
        c_farad: r.c_farad,
        r_ohm: r.r_ohm,
        stretch_mm: r.stretch_mm,
        chosen_hz: r.f_hz[1],
        chi2: r.chi2,
        sigma_ln_c: r.sigma_ln_c,
        flags: r.flags.0,
    }
}

/// A link record of the array as the array's record.
pub fn to_tone_record(r: &link::Record) -> ToneRecord {
    ToneRecord {
        t_us: r.t_us,
        sensor: r.sensor,
        f_hz: [r.tones[0].f_hz, r.tones[1].f_hz],
        z: r.tones.map(|t| Complex32::new(t.z_re_ohm, t.z_im_ohm)),
        c_farad: r.c_farad,
        r_ohm: r.r_ohm,
        chi2: r.chi2,
        sigma_ln_c: r.sigma_ln_c,
        stretch_mm: r.stretch_mm,
        flags: Flags(r.flags),
    }
}

/// A multiplexed record as a link record: the policy's tone's impedance
/// from the lumped reading, Z = Rs − j/(ωCs) (zero when there is none),
/// the second tone's as measured, the two tones' χ² and σ of C.
pub fn from_record(r: &Record) -> link::Record {
    let z = match r.cs_farad > 0.0 && r.freq_hz > 0.0 {
        true => SeriesRc {
            cs_farad: r.cs_farad,
            rs_ohm: r.rs_ohm,
        }
        .impedance(r.freq_hz),
        false => Complex32::new(0.0, 0.0),
    };
    let tone = Tone {
        f_hz: r.freq_hz,
        z_re_ohm: z.re,
        z_im_ohm: z.im,
    };
    let companion = Tone {
        f_hz: r.companion_hz,
        z_re_ohm: r.companion_z.re,
        z_im_ohm: r.companion_z.im,
    };
    link::Record {
        t_us: r.t_us,
        sensor: r.sensor,
        tones: [tone, companion],
        c_farad: r.c_farad,
        r_ohm: r.r_ohm,
        stretch_mm: r.stretch_mm,
        chosen_hz: r.freq_hz,
        chi2: r.chi2,
        sigma_ln_c: r.sigma_ln_c,
        flags: r.flags.0,
    }
}

/// A stream's start frame: the firmware's name and version, the device's
/// id, the stored set in force (its `generation`, 0: none stored, and the
/// digests of its settings and calibrations), the sensors and the sample
/// rate.
pub fn start(
    firmware: &str,
    device_id: u32,
    generation: u32,
    settings: &impl Digestible,
    calibration: &impl Digestible,
    sensors: usize,
    sample_rate_hz: u32,
) -> link::Start {
    link::Start {
        version: link::VERSION,
        firmware: link::Start::firmware_field(firmware),
        settings_digest: Digest::of(settings),
        calibration_digest: Digest::of(calibration),
        sensors: sensors as u8,
        sample_rate_hz,
        generation,
        device_id,
        // Not run: an array firmware sets its own after the test.
        self_test: link::SelfTest::default(),
    }
}

/// The frame of stored set `generation` applied while the device runs
/// (its settings and calibrations), at device time `t_us`.
pub fn applied(
    generation: u32,
    settings: &impl Digestible,
    calibration: &impl Digestible,
    t_us: u64,
) -> link::Applied {
    link::Applied {
        generation,
        settings_digest: Digest::of(settings),
        calibration_digest: Digest::of(calibration),
        t_us,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tone_record_survives_the_link() {
        let r = ToneRecord {
            t_us: 12_345_678,
            sensor: 7,
            f_hz: [500.0, 2000.0],
            z: [Complex32::new(4.1e5, -1.6e6), Complex32::new(2.0e5, -3.9e5)],
            c_farad: 205.1e-12,
            r_ohm: 1.0e6,
            chi2: 1.2,
            sigma_ln_c: 4e-4,
            stretch_mm: 3.5,
            flags: Flags(Flags::MODEL),
        };
        assert_eq!(to_tone_record(&from_tone_record(&r)), r);
    }

    #[test]
    fn a_multiplexed_record_carries_its_lumped_reading_and_its_second_tone() {
        let r = Record {
            t_us: 2560,
            sensor: 3,
            freq_hz: 1953.125,
            cs_farad: 201.5e-12,
            rs_ohm: 123_456.0,
            c_farad: 209.9e-12,
            r_ohm: 7e5,
            stretch_mm: -0.1,
            flags: Flags(Flags::UNCERTAIN),
            companion_hz: 976.5625,
            companion_z: Complex32::new(2.5e5, -8.1e5),
            chi2: 3.5,
            sigma_ln_c: 2e-4,
        };
        let l = from_record(&r);
        let cs = -1.0 / (core::f32::consts::TAU * l.tones[0].f_hz * l.tones[0].z_im_ohm);
        assert!((cs / r.cs_farad - 1.0).abs() < 1e-6, "{cs}");
        assert_eq!(
            (l.tones[0].z_re_ohm, l.chosen_hz, l.flags),
            (r.rs_ohm, r.freq_hz, r.flags.0)
        );
        assert_eq!(
            (
                l.tones[1].f_hz,
                l.tones[1].z_re_ohm,
                l.tones[1].z_im_ohm,
                l.chi2,
                l.sigma_ln_c
            ),
            (976.5625, 2.5e5, -8.1e5, 3.5, 2e-4)
        );
        assert_eq!(l.measured().count(), 2);
    }
}
