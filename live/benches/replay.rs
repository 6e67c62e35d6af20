//! Replaying a recorded stream (`live --replay FILE`, `live::replay`):
//! the array's link at 16 sensors × 1,000 records/s for 10 s (160,000
//! record frames, COBS-framed postcard with CRC-32), decoded, checked
//! and written as a data set. Target: ≥ 10⁶ records/s.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use link::{Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::time::Duration;

/// Sensors, records per second each, seconds.
const SENSORS: u32 = 16;
const RATE: u32 = 1000;
const SECONDS: u32 = 10;

/// The stream of a skin stretching: every sensor's line moving, a few
/// records flagged.
fn stream() -> (Vec<u8>, u32) {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = vec![];
    let start = Start {
        version: VERSION,
        firmware: Start::firmware_field("skin-array 0.1.0"),
        settings_digest: 0xDEAD_BEEF,
        calibration_digest: 0x0BAD_F00D,
        sensors: SENSORS as u8,
        sample_rate_hz: 25_000,
    };
    bytes.extend_from_slice(enc.start(&start, &mut out).unwrap());
    let n = SENSORS * RATE * SECONDS;
    for k in 0..n {
        let (block, sensor) = (k / SENSORS, k % SENSORS);
        let phase = (block as f32 * 1e-3 + sensor as f32 * 0.6).sin();
        let c = 205e-12 * (1.0 + 0.3 * phase);
        let r = 7.1e5 * (1.0 + 0.5 * phase);
        let rec = Record {
            t_us: 500 + 1000 * u64::from(block),
            sensor: sensor as u8,
            tones: [
                Tone {
                    f_hz: 1000.0,
                    z_re_ohm: 0.33 * r,
                    z_im_ohm: -1.0 / (std::f32::consts::TAU * 1000.0 * c),
                },
                Tone {
                    f_hz: 4000.0,
                    z_re_ohm: 0.3 * r,
                    z_im_ohm: -1.0 / (std::f32::consts::TAU * 4000.0 * c),
                },
            ],
            c_farad: c,
            r_ohm: r,
            stretch_mm: 100.0 * (c / 205e-12 - 1.0),
            chosen_hz: 4000.0,
            chi2: 3.9,
            sigma_ln_c: 4e-4,
            flags: if k % 97 == 0 { 128 } else { 0 },
        };
        bytes.extend_from_slice(enc.record(&rec, &mut out).unwrap());
    }
    let end = End {
        records: n,
        dropped: 0,
    };
    bytes.extend_from_slice(enc.end(&end, &mut out).unwrap());
    (bytes, n)
}

fn bench(c: &mut Criterion) {
    let (bytes, n) = stream();
    let mut g = c.benchmark_group("replay");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.throughput(Throughput::Elements(u64::from(n)));
    g.bench_function("array_16x1000_10s", |b| {
        b.iter(|| {
            let dir = tempfile::tempdir().unwrap();
            let done = live::replay(&bytes, dir.path(), live::Earlier::Refuse).unwrap();
            assert_eq!(done.summary.records, n as usize);
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
