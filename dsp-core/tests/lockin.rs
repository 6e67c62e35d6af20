//! The windowed lock-in against an f64 reference: the tone of a clean
//! block, the stop band's rejection of far energy, the guards' bound on
//! near energy, the noise the window passes, and a wrong block length.

use dsp_core::demod::FrontEnd;
use dsp_core::lockin::{Basis, Lockin, Reading, GUARD_BOUND, NUTTALL, STOP_BAND_BINS};
use dsp_core::Complex32;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

const H: usize = 512;
const N: usize = 2 * H;
static BASIS: Basis<H> = Basis::new();
/// The firmware's set: 3, 5, 10, 20 and 30 periods per block.
static LOCKINS: [Lockin<H>; 5] = [
    Lockin::new(3, &BASIS),
    Lockin::new(5, &BASIS),
    Lockin::new(10, &BASIS),
    Lockin::new(20, &BASIS),
    Lockin::new(30, &BASIS),
];

/// A sinusoid of `amp` counts at `bins` cycles per block, phase `phi`.
fn tone(amp: f64, bins: f64, phi: f64) -> impl Fn(usize) -> f64 {
    move |n| amp * (TAU * bins * n as f64 / N as f64 + phi).cos()
}

fn block(v: impl Fn(usize) -> f64, i: impl Fn(usize) -> f64) -> Vec<[i16; 2]> {
    let q = |x: f64| x.round().clamp(-32768.0, 32767.0) as i16;
    (0..N).map(|n| [q(v(n)), q(i(n))]).collect()
}

/// The f64 reference: Σ x·w·e^(−j2π·bin·n/N)·2/Σw, the window exact.
fn reference(x: &[f64], bin: f64) -> (f64, f64) {
    let a = NUTTALL;
    let (mut re, mut im, mut sw) = (0.0, 0.0, 0.0);
    for (n, &x) in x.iter().enumerate() {
        let t = TAU * n as f64 / N as f64;
        let w = a[0] - a[1] * t.cos() + a[2] * (2.0 * t).cos() - a[3] * (3.0 * t).cos();
        re += x * w * (bin * t).cos();
        im -= x * w * (bin * t).sin();
        sw += w;
    }
    (2.0 * re / sw, 2.0 * im / sw)
}

fn err(got: Complex32, want: (f64, f64)) -> f64 {
    (got.re as f64 - want.0).hypot(got.im as f64 - want.1)
}

/// A clean tone on a DC offset (the ADC's bias, up to full scale): the
/// tone's phasor within 2·10⁻⁵ of its amplitude plus 0.01 count of the
/// f64 reference, and the guards below 2·10⁻⁵ of it plus 0.08 count
/// (five σ of the samples' rounding, 0.29 counts rms, through a guard),
/// at every frequency of the set, amplitude and phase. RMS error over all
/// cases below a third of the max bound.
#[test]
fn a_clean_tone_reads_as_the_f64_reference_and_leaves_its_guards_empty() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (mut worst, mut sq, mut count, mut guard) = (0.0f64, 0.0, 0, 0.0f64);
    for l in &LOCKINS {
        for _ in 0..40 {
            let (amp, phi, dc) = (
                rng.gen_range(30.0..2000.0),
                rng.gen_range(0.0..TAU),
                rng.gen_range(0.0..2048.0),
            );
            let k = l.periods() as f64;
            let b = block(
                |n| dc + tone(amp, k, phi)(n),
                |n| dc - tone(amp / 3.0, k, phi + 1.0)(n),
            );
            let r = l.block(&b).unwrap();
            let xs: Vec<f64> = b.iter().map(|p| p[0] as f64 - dc).collect();
            // The reference takes the exact DC out; the rounding of the
            // samples stays in both.
            let e = err(r.v, reference(&xs, k)) / (2e-5 * amp + 0.01);
            worst = worst.max(e);
            sq += e * e;
            count += 1;
            guard = guard.max(r.near()[0] as f64 / (2e-5 * amp + 0.08));
            // V/I = −3·e^(−j): the rounding of a tone of amp/3 counts.
            let z = r.impedance(&FrontEnd::transimpedance(1.0, false)).unwrap();
            let want = Complex32::from_polar(-3.0, -1.0);
            assert!((z - want).norm() < 1.0 / amp as f32, "{z} for {want}");
        }
    }
    let rms = (sq / count as f64).sqrt();
    println!("clean tone: error/bound max {worst:.3}, rms {rms:.3}; guards/bound ≤ {guard:.3}");
    assert!(worst <= 1.0 && rms <= 1.0 / 3.0, "{worst} {rms}");
    assert!(guard <= 1.0, "{guard}");
}

/// Far energy: an interferer of up to three times the tone, anywhere from
/// the stop band's edge (4.5 bins from the tone) to Nyquist. The lock-in
/// reads its block as the f64 reference does, within 2·10⁻⁵ of all it
/// holds; the f64 window passes less than 2.5·10⁻⁵ (−92 dB) of the
/// interferer into the tone, and less than 3·10⁻⁴ into the guards from
/// 5.5 bins on (they see it up to there; 0.06 count allowed for the
/// rounding of the samples).
#[test]
fn the_stop_band_rejects_far_energy() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let (mut worst_read, mut worst_leak, mut worst_guard) = (0.0f64, 0.0f64, 0.0f64);
    for l in &LOCKINS {
        let k = l.periods() as f64;
        for _ in 0..200 {
            let off = rng.gen_range(STOP_BAND_BINS as f64..(N as f64 / 2.0 - k));
            let bins = if rng.gen_bool(0.5) && off < k {
                k - off
            } else {
                k + off
            };
            let (amp, a_i) = (500.0, rng.gen_range(10.0..1500.0));
            let b = block(tone(amp, k, 0.3), |n| {
                tone(amp, k, 0.3)(n) + tone(a_i, bins, 1.1)(n)
            });
            let r = l.block(&b).unwrap();
            let xs: Vec<f64> = b.iter().map(|p| p[1] as f64).collect();
            let e = err(r.i, reference(&xs, k)) / (2e-5 * (amp + a_i));
            worst_read = worst_read.max(e);
            let alone: Vec<f64> = (0..N).map(tone(a_i, bins, 1.1)).collect();
            let (re, im) = reference(&alone, k);
            worst_leak = worst_leak.max(re.hypot(im) / a_i);
            if off >= 5.5 {
                let g = r.near()[1] as f64;
                worst_guard = worst_guard.max((g - 0.06).max(0.0) / a_i);
            }
        }
    }
    println!("stop band: read within {worst_read:.3} of its bound; leak ≤ {worst_leak:.2e}, guards ≤ {worst_guard:.2e} of the interferer");
    assert!(worst_read <= 1.0, "{worst_read}");
    assert!(worst_leak < 2.5e-5, "{worst_leak}");
    assert!(worst_guard < 3e-4, "{worst_guard}");
}

/// Near energy: an interferer half a bin to the stop band from the tone
/// moves the tone by at most GUARD_BOUND times the larger guard it leaves
/// (plus 0.1 count: five σ of the samples' rounding through the window).
#[test]
fn the_guards_bound_what_near_energy_does_to_the_tone() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let l = &LOCKINS[rng.gen_range(0..LOCKINS.len())];
        let k = l.periods() as f64;
        let off = rng.gen_range(0.5..STOP_BAND_BINS as f64) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let (amp, a_i) = (rng.gen_range(50.0..1500.0), rng.gen_range(0.5..500.0));
        let phi = rng.gen_range(0.0..TAU);
        let clean = block(tone(amp, k, 0.3), tone(amp, k, 0.3));
        let b = block(tone(amp, k, 0.3), |n| {
            tone(amp, k, 0.3)(n) + tone(a_i, k + off, phi)(n)
        });
        let (r0, r) = (l.block(&clean).unwrap(), l.block(&b).unwrap());
        let moved = (r.i - r0.i).norm() as f64;
        let bound = GUARD_BOUND as f64 * r.near()[1] as f64 + 0.1;
        worst = worst.max(moved / bound);
    }
    println!("near energy: moved/bound ≤ {worst:.3}");
    assert!(worst <= 1.0, "{worst}");
}

/// White noise: each component of the tone varies by σ·noise_gain and of
/// a guard by σ·guard_noise_gain (within 8 %, 3000 blocks): 0.063·σ and
/// 0.037·σ at N = 1024.
#[test]
fn the_noise_the_window_passes_is_noise_gain() {
    let l = &LOCKINS[2];
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let sigma = 20.0;
    let noise = Normal::new(0.0, sigma).unwrap();
    let (mut tone_sq, mut guard_sq, mut gain, mut ggain) = (0.0f64, 0.0f64, 0.0f32, 0.0f32);
    let trials = 3000;
    for _ in 0..trials {
        let b: Vec<[i16; 2]> = (0..N)
            .map(|n| {
                let x = 2048.0 + tone(800.0, 10.0, 0.2)(n);
                [
                    (x + noise.sample(&mut rng)).round() as i16,
                    (x + noise.sample(&mut rng)).round() as i16,
                ]
            })
            .collect();
        let r: Reading = l.block(&b).unwrap();
        let t0 = Complex32::from_polar(800.0, 0.2);
        tone_sq += (r.v - t0).norm_sqr() as f64 / 2.0;
        guard_sq += (r.guards[0][0].norm_sqr() + r.guards[0][1].norm_sqr()) as f64 / 4.0;
        (gain, ggain) = (r.noise_gain, r.guard_noise_gain);
    }
    let s2 = sigma * sigma + 1.0 / 12.0;
    let (t, g) = (
        (tone_sq / trials as f64 / s2).sqrt(),
        (guard_sq / trials as f64 / s2).sqrt(),
    );
    println!("noise per component: tone {t:.4}·σ ({gain:.4}), guards {g:.4}·σ ({ggain:.4})");
    assert!((t / gain as f64 - 1.0).abs() < 0.08, "{t} {gain}");
    assert!((g / ggain as f64 - 1.0).abs() < 0.08, "{g} {ggain}");
    assert!((gain - 0.0628).abs() < 1e-3 && (ggain - 0.0370).abs() < 1e-3);
}

/// A step or a spike inside the block reaches the guards: a step of 5 % of
/// the tone moves the tone by no more than GUARD_BOUND times its guards.
#[test]
fn steps_and_spikes_show_in_the_guards() {
    let l = &LOCKINS[1];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..300 {
        let at = rng.gen_range(0..N);
        let h = rng.gen_range(-100.0..100.0);
        let spike = rng.gen_bool(0.5);
        let clean = block(tone(1000.0, 5.0, 0.4), tone(1000.0, 5.0, 0.4));
        let b = block(tone(1000.0, 5.0, 0.4), |n| {
            let d = if spike {
                if n == at {
                    20.0 * h
                } else {
                    0.0
                }
            } else if n >= at {
                h
            } else {
                0.0
            };
            tone(1000.0, 5.0, 0.4)(n) + d
        });
        let (r0, r) = (l.block(&clean).unwrap(), l.block(&b).unwrap());
        let moved = (r.i - r0.i).norm();
        assert!(
            moved <= GUARD_BOUND * r.near()[1] + 0.1,
            "{spike} at {at} of {h}: {moved} vs {:?}",
            r.near()
        );
    }
}

#[test]
fn a_block_of_the_wrong_length_is_refused() {
    let b = vec![[0i16; 2]; N - 1];
    let e = LOCKINS[0].block(&b).unwrap_err();
    assert_eq!((e.got, e.expected), (N - 1, N));
}

/// The tone alone (`Lockin::tone`) is the tone of the whole reading, bit
/// for bit, on any block (noise, a DC offset, a second tone five bins
/// away, full-scale extremes), at every frequency of the set; and a
/// second tone five bins or more away leaves a tone within the clean
/// bound of the f64 reference: two tones share one block.
#[test]
fn the_tone_alone_is_the_readings_tone_and_a_second_tone_leaves_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 3.0).unwrap();
    let pairs = [(3usize, 10usize), (5, 10), (10, 5), (20, 5), (30, 10)];
    let mut worst = 0.0f64;
    for &(k, other) in &pairs {
        let l = LOCKINS.iter().find(|l| l.periods() as usize == k).unwrap();
        for case in 0..60 {
            let (amp, amp2, phi, dc) = (
                rng.gen_range(30.0..1200.0),
                rng.gen_range(0.0..800.0),
                rng.gen_range(0.0..TAU),
                rng.gen_range(-2048.0..2048.0),
            );
            let mut b = block(
                |n| dc + tone(amp, k as f64, phi)(n) + tone(amp2, other as f64, 0.3)(n),
                |n| -dc - tone(amp / 2.0, k as f64, phi + 1.0)(n) + tone(amp2 / 3.0, other as f64, 2.0)(n),
            );
            if case % 3 == 0 {
                for p in b.iter_mut() {
                    p[0] = p[0].saturating_add(noise.sample(&mut rng) as i16);
                    p[1] = p[1].saturating_add(noise.sample(&mut rng) as i16);
                }
            }
            if case == 59 {
                b.iter_mut().enumerate().for_each(|(n, p)| {
                    *p = if n % 2 == 0 {
                        [i16::MAX, i16::MIN]
                    } else {
                        [i16::MIN, i16::MAX]
                    }
                });
            }
            let r = l.block(&b).unwrap();
            let t = l.tone(&b).unwrap();
            assert_eq!(
                (t.v, t.i, t.noise_gain, t.n),
                (r.v, r.i, r.noise_gain, r.n),
                "{k}"
            );
            assert_eq!(t, r.phasors());
            if case % 3 != 0 && case != 59 {
                let xs: Vec<f64> = b
                    .iter()
                    .enumerate()
                    .map(|(n, p)| p[0] as f64 - dc - tone(amp2, other as f64, 0.3)(n))
                    .collect();
                worst = worst.max(err(t.v, reference(&xs, k as f64)) / (2e-5 * amp + 0.01));
            }
        }
    }
    assert!(worst <= 1.0, "worst {worst} of the bound");
    assert_eq!(
        LOCKINS[0].tone(&[[0; 2]; 10]).unwrap_err(),
        dsp_core::lockin::BlockLength { got: 10, expected: N }
    );
}

/// A weak tone on a bias at the rails, at the frequencies whose mean is
/// solved for beside the tone (3 and 4 periods; from 5 on the window
/// has no DC at the tone's bin, and the stop band's test bounds a bias
/// as any far energy): a 0.5 to 10-count tone on a bias of up to
/// ±32 000 counts, three phases, reads as the f64 reference of the
/// samples less their mean within 2·10⁻⁵ of the tone plus 10⁻³ counts
/// (the samples' own rounding is 0.29 counts rms). For 3 periods the
/// bias's share of the sum is 10³ times a 0.5-count tone's, and the solve
/// runs in f32: 0.21 of the bound (0.12 in f64).
#[test]
fn a_weak_tone_on_a_bias_at_the_rails_reads_as_the_f64_reference() {
    let mut worst = 0.0f64;
    static FOUR: Lockin<H> = Lockin::new(4, &BASIS);
    for l in LOCKINS.iter().filter(|l| l.periods() < 5).chain([&FOUR]) {
        let k = l.periods() as f64;
        for dc in [-32_000.0, -20_000.0, 1_000.0, 30_000.0, 32_000.0] {
            for amp in [0.5, 2.0, 10.0] {
                for phi in [0.0, 1.0, 2.0] {
                    let b = block(
                        |n| dc + tone(amp, k, phi)(n),
                        |n| -dc + tone(amp, k, phi + 2.0)(n),
                    );
                    let r = l.block(&b).unwrap();
                    for (c, got) in [(0, r.v), (1, r.i)] {
                        let x: Vec<f64> = b.iter().map(|p| p[c] as f64).collect();
                        let mean = x.iter().sum::<f64>() / N as f64;
                        let x: Vec<f64> = x.iter().map(|x| x - mean).collect();
                        let e = err(got, reference(&x, k)) / (2e-5 * amp + 1e-3);
                        worst = worst.max(e);
                    }
                }
            }
        }
    }
    println!("weak tone on a rail's bias: error/bound max {worst:.3}");
    assert!(worst <= 1.0, "worst {worst} of the bound");
}
