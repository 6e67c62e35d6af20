//! Mains hum followed across blocks and taken out of a comb's sums.
//!
//! Over a 4 ms block a 50 Hz hum is a fifth of a turn: a slow arc that
//! neither the block's mean nor its tones fit, so it leaks into the
//! lowest tones (38 % of its amplitude into a tone of one period a
//! block) and fills the residual. Fitted inside the block it cannot be
//! told from those tones: a parabola beside them costs the one-period
//! tone eight times its noise. Across blocks it can: the hum keeps its
//! frequency and phase, so one phasor fitted over the last few tens of
//! milliseconds, each block's own hum sums with its mean and tones taken
//! out, separates it, and each block's sums become those of the block
//! less that hum.
//!
//! In a block of N instants at f_s, with b₀ₙ = cos φₙ, b₁ₙ = sin φₙ,
//! φₙ = 2π·f·n/f_s (the block's own instants), a hum is p·b = p₀·b₀ + p₁·b₁
//! and is T·p in the next block (T the rotation by ψ = 2π·f·N/f_s). With
//! P the projection on the mean and the comb's tones and P⊥ = I − P:
//!
//! ```text
//! uⱼ = ⟨P⊥x, bⱼ⟩ = ⟨x, bⱼ⟩ − Σx·dcⱼ/N − (2/N)·Σₖ Re(Xₖ·conj Lₖⱼ)   (counts·instants)
//! Q  = ⟨P⊥bᵢ, P⊥bⱼ⟩                                                (instants)
//! M ← λ·T·M·Tᵀ + Q,   r ← λ·T·r + u,   p = M⁻¹·r                 (per block, λ = 1 − T_block/τ)
//! ```
//!
//! (Lₖⱼ = Σₙ bⱼₙ·e^(−jθₖₙ), dcⱼ = Σₙ bⱼₙ: the basis's own comb sums.) The
//! block's sums are then those of x − p·b, exactly: Xₖ − p·Lₖ, Σx − p·dc,
//! and the residual's energy E − 2·pᵀu + pᵀQp; every later step (the
//! amplitudes, the ratio V/I, the residual checks) reads them unchanged.
//!
//! Only a hum the window vouches for is taken out ([`Mains::cancel`]):
//! the window must be half full (τ·ln 2: a block or two cannot tell the
//! hum from the lowest tones), its energy pᵀr must stand out of the noise the window leaves
//! (χ² of 2 degrees of freedom above [`SIGNIFICANT`]), and what the
//! window leaves must itself be clean (its rms within the caller's
//! bound): a sinusoid of another frequency turns in this frame, is not
//! one phasor, and leaves the window unclean. p's own noise, σ²·M⁻¹M₂M⁻¹
//! (M₂ the same sum with λ²), moves each tone by p·Lₖ: the tone's noise
//! grows by the factor [`Window::gains`] gives.
//!
//! u is formed in i128 from the comb's exact sums, the residual's energy
//! in f64 (a strong hum's is the small difference of large numbers), the
//! rest in f32 (the constants in f64 once, from the Q31 words the sums
//! use): basic arithmetic only, the same bits on every target.

use crate::comb::{Comb, Levels, Tones};
use crate::cossin::cossin;
use crate::fmath;
use crate::Complex32;

/// A hum's χ² (2 degrees of freedom) over the window's noise above which
/// it is taken out: by chance once in 2.7·10⁵ blocks.
pub const SIGNIFICANT: f32 = 25.0;

/// The window's time constant τ, s: two turns of 50 Hz.
pub const TAU_S: f32 = 0.04;

/// The reference's full scale, 2³¹.
const Q31: f64 = 2_147_483_648.0;

/// A comb's view of mains hum at one frequency: its reference and how it
/// overlaps the comb's mean and tones (configuration, fixed per layout).
#[derive(Clone, Debug, PartialEq)]
pub struct Mains<const N: usize, const K: usize> {
    /// Instant n: [cos φₙ, sin φₙ], Q31 (saturated, as the comb's).
    reference: [[i32; 2]; N],
    /// Lₖⱼ: the comb's sum of basis j at tone k, instants.
    leak: [[Complex32; 2]; K],
    /// dcⱼ = Σₙ bⱼₙ, instants.
    dc: [f32; 2],
    /// 2·Lₖⱼ/N, Q32: [re, im] (u's tone terms in exact integers).
    leak_q32: [[[i64; 2]; 2]; K],
    /// dcⱼ/N, Q32.
    dc_q32: [i64; 2],
    /// Q = ⟨P⊥bᵢ, P⊥bⱼ⟩, instants.
    q: [[f32; 2]; 2],
    /// cos ψ, sin ψ: a block's turn of the hum.
    turn: [f32; 2],
    /// λ per block.
    forget: f32,
}

/// What the window has seen, shared by every input of a front end (the
/// same instants): M, M₂, Σλᵃ, and from them M⁻¹ and each tone's noise
/// gain (state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window<const K: usize> {
    m: [[f32; 2]; 2],
    m2: [[f32; 2]; 2],
    weight: f32,
    inverse: Option<[[f32; 2]; 2]>,
    gains: [f32; K],
}

/// One input's hum so far: r (counts·instants) and Σλᵃ·E, the residual
/// energies the window holds (counts²·instants) (state).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HumState {
    r: [f32; 2],
    energy: f32,
}

impl HumState {
    /// No block yet.
    pub const EMPTY: Self = Self {
        r: [0.0; 2],
        energy: 0.0,
    };
}

impl<const K: usize> Window<K> {
    /// No block yet.
    pub const EMPTY: Self = Self {
        m: [[0.0; 2]; 2],
        m2: [[0.0; 2]; 2],
        weight: 0.0,
        inverse: None,
        gains: [1.0; K],
    };

    /// Each tone's noise, times its own, where a hum is taken out.
    pub fn gains(&self) -> &[f32; K] {
        &self.gains
    }

    /// One more block (before any input's [`Mains::cancel`] of it).
    pub fn advance<const N: usize>(&mut self, mains: &Mains<N, K>) {
        let l = mains.forget;
        self.m = add(&scale(&mains.rotate(&self.m), l), &mains.q);
        self.m2 = add(&scale(&mains.rotate(&self.m2), l * l), &mains.q);
        self.weight = l * self.weight + 1.0;
        self.inverse = inverse2(&self.m);
        let Some(a) = self.inverse else {
            self.gains = [f32::INFINITY; K];
            return;
        };
        // Cov p / σ² = M⁻¹·M₂·M⁻¹; a tone's component moves by l·p.
        let cov = mul(&mul(&a, &self.m2), &a);
        let half = N as f32 / 2.0;
        for (g, leak) in self.gains.iter_mut().zip(&mains.leak) {
            let re = quad(&cov, [leak[0].re, leak[1].re]);
            let im = quad(&cov, [leak[0].im, leak[1].im]);
            *g = fmath::sqrt(1.0 + fmath::max(re, im) / half);
        }
    }
}

impl<const N: usize, const K: usize> Mains<N, K> {
    /// Hum at `mains_hz` in blocks of N instants at `rate_hz`, beside
    /// `comb`'s tones, followed over [`TAU_S`].
    pub fn new(mains_hz: u32, rate_hz: u32, comb: &Comb<N, K>) -> Self {
        let mut reference = [[0i32; 2]; N];
        for (n, w) in reference.iter_mut().enumerate() {
            let (c, s) = cossin(turns(mains_hz as u64 * n as u64, rate_hz));
            *w = [c.max(-i32::MAX), s.max(-i32::MAX)];
        }
        let basis = |j: usize, n: usize| reference[n][j] as f64 / Q31;
        let mut leak = [[Complex32::new(0.0, 0.0); 2]; K];
        let mut leak64 = [[(0.0f64, 0.0f64); 2]; K];
        for (k, row) in leak64.iter_mut().enumerate() {
            let Some(tone) = comb.reference(k) else { continue };
            for (j, l) in row.iter_mut().enumerate() {
                for (n, &[c, s]) in tone.iter().enumerate() {
                    l.0 += basis(j, n) * c as f64 / Q31;
                    l.1 -= basis(j, n) * s as f64 / Q31;
                }
                leak[k][j] = Complex32::new(l.0 as f32, l.1 as f32);
            }
        }
        let dc = [0, 1].map(|j| (0..N).map(|n| basis(j, n)).sum::<f64>());
        let nf = N as f64;
        let q = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                let own: f64 = (0..N).map(|n| basis(i, n) * basis(j, n)).sum();
                let tones: f64 = leak64.iter().map(|l| l[i].0 * l[j].0 + l[i].1 * l[j].1).sum();
                (own - dc[i] * dc[j] / nf - 2.0 / nf * tones) as f32
            })
        });
        let q32 = |v: f64| libm::round(v * 4_294_967_296.0) as i64;
        let leak_q32 = leak64.map(|l| l.map(|(re, im)| [q32(2.0 * re / nf), q32(2.0 * im / nf)]));
        let dc_q32 = dc.map(|d| q32(d / nf));
        let (c, s) = cossin(turns(mains_hz as u64 * N as u64, rate_hz));
        let block_s = N as f32 / rate_hz as f32;
        Self {
            reference,
            leak,
            dc: dc.map(|d| d as f32),
            leak_q32,
            dc_q32,
            q,
            turn: [c as f32 / Q31 as f32, s as f32 / Q31 as f32],
            forget: 1.0 - block_s / TAU_S,
        }
    }

    /// Σₙ xₙ·b₀ₙ and Σₙ xₙ·b₁ₙ of input `col` of a block's rows (Q31 ·
    /// counts; each product below 2⁴⁶, N of them: no overflow for
    /// N < 2¹⁷).
    pub fn sums<const S: usize>(&self, rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
        let (mut c, mut s) = (0i64, 0i64);
        if col >= S {
            return [0, 0];
        }
        for (row, &[rc, rs]) in rows.iter().zip(&self.reference) {
            let x = row[col] as i64;
            c += x * rc as i64;
            s += x * rs as i64;
        }
        [c, s]
    }

    /// u = ⟨P⊥x, b⟩ (counts·instants) from the block's exact sums: in
    /// i128 (every term below 2⁸⁷: the sums below 2⁵³, the constants
    /// 2³³), so that a strong hum's u, the small difference of large
    /// sums, keeps every bit but the constants' rounding (2⁻³²).
    fn projections(&self, sums: [i64; 2], tones: &Tones<K>) -> [f64; 2] {
        core::array::from_fn(|j| {
            let mut acc = (sums[j] as i128) << 32;
            for (x, l) in tones.x.iter().zip(&self.leak_q32) {
                acc -= x.re as i128 * l[j][0] as i128 + x.im as i128 * l[j][1] as i128;
            }
            acc -= (tones.sum as i128 * self.dc_q32[j] as i128) << 31;
            acc as f64 / (Q31 * 4_294_967_296.0)
        })
    }

    /// T·A·Tᵀ.
    fn rotate(&self, a: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
        let [c, s] = self.turn;
        let t = [[c, s], [-s, c]];
        let tt = [[c, -s], [s, c]];
        mul(&mul(&t, a), &tt)
    }

    /// Take this block's view of the hum (`sums`: [`Mains::sums`] of the
    /// input whose comb gave `tones` and `levels`) into `state`, and the
    /// hum the window vouches for out of `levels` (module docs): its
    /// phasors, amplitudes, largest and residual are then the block's
    /// less the hum. `clean_counts`: the rms the window may leave (the
    /// front end's residual bound). Returns the hum taken out, p
    /// (counts), or None where none was (`levels` untouched). `window`
    /// has advanced for this block.
    pub fn cancel(
        &self,
        window: &Window<K>,
        state: &mut HumState,
        sums: [i64; 2],
        tones: &Tones<K>,
        levels: &mut Levels<K>,
        clean_counts: f32,
    ) -> Option<[f32; 2]> {
        if tones.n as usize != N {
            return None;
        }
        let nf = N as f32;
        let q31 = Q31 as f32;
        let u = self.projections(sums, tones);
        let u32 = u.map(|v| v as f32);
        let energy = tones.residual_energy();
        let [c, s] = self.turn;
        let l = self.forget;
        let r = state.r;
        state.r = [
            l * (c * r[0] + s * r[1]) + u32[0],
            l * (-s * r[0] + c * r[1]) + u32[1],
        ];
        state.energy = l * state.energy + energy as f32;
        let a = window.inverse?;
        let r = state.r;
        let p = [a[0][0] * r[0] + a[0][1] * r[1], a[1][0] * r[0] + a[1][1] * r[1]];
        let explained = p[0] * r[0] + p[1] * r[1];
        let dof = window.weight * (N - 1 - 2 * K) as f32 - 2.0;
        let noise = (state.energy - explained) / dof;
        // Half a window at least: a block or two alone cannot tell the
        // hum from the lowest tones (M is near singular).
        let full = window.weight * (1.0 - self.forget) >= 0.5;
        if !(full && explained > SIGNIFICANT * noise && noise <= clean_counts * clean_counts) {
            return None;
        }
        for ((phasor, amplitude), leak) in levels
            .phasor
            .iter_mut()
            .zip(levels.amplitude.iter_mut())
            .zip(&self.leak)
        {
            let y = *phasor / q31 - (leak[0] * p[0] + leak[1] * p[1]);
            *phasor = y * q31;
            *amplitude = fmath::hypot(y.re, y.im) * (2.0 / nf);
        }
        levels.largest = levels
            .amplitude
            .iter()
            .fold(0.0, |m, &a| if a > m { a } else { m });
        // The energy less the hum's cancels two numbers up to 10⁷ times
        // the noise's (a strong hum): in f64, from u and E as exact.
        let (p0, p1) = (p[0] as f64, p[1] as f64);
        let q = self.q.map(|row| row.map(|v| v as f64));
        let pqp = p0 * (q[0][0] * p0 + q[0][1] * p1) + p1 * (q[1][0] * p0 + q[1][1] * p1);
        let e = energy - 2.0 * (p0 * u[0] + p1 * u[1]) + pqp;
        levels.residual = fmath::sqrt((if e > 0.0 { e } else { 0.0 } / N as f64) as f32);
        Some(p)
    }
}

/// The phase of `num/den` turns as the comb's references take it (2³² a
/// turn, rounded).
fn turns(num: u64, den: u32) -> i32 {
    let m = num % den as u64;
    (((m << 32) + den as u64 / 2) / den as u64) as u32 as i32
}

fn mul(a: &[[f32; 2]; 2], b: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
    core::array::from_fn(|i| core::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j]))
}

fn add(a: &[[f32; 2]; 2], b: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
    core::array::from_fn(|i| core::array::from_fn(|j| a[i][j] + b[i][j]))
}

fn scale(a: &[[f32; 2]; 2], k: f32) -> [[f32; 2]; 2] {
    a.map(|row| row.map(|v| v * k))
}

/// vᵀ·A·v.
fn quad(a: &[[f32; 2]; 2], v: [f32; 2]) -> f32 {
    v[0] * (a[0][0] * v[0] + a[0][1] * v[1]) + v[1] * (a[1][0] * v[0] + a[1][1] * v[1])
}

/// A⁻¹, None where A is singular.
fn inverse2(a: &[[f32; 2]; 2]) -> Option<[[f32; 2]; 2]> {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    fmath::positive_finite(det).then(|| [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]])
}

#[cfg(test)]
mod tests;
