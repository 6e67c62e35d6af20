//! The I/Q demodulator: efficiency against the Cramér–Rao bound, rejection
//! of DC and harmonics, impedance recovery, and chunking.

use dsp_core::demod::{residual_rms_tones, DemodState, Demodulator, FrontEnd};
use dsp_core::{Complex32, Oscillator};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

const FS: f32 = 200e3;
const LOG2N: u32 = 11;
const N: usize = 1 << LOG2N;

fn osc(f: f32) -> Oscillator {
    Oscillator::coherent(f, FS, LOG2N).unwrap()
}

/// Phase of sample n of the excitation, radians.
fn theta(o: &Oscillator, n: usize) -> f64 {
    (o.ftw() as f64 * n as f64 / 2f64.powi(32)) * TAU
}

fn q16(x: f64) -> i16 {
    x.round().clamp(-32768.0, 32767.0) as i16
}

/// Monte-Carlo: amplitude and phase variances within 10 % of the CRB,
/// var(A) = 2σ²/N and var(φ) = 2σ²/(A²N) for a sinusoid of known
/// frequency in white Gaussian noise.
#[test]
fn variance_meets_cramer_rao_bound() {
    let o = osc(6000.0);
    let dm = Demodulator::<N>::new(&o);
    let (a, phi, sigma) = (1000.0f64, 0.7f64, 40.0f64);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, sigma).unwrap();
    let trials = 4000;
    let (mut amps, mut phases) = (Vec::with_capacity(trials), Vec::with_capacity(trials));
    let mut buf = vec![[0i16; 2]; N];
    for _ in 0..trials {
        for (n, s) in buf.iter_mut().enumerate() {
            let x = a * (theta(&o, n) + phi).cos();
            *s = [q16(x + noise.sample(&mut rng)), q16(x + noise.sample(&mut rng))];
        }
        let p = dm.block(buf.as_slice().try_into().unwrap());
        amps.push(p.v_amplitude() as f64);
        phases.push((p.v.im as f64).atan2(p.v.re as f64));
    }
    let var = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64
    };
    // σ² includes the rounding of the ADC model (1/12 LSB²).
    let s2 = sigma * sigma + 1.0 / 12.0;
    let crb_a = 2.0 * s2 / N as f64;
    let crb_p = 2.0 * s2 / (a * a * N as f64);
    let (ra, rp) = (var(&amps) / crb_a, var(&phases) / crb_p);
    println!("var/CRB: amplitude {ra:.3}, phase {rp:.3}");
    assert!((ra - 1.0).abs() < 0.10, "amplitude var/CRB = {ra}");
    assert!((rp - 1.0).abs() < 0.10, "phase var/CRB = {rp}");
    // and unbiased
    let ma = amps.iter().sum::<f64>() / trials as f64;
    assert!((ma / a - 1.0).abs() < 1e-3, "mean amplitude {ma}");
}

#[test]
fn rejects_dc_and_harmonics() {
    for f in [500.0f32, 2000.0, 6000.0, 20000.0] {
        let o = osc(f);
        let dm = Demodulator::<N>::new(&o);
        let clean: Vec<[i16; 2]> = (0..N)
            .map(|n| {
                let t = theta(&o, n);
                [q16(8000.0 * t.cos()), q16(3000.0 * (t - 1.0).cos())]
            })
            .collect();
        let dirty: Vec<[i16; 2]> = (0..N)
            .map(|n| {
                let t = theta(&o, n);
                let h: f64 = (2..=7).map(|k| 1500.0 * (k as f64 * t + k as f64).cos()).sum();
                [
                    q16(8000.0 * t.cos() + 4000.0 + h),
                    q16(3000.0 * (t - 1.0).cos() - 7000.0 + h),
                ]
            })
            .collect();
        let (a, b) = (
            dm.block(clean.as_slice().try_into().unwrap()),
            dm.block(dirty.as_slice().try_into().unwrap()),
        );
        let rel = |x: num_complex::Complex<i64>, y: num_complex::Complex<i64>| {
            let d = ((x.re - y.re) as f64).hypot((x.im - y.im) as f64);
            d / (x.re as f64).hypot(x.im as f64)
        };
        // Only the rounding of the 16-bit samples differs.
        assert!(rel(a.v, b.v) < 2e-4, "{f}: {}", rel(a.v, b.v));
        assert!(rel(a.i, b.i) < 5e-4, "{f}: {}", rel(a.i, b.i));
    }
}

#[test]
fn recovers_impedance_through_front_end() {
    // Z = 150 kΩ − j 600 kΩ, inverting transimpedance 100 kΩ.
    let z = Complex32::new(150e3, -600e3);
    let fe = FrontEnd::transimpedance(100e3, true);
    let o = osc(2000.0);
    let dm = Demodulator::<N>::new(&o);
    let (va, zm, zarg) = (10000.0f64, (z.norm() as f64), (z.im as f64).atan2(z.re as f64));
    let ia = va / zm * 100e3;
    let pairs: Vec<[i16; 2]> = (0..N)
        .map(|n| {
            let t = theta(&o, n);
            [q16(va * (t + 0.3).cos()), q16(-ia * (t + 0.3 - zarg).cos())]
        })
        .collect();
    let got = dm
        .block(pairs.as_slice().try_into().unwrap())
        .impedance(&fe)
        .unwrap();
    assert!((got - z).norm() / z.norm() < 2e-4, "{got}");
    // No current at all: open sensor.
    let open: Vec<[i16; 2]> = pairs.iter().map(|p| [p[0], 0]).collect();
    assert_eq!(dm.block(open.as_slice().try_into().unwrap()).impedance(&fe), None);
}

#[test]
fn chunks_equal_one_block() {
    let o = osc(3000.0);
    let dm = Demodulator::<N>::new(&o);
    let pairs: Vec<[i16; 2]> = (0..N)
        .map(|n| {
            [
                (n as i32 * 37 % 4001 - 2000) as i16,
                (n as i32 * 91 % 3001 - 1500) as i16,
            ]
        })
        .collect();
    let whole = dm.block(pairs.as_slice().try_into().unwrap());
    let mut st = DemodState::default();
    for c in pairs.chunks(100) {
        assert_eq!(dm.update(&mut st, c), c.len());
    }
    // A full block takes no more pairs.
    assert_eq!(dm.update(&mut st, &pairs[..10]), 0);
    assert_eq!(dm.finish(&mut st), whole);
    assert_eq!(whole.n, N as u32);
    // finish resets: the next block starts afresh.
    let mut longer = pairs.clone();
    longer.extend_from_slice(&pairs[..5]);
    assert_eq!(dm.update(&mut st, &longer), N);
    assert_eq!(dm.finish(&mut st), whole);
}

/// Full-scale samples over the longest block cannot overflow the sums.
#[test]
fn full_scale_does_not_overflow() {
    const BIG: usize = 1 << 16;
    let o = Oscillator::coherent(1000.0, FS, 16).unwrap();
    let dm = Box::new(Demodulator::<BIG>::new(&o));
    let pairs = vec![[i16::MIN, i16::MIN]; BIG];
    let p = dm.block(pairs.as_slice().try_into().unwrap());
    // DC is rejected exactly over whole periods.
    assert!(p.v.re.abs() < 1 << 16 && p.v.im.abs() < 1 << 16, "{:?}", p.v);
}

/// The residual rms (what the tone does not explain) against an f64
/// least-squares fit of mean + cos + sin with exact references, over
/// tones of 0..2000 counts, noise of 0.5..50 counts and hum-like ramps and
/// parabolas up to 2000 counts, at 3..30 periods per block: within 1 % +
/// 0.05 counts (max), 0.2 % + 0.01 counts (RMS), the gap being the Q15
/// reference's rounding.
#[test]
fn residual_rms_matches_an_f64_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut worst, mut ss, mut cnt) = (0f64, 0f64, 0u32);
    for trial in 0..300 {
        let k = [3u32, 5, 10, 20, 30][trial % 5];
        let o = Oscillator::from_ftw(k << (32 - LOG2N));
        let dm = Demodulator::<N>::new(&o);
        let a = rand::Rng::gen_range(&mut rng, 0.0..2000.0);
        let sigma = rand::Rng::gen_range(&mut rng, 0.5..50.0);
        let (ramp, curve) = (
            rand::Rng::gen_range(&mut rng, -2000.0..2000.0),
            rand::Rng::gen_range(&mut rng, -2000.0..2000.0),
        );
        let noise = Normal::new(0.0, sigma).unwrap();
        let mut buf = vec![[0i16; 2]; N];
        for (n, p) in buf.iter_mut().enumerate() {
            let u = n as f64 / N as f64;
            let x = a * theta(&o, n).cos() + ramp * u + curve * u * u + noise.sample(&mut rng);
            *p = [q16(x), q16(0.5 * x)];
        }
        let ph = dm.block(buf.as_slice().try_into().unwrap());
        let got = ph.residual_rms();
        for (ch, g) in got.iter().enumerate() {
            let xs: Vec<f64> = buf.iter().map(|p| p[ch] as f64).collect();
            let want = ls_residual(&xs, &o);
            let e = (*g as f64 - want).abs();
            let bound = 0.01 * want + 0.05;
            assert!(e <= bound, "k={k} ch={ch}: {g} vs {want}");
            worst = worst.max(e / bound);
            ss += (e / (0.002 * want + 0.01)).powi(2);
            cnt += 1;
        }
    }
    let rms = (ss / cnt as f64).sqrt();
    println!("residual rms: worst {worst:.2} of the max bound, rms {rms:.2} of the rms bound");
    assert!(rms <= 1.0, "{rms}");
}

/// rms of x after an exact least-squares fit of mean, cos θ and sin θ
/// (orthogonal over whole periods).
fn ls_residual(xs: &[f64], o: &Oscillator) -> f64 {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let (mut c, mut s) = (0.0, 0.0);
    for (k, x) in xs.iter().enumerate() {
        c += x * theta(o, k).cos();
        s += x * theta(o, k).sin();
    }
    let (a, b) = (2.0 * c / n, 2.0 * s / n);
    let e: f64 = xs
        .iter()
        .enumerate()
        .map(|(k, x)| (x - mean - a * theta(o, k).cos() - b * theta(o, k).sin()).powi(2))
        .sum();
    (e / n).sqrt()
}

/// Two tones in one block, each demodulated by its own reference: each
/// phasor is its tone's alone (the other, a whole number of periods, sums
/// to zero against it), and the residual after both is an f64 fit of mean
/// and both tones: the residual energies within 2 % plus 4·10⁻⁶ of the
/// tones' (the Q15 references' rounding misses that part of a tone's
/// energy: 0.1 counts rms under two tones of 1000 counts).
#[test]
fn two_tones_in_one_block_are_separate_and_their_residual_is_the_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut worst = 0f64;
    for trial in 0..100 {
        let (k1, k2) = [(3u32, 12u32), (5, 20), (10, 30), (4, 28), (8, 9)][trial % 5];
        let (o1, o2) = (
            Oscillator::from_ftw(k1 << (32 - LOG2N)),
            Oscillator::from_ftw(k2 << (32 - LOG2N)),
        );
        let (d1, d2) = (Demodulator::<N>::new(&o1), Demodulator::<N>::new(&o2));
        let (a1, a2) = (
            rand::Rng::gen_range(&mut rng, 100.0..1500.0),
            rand::Rng::gen_range(&mut rng, 100.0..1500.0),
        );
        let (p1, p2) = (
            rand::Rng::gen_range(&mut rng, 0.0..TAU),
            rand::Rng::gen_range(&mut rng, 0.0..TAU),
        );
        let sigma = rand::Rng::gen_range(&mut rng, 0.5..20.0);
        let noise = Normal::new(0.0, sigma).unwrap();
        let mut buf = vec![[0i16; 2]; N];
        for (n, p) in buf.iter_mut().enumerate() {
            let x =
                a1 * (theta(&o1, n) + p1).cos() + a2 * (theta(&o2, n) + p2).cos() + noise.sample(&mut rng);
            *p = [q16(x), q16(0.7 * x)];
        }
        let block: &[[i16; 2]; N] = buf.as_slice().try_into().unwrap();
        let (t1, t2) = (d1.block(block), d2.block(block));
        // Each tone's amplitude and phase as if alone (noise: 2σ/√N).
        for (t, a, p) in [(t1, a1, p1), (t2, a2, p2)] {
            let tol = 4.0 * sigma * (2.0 / N as f64).sqrt() + 0.5;
            assert!(
                (t.v_amplitude() as f64 - a).abs() < tol,
                "{trial}: {} vs {a}",
                t.v_amplitude()
            );
            let phase = (t.v.im as f64).atan2(t.v.re as f64);
            let dp = ((phase - p).rem_euclid(TAU) + 0.5 * TAU).rem_euclid(TAU) - 0.5 * TAU;
            assert!(dp.abs() < tol / a + 1e-3, "{trial}: phase {phase} vs {p}");
        }
        let got = residual_rms_tones(&[t1, t2]);
        for (ch, g) in got.iter().enumerate() {
            let xs: Vec<f64> = buf.iter().map(|p| p[ch] as f64).collect();
            let want = ls_residual2(&xs, &o1, &o2);
            let tones = (a1 * a1 + a2 * a2) * if ch == 0 { 1.0 } else { 0.49 };
            let bound = 0.02 * want * want + 4e-6 * tones;
            let e = ((*g as f64).powi(2) - want * want).abs();
            assert!(e <= bound, "{trial} ch {ch}: {g} vs {want}");
            worst = worst.max(e / bound);
        }
        // One tone alone leaves the other in the residual.
        assert!(t1.residual_rms()[0] as f64 > 0.5 * a2);
    }
    println!("two-tone residual: worst {worst:.2} of the bound");
}

/// rms of x after an exact least-squares fit of the mean and two tones
/// (orthogonal over whole periods).
fn ls_residual2(xs: &[f64], o1: &Oscillator, o2: &Oscillator) -> f64 {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let fit = |o: &Oscillator| {
        let (mut c, mut s) = (0.0, 0.0);
        for (k, x) in xs.iter().enumerate() {
            c += x * theta(o, k).cos();
            s += x * theta(o, k).sin();
        }
        (2.0 * c / n, 2.0 * s / n)
    };
    let ((a1, b1), (a2, b2)) = (fit(o1), fit(o2));
    let e: f64 = xs
        .iter()
        .enumerate()
        .map(|(k, x)| {
            let m = mean
                + a1 * theta(o1, k).cos()
                + b1 * theta(o1, k).sin()
                + a2 * theta(o2, k).cos()
                + b2 * theta(o2, k).sin();
            (x - m).powi(2)
        })
        .sum();
    (e / n).sqrt()
}
