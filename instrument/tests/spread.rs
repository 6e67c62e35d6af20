//! The spreads of an interferer over a record's tones
//! (`instrument::spread`) against the comb itself: a sinusoid added to a
//! sensor's current in the simulated front end (`skin_sim::array`),
//! demodulated by the reader, moves each fitted tone's V/I as the
//! spread at its frequency says, for some phase of the sinusoid.

use dsp_core::comb::Levels;
use dsp_core::fixture::Fixture;
use dsp_core::Complex32;
use instrument::array::{Frame, Layout, BLOCK_INSTANTS, SENSORS};
use instrument::reader::{ArrayReader, Demodulated};
use instrument::sensor::{self as skin_sensor, Sensors};
use instrument::spread::{factors, spread_at};
use instrument::tones::ToneChannel;
use skin_sim::array::ArrayFrontEnd;
use skin_sim::frontend::Disturbance;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};
use skin_spec::leak::{KERNEL, NU, POINTS};

/// For every frequency of `skin_spec::leak::NU`, two phases, the
/// paper's sensor and one of electrodes 4 times its (at the tones it
/// reads, to 2 kHz), and each set of tones a record fits: a sinusoid on
/// the current's input that moves the fitted tone it moves most by 1 %
/// changes the fitted tones' V/I (averaged over 8 noise seeds, each
/// drawn alike with the sinusoid and without) by a vector that the
/// spread's two quadratures span to 2.5 % of its size (what first order
/// and the ADC's rounding leave; with the kernels conjugated, the first
/// case is 3.7 % off), and, up to 100 counts, with the sinusoid's own
/// amplitude (to 3 %: the spreads are in Ω per count).
#[test]
fn a_sinusoid_on_the_current_moves_the_tones_along_its_spread() {
    let layout = Layout::BLOCK_4MS;
    let fe = ArrayFrontEnd::reference(layout);
    let paper = SensorParams::PAPER;
    let each = Sensors::all(
        skin_sensor::Sensor::calibrated(
            skin_sim::sensor::PAPER_CALIBRATION,
            paper.effects.lead_ratio(),
            Fixture::NONE,
        )
        .unwrap(),
    );
    let reader = ArrayReader::new(layout, &each).unwrap();
    let hz = layout.tones_hz().map(|f| f as f64);
    let mut worst = 0f64;
    for (r_scale, highest) in [(1.0, 4), (4.0, 3)] {
        let params = paper.with_electrodes_scaled(r_scale);
        let z = [Sensor::settled(params).impedances(&hz); SENSORS];
        let levels_of = |hum: &Disturbance, seed: u64| -> (Levels<5>, Levels<5>) {
            let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
            fe.frame(&z, &[*hum; SENSORS], &mut Rng::new(seed), &mut frame);
            let mut d = Demodulated::EMPTY;
            reader.demodulate_into(|a| layout.rows(&frame[a]), &mut d);
            (d.v.levels(), d.i[0].levels())
        };
        let (v0, i0) = levels_of(&Disturbance::NONE, 11);
        for hi in 1..=highest {
            let fitted = ToneChannel::fitted_of(ToneChannel::pair_of(hi));
            let ratio = |v: &Levels<5>, i: &Levels<5>| -> [Complex32; 3] {
                fitted.map(|k| Levels::ratio(v, i, k).unwrap())
            };
            let z0 = ratio(&v0, &i0);
            let f = factors(&i0, true, &z0, &fitted);
            for p in 0..POINTS {
                for phase in [0.0, 0.3] {
                    // A change of 10⁻² at the fitted tone the
                    // sinusoid moves most, relative.
                    let most = fitted
                        .iter()
                        .map(|&k| (KERNEL[p][k][0].norm() / i0.amplitude[k]) as f64)
                        .fold(0f64, f64::max);
                    let hum = Disturbance {
                        hum_hz: NU[p] * layout.tone_hz(0),
                        hum_i: (1e-2 / most) as f32,
                        hum_phase_turns: phase,
                        ..Disturbance::NONE
                    };
                    // The change, each seed's noise drawn alike with the
                    // sinusoid and without, over SEEDS seeds: the ADC's
                    // rounding differs and averages down.
                    let mut moved = vec![0f64; 6];
                    for seed in 0..SEEDS {
                        let (va, ia) = levels_of(&Disturbance::NONE, seed);
                        let (vb, ib) = levels_of(&hum, seed);
                        let (za, zb) = (ratio(&va, &ia), ratio(&vb, &ib));
                        for j in 0..3 {
                            let d = zb[j] - za[j];
                            moved[2 * j] += d.re as f64 / SEEDS as f64;
                            moved[2 * j + 1] += d.im as f64 / SEEDS as f64;
                        }
                    }
                    let s = spread_at(&f, &fitted, p);
                    let col = |q: usize| -> Vec<f64> {
                        s.iter().flat_map(|t| [t[q].re as f64, t[q].im as f64]).collect()
                    };
                    let (off, amplitude) = off_span(&moved, &col(0), &col(1));
                    let size = moved.iter().map(|x| x * x).sum::<f64>().sqrt();
                    // In counts: the sinusoid's own amplitude (where it
                    // is one an input holds, up to 100 counts).
                    let scale = amplitude / hum.hum_i as f64;
                    assert!(
                        hum.hum_i > 100.0 || (scale - 1.0).abs() < 0.03,
                        "{r_scale}× tones {fitted:?} ν {} phase {phase}: amplitude {amplitude:.3} of {}",
                        NU[p],
                        hum.hum_i
                    );
                    worst = worst.max(off / size);
                    assert!(
                        off <= 0.025 * size,
                        "{r_scale}× tones {fitted:?} ν {} phase {phase}: {off:.3e} of {size:.3e} off the spread",
                        NU[p]
                    );
                }
            }
        }
    }
    println!("the worst change is {:.2} % off its spread", worst * 100.0);
}

/// Noise seeds a change is averaged over.
const SEEDS: u64 = 8;

/// How far `x` is from the span of `a` and `b` (least squares), and the
/// size of its coefficients there.
fn off_span(x: &[f64], a: &[f64], b: &[f64]) -> (f64, f64) {
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
    let (aa, ab, bb) = (dot(a, a), dot(a, b), dot(b, b));
    let (xa, xb) = (dot(x, a), dot(x, b));
    let det = aa * bb - ab * ab;
    let (p, q) = ((xa * bb - xb * ab) / det, (xb * aa - xa * ab) / det);
    let off = x
        .iter()
        .zip(a.iter().zip(b))
        .map(|(x, (a, b))| (x - p * a - q * b).powi(2))
        .sum::<f64>()
        .sqrt();
    (off, p.hypot(q))
}
