//! Deterministic pseudo-random numbers (xoshiro128++-style state of four
//! `u32`, seeded by SplitMix), with uniform and Gaussian samples. The same
//! seed gives the same sequence on every target.

/// Random number generator state.
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u32; 4],
    spare: Option<f64>,
}

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        let mut z = seed;
        let mut next = || {
            z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut x = z;
            x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            x ^ (x >> 31)
        };
        let (a, b) = (next(), next());
        Self {
            s: [a as u32, (a >> 32) as u32 | 1, b as u32, (b >> 32) as u32],
            spare: None,
        }
    }

    /// Next 32 random bits (xoshiro128++).
    pub fn next_u32(&mut self) -> u32 {
        let s = &mut self.s;
        let r = s[0].wrapping_add(s[3]).rotate_left(7).wrapping_add(s[0]);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        r
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 / (1u64 << 53) as f64
    }

    /// Approximately standard normal, integer-only and cheap: the sum of
    /// four uniforms (Irwin–Hall), scaled to unit variance. Tails end at
    /// ±3.46 σ; fine for ADC noise, where it keeps simulated blocks fast
    /// enough to run inside QEMU.
    pub fn gaussian_fast(&mut self) -> f32 {
        let (a, b) = (self.next_u32(), self.next_u32());
        let sum = (a & 0xffff) + (a >> 16) + (b & 0xffff) + (b >> 16); // 4 × U[0, 65536)
                                                                       // Mean 2·65535, variance 4·(65536² − 1)/12; scale to N(0, 1).
        (sum as f32 - 131_070.0) * (1.732_050_8 / 65_536.0)
    }

    /// Standard normal (Box–Muller, both values used).
    pub fn gaussian(&mut self) -> f64 {
        if let Some(v) = self.spare.take() {
            return v;
        }
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        let r = libm::sqrt(-2.0 * libm::log(u1));
        let (s, c) = (
            libm::sin(core::f64::consts::TAU * u2),
            libm::cos(core::f64::consts::TAU * u2),
        );
        self.spare = Some(r * s);
        r * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_moments_and_determinism() {
        let mut r = Rng::new(42);
        let n = 200_000;
        let (mut m, mut v) = (0.0, 0.0);
        for _ in 0..n {
            let g = r.gaussian();
            m += g;
            v += g * g;
        }
        m /= n as f64;
        v = v / n as f64 - m * m;
        assert!(m.abs() < 0.01, "{m}");
        assert!((v - 1.0).abs() < 0.01, "{v}");
        let (mut m, mut v) = (0.0, 0.0);
        for _ in 0..n {
            let g = r.gaussian_fast() as f64;
            m += g;
            v += g * g;
        }
        m /= n as f64;
        v = v / n as f64 - m * m;
        assert!(m.abs() < 0.01 && (v - 1.0).abs() < 0.01, "fast: {m} {v}");
        let (mut a, mut b) = (Rng::new(7), Rng::new(7));
        assert!((0..100).all(|_| a.next_u32() == b.next_u32()));
    }
}
