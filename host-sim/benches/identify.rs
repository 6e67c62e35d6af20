//! `identify` on a 6-trace data set of 1500 rows per trace (the paper's
//! trapezoids at 10 and 20 mm/s, 500 / 2000 / 6000 Hz, with calibration
//! and sweep): a wiring effect alone (contact resistance, a uniform
//! line), a shape effect alone (nonuniform stretch, the segmented line),
//! and the two together (contact resistance and a symmetric stretch mode:
//! every single effect, then every pair, the slowest path); a set nothing
//! in the library explains (dielectric dispersion: every single effect
//! and every pair tried, never explained); and a set whose one trace
//! holds 10⁶ rows (read, decimated, fitted). Targets: ≤ 10 s
//! each on 2 cores in release, ≤ 60 s for the 10⁶-row trace.

use criterion::{criterion_group, criterion_main, Criterion};
use host_sim::chain::Meter;
use host_sim::dataset::read_dir;
use host_sim::experiments::{dataset, dense_trace, with_effects};
use host_sim::identify::{identify, Options};
use host_sim::model::{Effect, EffectSet};
use indicatif::ProgressBar;
use std::time::Duration;

/// A data set of the hidden effects `fx` (noise seed `seed`), written
/// into a folder of its own.
fn set(fx: EffectSet, seed: u64) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    dataset(
        dir.path(),
        with_effects(fx),
        Meter::lcr(&fx),
        seed,
        ProgressBar::hidden(),
    )
    .unwrap();
    dir
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("identify");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    let cr = Effect::ContactResistance;
    for (name, effects) in [
        ("contact_resistance_30k", vec![(cr, 30e3)]),
        ("nonuniform_stretch_0.3", vec![(Effect::NonuniformStretch, 0.3)]),
        (
            "contact_50k_and_stretch_bulge_0.3",
            vec![(cr, 50e3), (Effect::StretchBulge, 0.3)],
        ),
    ] {
        let fx = effects.iter().fold(EffectSet::NONE, |fx, &(e, v)| fx.with(e, v));
        let dir = set(fx, 3);
        let ds = read_dir(dir.path()).unwrap();
        assert_eq!(ds.traces.len(), 6);
        assert!(ds.traces.iter().all(|t| t.rows.len() == 1500));
        g.bench_function(name, |b| {
            b.iter(|| {
                let r = identify(&ds, Options::default()).unwrap();
                let mut named = r.accepted.as_ref().map_or(vec![], |f| f.effects.clone());
                named.sort_by_key(|e| e.id());
                let mut want: Vec<Effect> = effects.iter().map(|x| x.0).collect();
                want.sort_by_key(|e| e.id());
                assert_eq!(named, want);
                r
            })
        });
    }
    // Nothing in the library explains it.
    let dir = set(EffectSet::NONE.with(Effect::DielectricDispersion, 0.03), 3);
    let ds = read_dir(dir.path()).unwrap();
    g.bench_function("unexplained_dielectric_dispersion_0.03", |b| {
        b.iter(|| {
            let r = identify(&ds, Options::default()).unwrap();
            assert!(r.accepted.is_none(), "never explained: {}", r.verdict());
            r
        })
    });
    g.finish();
    // A 10⁶-row trace: reading the files is part of what a user waits
    // for.
    let mut g = c.benchmark_group("identify_long");
    g.sample_size(10).measurement_time(Duration::from_secs(300));
    let dir = set(EffectSet::NONE.with(Effect::ContactResistance, 30e3), 7);
    dense_trace(&dir.path().join("trace_20mmps_2000hz.csv"), 1_000_000, 0.03, 11).unwrap();
    g.bench_function("million_row_trace_read_and_identified", |b| {
        b.iter(|| {
            let ds = read_dir(dir.path()).unwrap();
            let r = identify(&ds, Options::default()).unwrap();
            assert_eq!(
                r.accepted.as_ref().map(|f| f.effects.clone()),
                Some(vec![Effect::ContactResistance])
            );
            r
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
