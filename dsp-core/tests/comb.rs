//! The comb demodulator against an f64 DFT of the same integer samples,
//! across its declared range: any tone of 1..N/2 periods, amplitudes to
//! the i16 rails, any input of a scanned row.

mod common;

use common::rms_max;
use dsp_core::comb::{Comb, CombError};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

const N: usize = 200;
const S: usize = 4;
const Q31: f64 = 2_147_483_648.0;
/// The skin's comb (periods per 200-instant block).
const PERIODS: [u32; 5] = [2, 4, 8, 16, 24];

/// A block whose input `col` holds `tones` ((periods, amplitude, phase))
/// plus `dc` and Gaussian noise of `sigma` counts; the other inputs are
/// random codes.
fn block(
    rng: &mut ChaCha8Rng,
    col: usize,
    tones: &[(u32, f64, f64)],
    dc: f64,
    sigma: f64,
) -> Box<[[i16; S]; N]> {
    let noise = Normal::new(0.0, sigma.max(1e-300)).unwrap();
    let mut rows = Box::new([[0i16; S]; N]);
    for (n, row) in rows.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = if c == col {
                let x: f64 = tones
                    .iter()
                    .map(|&(p, a, ph)| a * (TAU * p as f64 * n as f64 / N as f64 + ph).cos())
                    .sum::<f64>()
                    + dc
                    + if sigma > 0.0 { noise.sample(rng) } else { 0.0 };
                x.round().clamp(-32768.0, 32767.0) as i16
            } else {
                rng.gen()
            };
        }
    }
    rows
}

/// The f64 DFT bin of `p` periods of input `col`, scaled as the comb's
/// phasors (Q31: × 2³¹).
fn dft(rows: &[[i16; S]; N], col: usize, p: u32) -> Complex64 {
    rows.iter()
        .enumerate()
        .map(|(n, r)| r[col] as f64 * Complex64::from_polar(Q31, -TAU * p as f64 * n as f64 / N as f64))
        .sum()
}

#[test]
fn every_tone_matches_the_f64_dft_across_the_range() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut errors = Vec::new();
    for trial in 0..400 {
        // Random combs of 5 distinct tones anywhere in 1..N/2, amplitudes
        // summing to at most the i16 range.
        let mut periods = [0u32; 5];
        for k in 0..5 {
            periods[k] = loop {
                let p = rng.gen_range(1..N as u32 / 2);
                if !periods[..k].contains(&p) {
                    break p;
                }
            };
        }
        let comb = Comb::<N, 5>::new(periods).unwrap();
        let scale = 10f64.powf(rng.gen_range(0.0..3.8)) / 5.0;
        let tones: Vec<_> = periods
            .iter()
            .map(|&p| (p, scale * rng.gen_range(0.1..1.0), rng.gen_range(0.0..TAU)))
            .collect();
        let col = trial % S;
        let dc = rng.gen_range(-500.0..500.0);
        let rows = block(&mut rng, col, &tones, dc, 2.0);
        let t = comb.column(&rows, col);
        assert_eq!(t.n, N as u32);
        for (k, &p) in periods.iter().enumerate() {
            let want = dft(&rows, col, p);
            let got = Complex64::new(t.x[k].re as f64, t.x[k].im as f64);
            // Relative to the input's rms (DC included): the reference's
            // rounding errors weigh every sample of the input.
            let rms = (t.sq as f64 / N as f64).sqrt();
            errors.push((got - want).norm() / (Q31 * N as f64 / 2.0 * rms));
        }
    }
    let (rms, max) = rms_max(&errors);
    println!("comb vs f64 DFT: rms {rms:.2e}, max {max:.2e} of the input's rms");
    assert!(rms < 1e-9 && max < 5e-9, "rms {rms:e} max {max:e}");
}

#[test]
fn tones_do_not_leak_into_each_other_nor_dc_into_any() {
    // One tone at a time at 80 % of the rails, plus a DC offset of 10 000
    // counts: every other bin of the comb holds what the block's codes
    // hold there (their rounding's harmonics, 10⁻⁵ of the tone) within
    // 10⁻⁸ of the tone: the comb adds no leakage of its own.
    let comb = Comb::<N, 5>::new(PERIODS).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut worst = 0f64;
    for (k, &p) in PERIODS.iter().enumerate() {
        let rows = block(&mut rng, 1, &[(p, 16_000.0, 0.7)], 10_000.0, 0.0);
        let t = comb.column(&rows, 1);
        assert!((t.amplitude(k) as f64 / 16_000.0 - 1.0).abs() < 1e-4);
        for (q, &pq) in PERIODS.iter().enumerate() {
            if q != k {
                let want = 2.0 * dft(&rows, 1, pq).norm() / (Q31 * N as f64);
                worst = worst.max((t.amplitude(q) as f64 - want).abs() / 16_000.0);
            }
        }
    }
    println!("worst cross-talk between the comb's tones: {worst:.1e}");
    assert!(worst < 1e-8, "cross-talk {worst:e}");
}

#[test]
fn the_residual_is_what_no_tone_explains() {
    // Noise of σ counts under the five tones: the residual is σ within
    // sampling error (N − 11 degrees of freedom: ±5 % at 3σ), on average
    // over seeds within 1 %.
    let comb = Comb::<N, 5>::new(PERIODS).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for sigma in [1.0, 3.0, 30.0] {
        let mut mean = 0.0;
        let runs = 400;
        for _ in 0..runs {
            let tones: Vec<_> = PERIODS
                .iter()
                .map(|&p| (p, 3000.0, rng.gen_range(0.0..TAU)))
                .collect();
            let rows = block(&mut rng, 3, &tones, 100.0, sigma);
            let r = comb.column(&rows, 3).residual_rms() as f64;
            // Rounding to codes adds 1/12 count².
            let want = (sigma * sigma + 1.0 / 12.0).sqrt() * ((N - 11) as f64 / N as f64).sqrt();
            assert!(
                (r / want - 1.0).abs() < 0.25,
                "σ {sigma}: residual {r} against {want}"
            );
            mean += r / want / runs as f64;
        }
        println!("σ {sigma}: mean residual / σ {mean:.4}");
        assert!((mean - 1.0).abs() < 0.01, "σ {sigma}: mean ratio {mean}");
    }
    // A step the tones cannot explain raises it.
    let tones: Vec<_> = PERIODS.iter().map(|&p| (p, 3000.0, 0.0)).collect();
    let mut rows = block(&mut rng, 0, &tones, 0.0, 1.0);
    for row in rows[N / 2..].iter_mut() {
        row[0] += 400;
    }
    assert!(comb.column(&rows, 0).residual_rms() > 150.0);
}

#[test]
fn the_ratio_of_two_inputs_is_their_f64_ratio() {
    // Input 0 a voltage comb, input 2 a current comb with its own gain and
    // phase per tone: V/I per tone within 10⁻⁶ of the f64 DFTs' ratio
    // whatever the amplitudes (10 to 16 000 counts).
    let comb = Comb::<N, 5>::new(PERIODS).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut errors = Vec::new();
    for _ in 0..300 {
        let a = 10f64.powf(rng.gen_range(1.0..3.5));
        let v: Vec<_> = PERIODS.iter().map(|&p| (p, a, rng.gen_range(0.0..TAU))).collect();
        let i: Vec<_> = PERIODS
            .iter()
            .map(|&p| (p, a * rng.gen_range(0.05..1.0), rng.gen_range(0.0..TAU)))
            .collect();
        let mut rows = block(&mut rng, 0, &v, 0.0, 1.0);
        let cur = block(&mut rng, 2, &i, 0.0, 1.0);
        for (r, c) in rows.iter_mut().zip(cur.iter()) {
            r[2] = c[2];
        }
        let (tv, ti) = (comb.column(&rows, 0), comb.column(&rows, 2));
        for (k, &p) in PERIODS.iter().enumerate() {
            let want = dft(&rows, 0, p) / dft(&rows, 2, p);
            let got = dsp_core::comb::Tones::ratio(&tv, &ti, k).unwrap();
            errors.push((Complex64::new(got.re as f64, got.im as f64) - want).norm() / want.norm());
        }
    }
    let (rms, max) = rms_max(&errors);
    println!("ratio vs f64: rms {rms:.1e}, max {max:.1e}");
    assert!(rms < 2e-7 && max < 1e-6, "rms {rms:e} max {max:e}");
    let zero = Box::new([[0i16; S]; N]);
    assert!(dsp_core::comb::Tones::ratio(&tv0(&comb), &comb.column(&zero, 1), 0).is_none());
}

fn tv0(comb: &Comb<N, 5>) -> dsp_core::comb::Tones<5> {
    comb.column(&Box::new([[100i16; S]; N]), 0)
}

#[test]
fn bad_combs_and_inputs_say_why() {
    assert_eq!(Comb::<N, 2>::new([0, 3]), Err(CombError::Periods(0)));
    assert_eq!(Comb::<N, 2>::new([3, 100]), Err(CombError::Periods(100)));
    assert_eq!(Comb::<N, 3>::new([3, 5, 3]), Err(CombError::Repeated(3)));
    let comb = Comb::<N, 5>::new(PERIODS).unwrap();
    let rows = Box::new([[1000i16; S]; N]);
    let t = comb.column(&rows, S);
    assert_eq!((t.n, t.amplitude(0), t.residual_rms()), (0, 0.0, 0.0));
    assert_eq!(comb.column(&rows, 0).amplitude(7), 0.0);
    // Full-scale codes at every instant cannot overflow a sum.
    let rails = Box::new([[i16::MIN; S]; N]);
    let t = comb.column(&rails, 2);
    assert_eq!((t.sum, t.sq), (-32768 * N as i64, (1i64 << 30) * N as i64));
    assert!(t.residual_rms() < 1e-3);
}

proptest::proptest! {
    /// `Levels::ratio` (the sums converted once) is `Tones::ratio` bit for
    /// bit, over the whole i64 range of the sums and across the scale
    /// `Tones::ratio` applies above 2⁴⁰; the amplitudes are
    /// `Tones::amplitude`'s.
    #[test]
    fn levels_ratio_is_the_sums_ratio_bit_for_bit(
        parts in proptest::array::uniform4(proptest::prelude::any::<i64>()),
        shift in 0u32..63,
        n in 1u32..200,
    ) {
        use dsp_core::comb::{Levels, Tones};
        use dsp_core::Complex;
        let p = parts.map(|x| x >> shift);
        let tones = |a: i64, b: i64| Tones::<2> {
            x: [Complex::new(a, b), Complex::new(b, a)],
            n,
            sum: 0,
            sq: 0,
        };
        let (v, i) = (tones(p[0], p[1]), tones(p[2], p[3]));
        let (lv, li) = (v.levels(), i.levels());
        for k in 0..3 {
            let want = Tones::ratio(&v, &i, k).map(|z| (z.re.to_bits(), z.im.to_bits()));
            let got = Levels::ratio(&lv, &li, k).map(|z| (z.re.to_bits(), z.im.to_bits()));
            proptest::prop_assert_eq!(got, want);
        }
        for k in 0..2 {
            proptest::prop_assert_eq!(lv.amplitude[k].to_bits(), v.amplitude(k).to_bits());
        }
    }
}

proptest::proptest! {
    /// The tones' energy T = Σ (re² + im²)/2⁶¹ (the residual's largest
    /// term) within one unit of the exactly rounded sum for the array's
    /// five tones, two for sixteen, over components of any size below
    /// 2⁵⁶ (its three-multiply path: each exponent drawn alike, the
    /// edges of h = X/2³² among them) and beyond (the exact path, the
    /// same bits).
    #[test]
    fn the_tones_energy_is_within_a_unit_of_the_exact_sum(
        parts in proptest::array::uniform32(proptest::prelude::any::<i64>()),
        shifts in proptest::array::uniform32(0u32..64),
        edge in proptest::array::uniform32(0u8..6),
    ) {
        use dsp_core::comb::{tones_energy, tones_energy_exact};
        use dsp_core::Complex;
        let limit = (1i64 << 56) - 1;
        let v: [i64; 32] = core::array::from_fn(|j| match edge[j] {
            0 => limit,
            1 => -limit - 1,
            2 => limit - (parts[j] >> 40).abs(),
            _ => parts[j] >> shifts[j].max(8),
        });
        let five: [Complex<i64>; 5] = core::array::from_fn(|k| Complex::new(v[2 * k], v[2 * k + 1]));
        let sixteen: [Complex<i64>; 16] = core::array::from_fn(|k| Complex::new(v[2 * k], v[2 * k + 1]));
        let diff = |a: u128, b: u128| a.abs_diff(b);
        proptest::prop_assert!(diff(tones_energy(&five), tones_energy_exact(&five)) <= 1);
        proptest::prop_assert!(diff(tones_energy(&sixteen), tones_energy_exact(&sixteen)) <= 2);
        // A component beyond 2⁵⁶ sends the whole sum down the exact path:
        // the exact sum itself.
        let mut big = five;
        big[0].re = (1 << 57) + (v[0] >> 8);
        proptest::prop_assert_eq!(tones_energy(&big), tones_energy_exact(&big));
    }
}

/// `Comb::column` (the block folded on its mirror) against the plain
/// sums instant by instant (`comb::portable`, `comb::portable_moments`):
/// the same integers, on blocks of odd and even length, short and long,
/// any codes to the rails.
fn folded_is_plain<const B: usize>(rng: &mut ChaCha8Rng, periods: [u32; 3]) {
    let comb = Comb::<B, 3>::new(periods).unwrap();
    // The layout the fold needs: instant B − n is instant n conjugated,
    // and the comb repeats every L instants (L = B/g, g the largest
    // common divisor of B and the periods up to 8), or where that is 1
    // and B is even, over halves: a tone of odd periods negated.
    let g = (1..=8usize)
        .rev()
        .find(|&g| B % g == 0 && periods.iter().all(|&p| p as usize % g == 0))
        .unwrap();
    let g = if g == 1 && B % 2 == 0 { 2 } else { g };
    for (k, &p) in periods.iter().enumerate() {
        let r = comb.reference(k).unwrap();
        let sign = if p as usize % g == 0 { 1 } else { -1 };
        for n in 1..B {
            assert_eq!(r[B - n], [r[n][0], -r[n][1]], "tone {k}, instant {n} of {B}");
            let (l, q) = (B / g, n / (B / g));
            let t = if q % 2 == 1 { sign } else { 1 };
            let [c, s] = r[n % l];
            assert_eq!(r[n], [t * c, t * s], "tone {k}, instant {n} of {B}, {g} repeats");
        }
    }
    let mut rows = Box::new([[0i16; S]; B]);
    for case in 0..40 {
        for row in rows.iter_mut() {
            for v in row.iter_mut() {
                *v = match case {
                    0 => i16::MIN,
                    1 => i16::MAX,
                    _ if case % 2 == 0 => rng.gen(),
                    _ => rng.gen_range(-2048..2048),
                };
            }
        }
        for col in 0..S {
            let t = comb.column(&rows, col);
            assert_eq!(
                [t.sum, t.sq],
                dsp_core::comb::portable_moments(&rows, col),
                "{B}, {case}"
            );
            for (k, x) in t.x.iter().enumerate() {
                let [c, s] = dsp_core::comb::portable(&rows, col, comb.reference(k).unwrap());
                assert_eq!((x.re, x.im), (c, -s), "{B} instants, case {case}, tone {k}");
            }
        }
    }
}

#[test]
fn the_folded_sums_are_the_plain_sums() {
    let mut rng = ChaCha8Rng::seed_from_u64(30);
    folded_is_plain::<8>(&mut rng, [1, 2, 3]);
    folded_is_plain::<9>(&mut rng, [3, 1, 4]);
    folded_is_plain::<14>(&mut rng, [1, 2, 6]);
    folded_is_plain::<25>(&mut rng, [1, 4, 6]);
    folded_is_plain::<100>(&mut rng, [3, 25, 49]);
    folded_is_plain::<101>(&mut rng, [1, 2, 50]);
    folded_is_plain::<200>(&mut rng, [2, 24, 99]);
    // Over halves: the 4 ms block's (1, 8, 16 of its periods), and an
    // odd half (29 instants).
    folded_is_plain::<100>(&mut rng, [1, 8, 16]);
    folded_is_plain::<58>(&mut rng, [1, 6, 28]);
    // Combs that repeat: twice, and 4, 6, 8 times.
    folded_is_plain::<100>(&mut rng, [2, 8, 24]);
    folded_is_plain::<200>(&mut rng, [4, 8, 24]);
    folded_is_plain::<96>(&mut rng, [6, 12, 42]);
    folded_is_plain::<200>(&mut rng, [8, 16, 96]);
    folded_is_plain::<28>(&mut rng, [2, 4, 6]);
}
