//! Replaying a recorded stream (`live --replay FILE`, `live::replay`):
//! the array's link at 16 sensors × 1,000 records/s for 10 s (160,000
//! record frames, COBS-framed postcard with CRC-32), decoded, checked
//! and written as a data set. Target: ≥ 10⁶ records/s.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::time::Duration;

/// Sensors, records per second each, seconds.
const SENSORS: u32 = 16;
const RATE: u32 = 1000;
const SECONDS: u32 = 10;

/// The synthetic skin's stream ([`live::synthetic`]): every sensor's
/// line moving, a few records flagged; its records.
fn stream() -> (Vec<u8>, u32) {
    let n = SENSORS * RATE * SECONDS;
    let mut bytes = vec![];
    live::synthetic::write_skin_stream(&mut bytes, SENSORS as u8, n).unwrap();
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
