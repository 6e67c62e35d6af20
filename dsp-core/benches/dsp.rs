//! Host benchmarks (criterion) of the dsp-core kernels: ns per demodulated
//! sample pair, per line-model evaluation and per inversion.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use dsp_core::demod::Demodulator;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::{Oscillator, OscillatorState};

const PAIRS: usize = 2048;
const XS: [f32; 8] = [0.02, 0.1, 0.3, 1.0, 2.0, 3.5, 5.0, 6.0];

fn demod(c: &mut Criterion) {
    let osc = Oscillator::coherent(6000.0, 200e3, 11).unwrap();
    let mut st = OscillatorState::default();
    let mut buf = [[0i16; 2]; PAIRS];
    for p in buf.iter_mut() {
        let (co, s) = osc.next(&mut st);
        *p = [(co >> 17) as i16, (s >> 18) as i16];
    }
    let dm = Demodulator::<PAIRS>::new(&osc);
    let mut g = c.benchmark_group("demod");
    g.throughput(Throughput::Elements(PAIRS as u64));
    g.bench_function("block_2048_pairs", |b| b.iter(|| dm.block(black_box(&buf))));
    g.finish();
}

fn model(c: &mut Criterion) {
    let mut g = c.benchmark_group("model");
    g.throughput(Throughput::Elements(XS.len() as u64));
    for (name, m) in [
        ("ladder30", LineModel::Ladder(30)),
        ("continuous", LineModel::Continuous),
    ] {
        g.bench_function(format!("eval_{name}"), |b| {
            b.iter(|| {
                XS.iter()
                    .map(|&x| black_box(m).zeta(black_box(x)).unwrap().re)
                    .sum::<f32>()
            })
        });
        let inv = Inverter::new(m);
        let zs: Vec<_> = XS
            .iter()
            .map(|&x| m.zeta(x).unwrap() / (std::f32::consts::TAU * 6e3 * 200e-12))
            .collect();
        g.bench_function(format!("invert_{name}"), |b| {
            b.iter(|| {
                zs.iter()
                    .map(|&z| inv.invert(black_box(z), 6e3).unwrap().x)
                    .sum::<f32>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, demod, model);
criterion_main!(benches);
