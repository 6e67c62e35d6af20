//! Benchmark of the whole `paper` run (target: under 10 s in release on a
//! 2-core machine).

use criterion::{criterion_group, criterion_main, Criterion};
use host_sim::experiments::{paper, Ctx};

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("paper");
    g.sample_size(10);
    g.bench_function("paper_run_2_periods", |b| {
        b.iter(|| {
            let ctx = Ctx::new(dir.path(), 1).unwrap();
            paper(&ctx).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
