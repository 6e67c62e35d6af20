//! A synthetic skin's record stream, the one the replay benchmark, the
//! memory test and `cargo xtask soak` feed `live`: the array's sensors
//! read once a millisecond, each line's C and R moving slowly with its
//! own phase, one record in 97 flagged `UNCERTAIN`.

use link::{Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::io::{Error, ErrorKind, Result, Write};

/// Record `k` of the stream of a skin of `sensors`: sensor `k mod
/// sensors` of block `k / sensors` (1 ms each), its two tones (1 and
/// 4 kHz) those of its line.
pub fn skin_record(k: u64, sensors: u64) -> Record {
    let (block, sensor) = (k / sensors, (k % sensors) as u8);
    let phase = (block as f32 * 1e-3 + f32::from(sensor) * 0.6).sin();
    let c = 205e-12 * (1.0 + 0.3 * phase);
    let r = 7.1e5 * (1.0 + 0.5 * phase);
    let tone = |f_hz: f32, share: f32| Tone {
        f_hz,
        z_re_ohm: share * r,
        z_im_ohm: -1.0 / (std::f32::consts::TAU * f_hz * c),
    };
    Record {
        t_us: 500 + 1000 * block,
        sensor,
        tones: [tone(1000.0, 0.33), tone(4000.0, 0.3)],
        c_farad: c,
        r_ohm: r,
        stretch_mm: 100.0 * (c / 205e-12 - 1.0),
        chosen_hz: 4000.0,
        chi2: 3.9,
        sigma_ln_c: 4e-4,
        flags: if k.is_multiple_of(97) {
            instrument::faults::Flags::UNCERTAIN
        } else {
            0
        },
    }
}

/// The start frame of that skin's device.
pub fn skin_start(sensors: u8) -> Start {
    Start {
        version: VERSION,
        firmware: Start::firmware_field("skin-array 0.1.0"),
        settings_digest: 0xDEAD_BEEF,
        calibration_digest: 0x0BAD_F00D,
        sensors,
        sample_rate_hz: 25_000,
        generation: 0,
        device_id: 0,
        self_test: link::SelfTest::default(),
    }
}

/// Write the whole stream of `records` records of a skin of `sensors`
/// to `w`: its start frame, the records, its end frame.
pub fn write_skin_stream(w: &mut impl Write, sensors: u8, records: u32) -> Result<()> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let frame_error = |e: link::Error| Error::new(ErrorKind::InvalidData, format!("{e}"));
    w.write_all(enc.start(&skin_start(sensors), &mut out).map_err(frame_error)?)?;
    for k in 0..records {
        let rec = skin_record(u64::from(k), u64::from(sensors));
        w.write_all(enc.record(&rec, &mut out).map_err(frame_error)?)?;
    }
    let end = End { records, dropped: 0 };
    w.write_all(enc.end(&end, &mut out).map_err(frame_error)?)?;
    w.flush()
}
