//! `identify` on a 6-trace data set of 1500 rows per trace (the paper's
//! trapezoids at 10 and 20 mm/s, 500 / 2000 / 6000 Hz, with calibration
//! and sweep), one hidden effect each: a wiring effect (contact
//! resistance, a uniform line) and a shape effect (nonuniform stretch,
//! the segmented line: the slowest kind). Target: ≤ 10 s each on 2 cores
//! in release.

use criterion::{criterion_group, criterion_main, Criterion};
use host_sim::chain::Meter;
use host_sim::dataset::read_dir;
use host_sim::experiments::{dataset, with_effects};
use host_sim::identify::{identify, Options};
use host_sim::model::{Effect, EffectSet};
use indicatif::ProgressBar;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("identify");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    for (name, effect, v) in [
        ("contact_resistance_30k", Effect::ContactResistance, 30e3),
        ("nonuniform_stretch_0.3", Effect::NonuniformStretch, 0.3),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let fx = EffectSet::NONE.with(effect, v);
        dataset(
            dir.path(),
            with_effects(fx),
            Meter::lcr(&fx),
            3,
            ProgressBar::hidden(),
        )
        .unwrap();
        let ds = read_dir(dir.path()).unwrap();
        assert_eq!(ds.traces.len(), 6);
        assert!(ds.traces.iter().all(|t| t.rows.len() == 1500));
        g.bench_function(name, |b| {
            b.iter(|| {
                let r = identify(&ds, Options::default()).unwrap();
                assert_eq!(r.accepted.as_ref().map(|f| f.effects[0]), Some(effect));
                r
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
