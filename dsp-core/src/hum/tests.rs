//! The hum canceller against an f64 reference that computes the same
//! fit from the rows directly (exact cosines, the hum's basis rounded to
//! the device's 15 bits): over its declared
//! range (hum 0 to 8,000 counts, any phase, 50 and 60 Hz, both of the
//! array's blocks, noise 1 to 10 counts), the tones it leaves and its
//! residual.

use super::*;
use crate::comb::Comb;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const RATE_HZ: u32 = 25_000;
const TAU: f64 = core::f64::consts::TAU;

/// The comb's tones as the array lays them out: amplitude (counts) and
/// phase (rad) of each.
pub(crate) const LEVELS: [(f64, f64); 5] = [
    (3000.0, 0.3),
    (2000.0, 1.1),
    (1500.0, -2.0),
    (900.0, 0.7),
    (500.0, 2.9),
];

/// One block of input: DC, the tones, a hum and noise, rounded to codes.
struct Block<const N: usize> {
    rows: [[i16; 1]; N],
}

#[allow(clippy::too_many_arguments)]
fn block<const N: usize>(
    periods: &[u32; 5],
    b: usize,
    mains_hz: f64,
    hum: f64,
    hum_phase: f64,
    sigma: f64,
    rng: &mut ChaCha8Rng,
) -> Block<N> {
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut rows = [[0i16; 1]; N];
    for (n, row) in rows.iter_mut().enumerate() {
        let t = (b * N + n) as f64 / RATE_HZ as f64;
        let mut x = 120.0 + hum * (TAU * mains_hz * t + hum_phase).cos();
        for (&p, &(a, ph)) in periods.iter().zip(&LEVELS) {
            x += a * (TAU * p as f64 * n as f64 / N as f64 + ph).cos();
        }
        x += noise.sample(rng);
        row[0] = x.round().clamp(-32768.0, 32767.0) as i16;
    }
    Block { rows }
}

/// The same fit in f64 from the rows, with exact cosines: (p, the
/// corrected tone sums, the corrected residual rms) where it applies.
struct Reference<const N: usize> {
    periods: [u32; 5],
    mains_hz: f64,
    m: [[f64; 2]; 2],
    r: [f64; 2],
    energy: f64,
    weight: f64,
}

type Corrected = ([f64; 2], [(f64, f64); 5], f64);

impl<const N: usize> Reference<N> {
    fn new(periods: [u32; 5], mains_hz: f64) -> Self {
        Self {
            periods,
            mains_hz,
            m: [[0.0; 2]; 2],
            r: [0.0; 2],
            energy: 0.0,
            weight: 0.0,
        }
    }

    /// p = M⁻¹·r.
    fn estimate(&self) -> [f64; 2] {
        let m = self.m;
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        [
            (m[1][1] * self.r[0] - m[0][1] * self.r[1]) / det,
            (-m[1][0] * self.r[0] + m[0][0] * self.r[1]) / det,
        ]
    }

    /// x less its mean and tones.
    fn perp(&self, x: &[f64; N]) -> [f64; N] {
        let nf = N as f64;
        let mean = x.iter().sum::<f64>() / nf;
        let mut out = x.map(|v| v - mean);
        for &p in &self.periods {
            let th = |n: usize| TAU * p as f64 * n as f64 / nf;
            let c: f64 = (0..N).map(|n| x[n] * th(n).cos()).sum::<f64>() * 2.0 / nf;
            let s: f64 = (0..N).map(|n| x[n] * th(n).sin()).sum::<f64>() * 2.0 / nf;
            for (n, o) in out.iter_mut().enumerate() {
                *o -= c * th(n).cos() + s * th(n).sin();
            }
        }
        out
    }

    /// The hum's basis: a sinusoid in the 15 bits the device's words
    /// keep (rounded exactly so, from exact cosines).
    fn basis(&self, j: usize) -> [f64; N] {
        core::array::from_fn(|n| {
            let phi = TAU * self.mains_hz * n as f64 / RATE_HZ as f64;
            let v = if j == 0 { phi.cos() } else { phi.sin() };
            (v * 32768.0).round().clamp(-32767.0, 32767.0) / 32768.0
        })
    }

    fn step(&mut self, rows: &[[i16; 1]; N], clean: f64, restart: bool) -> Option<Corrected> {
        let x: [f64; N] = core::array::from_fn(|n| rows[n][0] as f64);
        let b = [self.basis(0), self.basis(1)];
        let pb = [self.perp(&b[0]), self.perp(&b[1])];
        let px = self.perp(&x);
        let dot = |a: &[f64; N], c: &[f64; N]| a.iter().zip(c).map(|(a, c)| a * c).sum::<f64>();
        let u = [dot(&px, &b[0]), dot(&px, &b[1])];
        let q = [
            [dot(&pb[0], &pb[0]), dot(&pb[0], &pb[1])],
            [dot(&pb[1], &pb[0]), dot(&pb[1], &pb[1])],
        ];
        let psi = TAU * self.mains_hz * N as f64 / RATE_HZ as f64;
        let (c, s) = (psi.cos(), psi.sin());
        let l = 1.0 - (N as f64 / RATE_HZ as f64) / TAU_S as f64;
        let t = [[c, s], [-s, c]];
        let rot = |a: &[[f64; 2]; 2]| {
            let ta: [[f64; 2]; 2] =
                core::array::from_fn(|i| core::array::from_fn(|j| t[i][0] * a[0][j] + t[i][1] * a[1][j]));
            let out: [[f64; 2]; 2] =
                core::array::from_fn(|i| core::array::from_fn(|j| ta[i][0] * t[j][0] + ta[i][1] * t[j][1]));
            out
        };
        // Where the device's window started again (its hum changed: a
        // decision at a threshold, taken from it), so does this one.
        if restart {
            (self.m, self.r, self.energy, self.weight) = ([[0.0; 2]; 2], [0.0; 2], 0.0, 0.0);
        }
        let m = rot(&self.m);
        self.m = core::array::from_fn(|i| core::array::from_fn(|j| l * m[i][j] + q[i][j]));
        let r = self.r;
        self.r = [
            l * (c * r[0] + s * r[1]) + u[0],
            l * (-s * r[0] + c * r[1]) + u[1],
        ];
        self.energy = l * self.energy + dot(&px, &px);
        self.weight = l * self.weight + 1.0;
        let p = self.estimate();
        let explained = p[0] * self.r[0] + p[1] * self.r[1];
        let noise = (self.energy - explained) / (self.weight * (N - 11) as f64 - 2.0);
        let full = self.weight * (1.0 - l) >= 0.5;
        if !(full && explained > SIGNIFICANT as f64 * noise && noise <= clean * clean) {
            return None;
        }
        let y: [f64; N] = core::array::from_fn(|n| x[n] - p[0] * b[0][n] - p[1] * b[1][n]);
        let tones = self.periods.map(|p| {
            let th = |n: usize| TAU * p as f64 * n as f64 / N as f64;
            let c: f64 = (0..N).map(|n| y[n] * th(n).cos()).sum();
            let s: f64 = (0..N).map(|n| y[n] * th(n).sin()).sum();
            (c, -s)
        });
        let py = self.perp(&y);
        let left = dot(&py, &py);
        (left < dot(&px, &px)).then_some((p, tones, (left / N as f64).sqrt()))
    }
}

/// Worst and rms errors over a run: of each corrected tone sum, relative
/// to the tone's noise σ·√(N/2); of the residual, relative; and how many
/// blocks both took a hum out of.
#[derive(Debug, Default)]
struct Errors {
    tone: (f64, f64),
    residual: (f64, f64),
    applied: usize,
    only_one: usize,
}

#[allow(clippy::too_many_arguments)]
fn run<const N: usize>(
    periods: [u32; 5],
    mains_hz: u32,
    hum: f64,
    phase: f64,
    sigma: f64,
    blocks: usize,
    seed: u64,
    errors: &mut Errors,
) {
    let comb = Comb::<N, 5>::new(periods).unwrap();
    let mains = Mains::new(mains_hz, RATE_HZ, &comb);
    let mut state = HumState::EMPTY;
    let mut reference = Reference::<N>::new(periods, mains_hz as f64);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let clean = 6.4;
    for b in 0..blocks {
        let blk = block::<N>(&periods, b, mains_hz as f64, hum, phase, sigma, &mut rng);
        let tones = comb.column(&blk.rows, 0);
        let mut levels = tones.levels();
        let before = state.restarts;
        let ours = mains
            .fit()
            .cancel(&mut state, mains.sums(&blk.rows, 0), &tones, &mut levels, clean);
        let theirs = reference.step(&blk.rows, clean as f64, state.restarts != before);

        match (ours, theirs) {
            (Some(_), Some((_, x, res))) => {
                errors.applied += 1;
                let tone_sigma = sigma * (N as f64 / 2.0).sqrt();
                for (ph, (re, im)) in levels.phasor.iter().zip(x) {
                    let d = ((ph.re as f64 / Q31 - re).powi(2) + (ph.im as f64 / Q31 - im).powi(2)).sqrt()
                        / tone_sigma;
                    errors.tone.0 = errors.tone.0.max(d);
                    errors.tone.1 += d * d;
                }
                let d = levels.residual as f64 / res - 1.0;
                errors.residual.0 = errors.residual.0.max(d.abs());
                errors.residual.1 += d * d;
            }
            (None, None) => {}
            _ => errors.only_one += 1,
        }
    }
}

fn sweep<const N: usize>(periods: [u32; 5], seed: u64) -> Errors {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut errors = Errors::default();
    for case in 0..24 {
        let hum = if case == 0 {
            0.0
        } else {
            10f64.powf(rng.gen_range(0.0..3.9))
        };
        let mains = if case % 2 == 0 { 50 } else { 60 };
        let phase = rng.gen_range(0.0..TAU);
        let sigma = rng.gen_range(1.0..10.0);
        run::<N>(periods, mains, hum, phase, sigma, 120, seed + case, &mut errors);
    }
    let n = errors.applied.max(1) as f64;
    errors.tone.1 = (errors.tone.1 / (5.0 * n)).sqrt();
    errors.residual.1 = (errors.residual.1 / n).sqrt();
    errors
}

/// The bounds both blocks' sweeps are held to (the 4 ms block's test
/// states them).
fn holds_the_bounds(e: &Errors) {
    assert!(e.applied > 500, "{e:?}");
    assert!(e.tone.0 < 0.05 && e.tone.1 < 5e-3, "{e:?}");
    assert!(e.residual.0 < 0.05 && e.residual.1 < 0.01, "{e:?}");
    assert!(e.only_one * 100 <= e.applied, "{e:?}");
}

/// The 4 ms block (100 instants, tones of 1 to 16 periods): the tones
/// left within 0.05 of their noise σ·√(N/2) (rms 0.005: the window
/// follows u in f32), the residual within 5 % (rms 1 %: the comb's own
/// residual, from its Q31 words, is 0.1 % off the exact one already, and
/// a weak hum's is given with f32's rounding added); the two decide alike
/// in all but 1 % of the blocks, at the edge of the thresholds (where
/// the device's window starts again, the reference's does: a decision
/// at a threshold, which f32 and f64 may take apart). Measured: 0.015
/// and 0.0013 of the noise, 0.7 % and 0.2 %.
#[test]
fn the_long_block_matches_the_f64_fit() {
    holds_the_bounds(&sweep::<100>([1, 2, 4, 8, 16], 11));
}

/// The 1 ms block (25 instants, tones of 1, 2, 3, 4 and 6 periods), the
/// same bounds. Measured: 0.008 and 0.0006 of the noise, 2.1 % and
/// 0.3 %.
#[test]
fn the_short_block_matches_the_f64_fit() {
    holds_the_bounds(&sweep::<25>([1, 2, 3, 4, 6], 12));
}

/// The tones' noise gains with a steady hum taken out: above 1, the
/// one-period tone's most, and steady once the window is full.
#[test]
fn the_tones_noise_grows_by_the_hums_own() {
    let periods = [1, 2, 4, 8, 16];
    let comb = Comb::<100, 5>::new(periods).unwrap();
    let mains = Mains::new(50, RATE_HZ, &comb);
    let mut state = HumState::EMPTY;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut last: Option<[f32; 5]> = None;
    for b in 0..200 {
        let blk = block::<100>(&periods, b, 50.0, 400.0, 0.2, 3.05, &mut rng);
        let tones = comb.column(&blk.rows, 0);
        let mut levels = tones.levels();
        let taken = mains
            .fit()
            .cancel(&mut state, mains.sums(&blk.rows, 0), &tones, &mut levels, 6.4);
        if b < 100 {
            continue;
        }
        let (_, g) = taken.expect("a steady hum is taken out");
        assert!(g.iter().all(|&g| g > 1.0 && g < 1.5), "{g:?}");
        assert!(g[0] >= g[1] && g[1] >= g[4], "{g:?}");
        if let Some(l) = last {
            assert!(g.iter().zip(&l).all(|(a, b)| (a - b).abs() < 1e-3), "{g:?} {l:?}");
        }
        last = Some(g);
    }
}

/// A hum that starts (1,000 counts, from block 50) is taken out within
/// a dozen blocks (the window starts again, then must be half full), and
/// one that stops is no longer taken out from the next block.
#[test]
fn a_hum_that_starts_or_stops_is_followed() {
    let periods = [1, 2, 4, 8, 16];
    let comb = Comb::<100, 5>::new(periods).unwrap();
    let mains = Mains::new(50, RATE_HZ, &comb);
    let mut state = HumState::EMPTY;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for b in 0..300 {
        let on = (50..200).contains(&b);
        let blk = block::<100>(
            &periods,
            b,
            50.0,
            if on { 1000.0 } else { 0.0 },
            1.3,
            3.05,
            &mut rng,
        );
        let tones = comb.column(&blk.rows, 0);
        let mut levels = tones.levels();
        let taken = mains
            .fit()
            .cancel(&mut state, mains.sums(&blk.rows, 0), &tones, &mut levels, 6.4);
        if (62..200).contains(&b) {
            assert!(taken.is_some(), "block {b}");
            assert!(levels.residual < 4.0, "block {b}: {}", levels.residual);
        }
        if b >= 200 {
            assert!(taken.is_none(), "block {b}");
        }
    }
}

/// Noise alone: a hum is taken out by chance in no more blocks than
/// [`SIGNIFICANT`] allows (far below 1 in 1,000), and a sinusoid of
/// 80 Hz, a tone the window cannot hold still, never.
#[test]
fn no_hum_and_other_frequencies_are_left_alone() {
    let periods = [1, 2, 4, 8, 16];
    for (hz, amplitude, most) in [(50.0, 0.0, 2), (80.0, 200.0, 0), (37.0, 500.0, 0)] {
        let comb = Comb::<100, 5>::new(periods).unwrap();
        let mains = Mains::new(50, RATE_HZ, &comb);
        let mut state = HumState::EMPTY;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut applied = 0;
        for b in 0..3000 {
            let blk = block::<100>(&periods, b, hz, amplitude, 0.4, 3.05, &mut rng);
            let tones = comb.column(&blk.rows, 0);
            let mut levels = tones.levels();
            if mains
                .fit()
                .cancel(&mut state, mains.sums(&blk.rows, 0), &tones, &mut levels, 6.4)
                .is_some()
            {
                applied += 1;
            }
        }
        assert!(applied <= most, "{hz} Hz: {applied}");
    }
}

/// A steady hum of 3,200 counts (0.1 of full scale) leaves the tones as
/// they are without it, within their noise, and the residual at the
/// noise.
#[test]
fn a_strong_hum_leaves_the_tones_as_they_are_without_it() {
    let periods = [1, 2, 4, 8, 16];
    let comb = Comb::<100, 5>::new(periods).unwrap();
    let mains = Mains::new(50, RATE_HZ, &comb);
    let mut state = HumState::EMPTY;
    let (mut rng, mut twin) = (ChaCha8Rng::seed_from_u64(8), ChaCha8Rng::seed_from_u64(8));
    let sigma = 3.05;
    for b in 0..200 {
        let blk = block::<100>(&periods, b, 50.0, 3200.0, 1.0, sigma, &mut rng);
        let clean = block::<100>(&periods, b, 50.0, 0.0, 1.0, sigma, &mut twin);
        let tones = comb.column(&blk.rows, 0);
        let mut levels = tones.levels();
        let p = mains
            .fit()
            .cancel(&mut state, mains.sums(&blk.rows, 0), &tones, &mut levels, 6.4);
        if b < 50 {
            continue;
        }
        assert!(p.is_some(), "block {b}");
        let want = comb.column(&clean.rows, 0).levels();
        for k in 0..5 {
            let d = (levels.phasor[k] - want.phasor[k]).norm() / Q31 as f32;
            assert!(d < 4.0 * sigma as f32 * 50f32.sqrt(), "block {b} tone {k}: {d}");
        }
        assert!(
            (levels.residual - want.residual).abs() < 0.5,
            "{} {}",
            levels.residual,
            want.residual
        );
    }
}

/// The words' pair layout gives back every instant's basis, for even
/// and odd blocks, and the portable sums are the plain ones.
#[test]
fn the_words_keep_every_instant() {
    fn check<const N: usize>() {
        let basis: [[i16; 2]; N] = core::array::from_fn(|n| [n as i16 * 3 - 7, -(n as i16) * 5 + 11]);
        let words = Words::new(&basis);
        assert!(words.iter().eq(basis.iter().copied()), "N = {N}");
        assert_eq!(words.at(N), [0, 0]);
        let rows: [[i16; 2]; N] = core::array::from_fn(|n| [0, (n as i16 - 3) * 101]);
        let plain = basis.iter().zip(&rows).fold([0i64; 2], |[c, s], (w, r)| {
            [c + r[1] as i64 * w[0] as i64, s + r[1] as i64 * w[1] as i64]
        });
        assert_eq!(portable(words.iter(), &rows, 1, 0), plain);
        assert_eq!(core::mem::align_of::<Words<N>>(), 8);
    }
    check::<1>();
    check::<24>();
    check::<25>();
    check::<100>();
}
