//! How a sinusoid near one of the 4 ms comb's tones (or near its mean)
//! leaks into every tone's bin at once: the kernels an interferer's
//! spread over the tones is built from (`instrument::spread`).
//!
//! A sinusoid x_n = Re(a·e^(j2πνn/N)) of ν bins (N instants a block)
//! adds to tone k's sum Xₖ = Σₙ xₙ·e^(−j2π·pₖ·n/N) (its phasor,
//! `dsp_core::comb`)
//!
//! ```text
//! δXₖ = ½·(a·S(ν − pₖ) + ā·S(−ν − pₖ)),   S(f) = Σₙ e^(j2πfn/N) = e^(jπf(N−1)/N)·sin(πf)/sin(πf/N)
//! ```
//!
//! so for the two quadratures of a (a = 1 and a = j) the kernels
//! S(ν − pₖ) + S(−ν − pₖ) and j·(S(ν − pₖ) − S(−ν − pₖ)), per unit of N
//! ([`KERNEL`]). Off the tones' and the mean's bins by half a bin or
//! more, a sinusoid leaves much of itself in the residual, which bounds
//! it; within half a bin it may hide in the bins. [`NU`] steps through
//! those half bins a quarter bin at a time (an eighth next to the mean,
//! where a slow drift sits), the tones' own bins left out (a sinusoid
//! there is one tone's error). A scan's skew only turns a.

use crate::array::{Layout, TONES};
use dsp_core::Complex32;

/// How many frequencies [`NU`] holds.
pub const POINTS: usize = 22;

/// The 4 ms layout's comb: each tone's periods a block.
const PERIODS: [u32; TONES] = Layout::BLOCK_4MS.comb();

/// The 4 ms layout's instants a block.
const INSTANTS: usize = Layout::BLOCK_4MS.instants();

/// Whether `layout`'s blocks are those the kernels are of: the 4 ms
/// layout's instants and comb (its amplitudes and phases aside: a
/// spread is taken relative to each tone's phasor).
pub fn of_layout(layout: &Layout) -> bool {
    let comb = layout.comb();
    let mut same = layout.instants() == INSTANTS;
    // (Tone by tone: a slice's comparison is a library call.)
    for k in 0..TONES {
        same &= comb[k] == PERIODS[k];
    }
    same
}

/// The sinusoids' frequencies, bins of a 4 ms block (250 Hz a bin):
/// within half a bin of the mean and of each tone of the comb, a
/// quarter bin apart (an eighth by the mean), not on a tone.
pub const NU: [f32; POINTS] = [
    0.125, 0.25, 0.375, 0.5, 0.75, 1.25, 1.5, 1.75, 2.25, 2.5, 3.5, 3.75, 4.25, 4.5, 7.5, 7.75, 8.25, 8.5,
    15.5, 15.75, 16.25, 16.5,
];

/// `NEAR[i]`: the comb tones [`NU`]`[i]` is within half a bin of, a bit
/// each (bit k for tone k; none for the mean's alone).
pub const NEAR: [u8; POINTS] = near();

const fn near() -> [u8; POINTS] {
    let mut out = [0u8; POINTS];
    let mut i = 0;
    while i < POINTS {
        let mut k = 0;
        while k < TONES {
            let d = NU[i] - PERIODS[k] as f32;
            if d >= -0.5 && d <= 0.5 {
                out[i] |= 1 << k;
            }
            k += 1;
        }
        i += 1;
    }
    out
}

/// `SEEN[i]`: the least share of a sinusoid at [`NU`]`[i]` the residual
/// keeps once the mean and every tone of the comb are fitted out, over
/// its phases: √(residual's mean square / (A²/2)) for amplitude A. A
/// residual of rms e beyond the noise holds a sinusoid there of at
/// most √2·e/`SEEN[i]`.
pub const SEEN: [f32; POINTS] = seen();

const fn seen() -> [f32; POINTS] {
    let mut out = [0f32; POINTS];
    let mut i = 0;
    while i < POINTS {
        // The residual's mean square is α + β·cos 2φ + γ·sin 2φ in the
        // phase φ: its least, α − √(β² + γ²), from three phases.
        let nu = NU[i] as f64;
        let (e0, e45, e90) = (kept(nu, 0.0), kept(nu, 0.25), kept(nu, 0.5));
        let alpha = (e0 + e90) / 2.0;
        let (beta, gamma) = ((e0 - e90) / 2.0, e45 - alpha);
        let least = alpha - sqrt(beta * beta + gamma * gamma);
        out[i] = sqrt(if least > 0.0 { least } else { 0.0 } / 0.5) as f32;
        i += 1;
    }
    out
}

/// The residual's mean square of a unit sinusoid at ν bins,
/// cos(2πνn/N + π·`half_turns`), once the mean and the comb's tones are
/// fitted out.
const fn kept(nu: f64, half_turns: f64) -> f64 {
    const PI: f64 = core::f64::consts::PI;
    let n = INSTANTS as f64;
    let phi = PI * half_turns;
    let (c, s) = (cos(phi), sin(phi));
    // Σx²/N = ½ + ½·Re(e^(2jφ)·S(2ν))/N; the mean Re(e^(jφ)·S(ν))/N.
    let (a_re, a_im) = sum(2.0 * nu);
    let total = 0.5 + 0.5 * ((c * c - s * s) * a_re - 2.0 * c * s * a_im) / n;
    let (m_re, m_im) = sum(nu);
    let mean = (c * m_re - s * m_im) / n;
    let mut kept = total - mean * mean;
    let mut k = 0;
    while k < TONES {
        let p = PERIODS[k] as f64;
        let (u_re, u_im) = sum(nu - p);
        let (w_re, w_im) = sum(-nu - p);
        // δX = ½·(e^(jφ)·S(ν − p) + e^(−jφ)·S(−ν − p)); the tone takes
        // 2·|δX|²/N² of the mean square.
        let x_re = 0.5 * ((c * u_re - s * u_im) + (c * w_re + s * w_im));
        let x_im = 0.5 * ((c * u_im + s * u_re) + (c * w_im - s * w_re));
        kept -= 2.0 * (x_re * x_re + x_im * x_im) / (n * n);
        k += 1;
    }
    kept
}

/// √x by Newton's method (x ≥ 0): `const`, for the tables.
const fn sqrt(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut r = if x > 1.0 { x } else { 1.0 };
    let mut i = 0;
    while i < 60 {
        r = 0.5 * (r + x / r);
        i += 1;
    }
    r
}

/// `KERNEL[i][k]`: the change of comb tone k's phasor (per unit of N, of
/// the sinusoid's amplitude) for a sinusoid at [`NU`]`[i]` of phase 0
/// and of phase 90°.
pub const KERNEL: [[[Complex32; 2]; TONES]; POINTS] = kernels();

const fn kernels() -> [[[Complex32; 2]; TONES]; POINTS] {
    let zero = Complex32::new(0.0, 0.0);
    let mut out = [[[zero; 2]; TONES]; POINTS];
    let mut i = 0;
    while i < POINTS {
        let mut k = 0;
        while k < TONES {
            let nu = NU[i] as f64;
            let p = PERIODS[k] as f64;
            let (a_re, a_im) = sum(nu - p);
            let (b_re, b_im) = sum(-nu - p);
            let n = INSTANTS as f64;
            out[i][k] = [
                Complex32::new(((a_re + b_re) / n) as f32, ((a_im + b_im) / n) as f32),
                Complex32::new((-(a_im - b_im) / n) as f32, ((a_re - b_re) / n) as f32),
            ];
            k += 1;
        }
        i += 1;
    }
    out
}

/// S(f) = Σₙ e^(j2πfn/N) over a block, (re, im), f not a whole multiple
/// of N.
const fn sum(f: f64) -> (f64, f64) {
    const PI: f64 = core::f64::consts::PI;
    let n = INSTANTS as f64;
    let magnitude = sin(PI * f) / sin(PI * f / n);
    let phase = PI * f * (n - 1.0) / n;
    (magnitude * cos(phase), magnitude * sin(phase))
}

/// sin x by its Taylor series after reducing x to [−π, π] (to 10⁻¹⁵
/// there): `const`, for the tables.
const fn sin(x: f64) -> f64 {
    const PI: f64 = core::f64::consts::PI;
    let turns = x / (2.0 * PI);
    let whole = if turns >= 0.0 {
        (turns + 0.5) as i64
    } else {
        (turns - 0.5) as i64
    };
    let r = x - whole as f64 * 2.0 * PI;
    let mut term = r;
    let mut total = r;
    let mut i = 1;
    while i < 30 {
        term = -term * r * r / ((2 * i) as f64 * (2 * i + 1) as f64);
        total += term;
        i += 1;
    }
    total
}

const fn cos(x: f64) -> f64 {
    sin(x + core::f64::consts::FRAC_PI_2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    /// The kernels against the sums themselves, in f64: within 10⁻⁶ of
    /// N per component.
    #[test]
    fn the_kernels_are_the_sums() {
        let n = INSTANTS;
        for (i, &nu) in NU.iter().enumerate() {
            for (k, &p) in PERIODS.iter().enumerate() {
                // Phase 0 and phase 90°: x = cos(θ), x = −sin(θ).
                for (q, shift) in [0.0, PI / 2.0].into_iter().enumerate() {
                    let (mut re, mut im) = (0f64, 0f64);
                    for t in 0..n {
                        let x = libm::cos(2.0 * PI * nu as f64 * t as f64 / n as f64 + shift);
                        let w = 2.0 * PI * p as f64 * t as f64 / n as f64;
                        re += x * libm::cos(w);
                        im -= x * libm::sin(w);
                    }
                    // δX = ½·(a·S⁺ + ā·S⁻): the kernel is 2·δX.
                    let (kr, ki) = (2.0 * re / n as f64, 2.0 * im / n as f64);
                    let got = KERNEL[i][k][q];
                    assert!(
                        (got.re as f64 - kr).abs() < 1e-6 && (got.im as f64 - ki).abs() < 1e-6,
                        "ν {nu} tone {k} quadrature {q}: {got} vs {kr} {ki}"
                    );
                }
            }
        }
    }

    /// The residual's share against the sinusoid itself in f64, at 3600
    /// phases: never below [`SEEN`], and within 10⁻⁴ of it at the least.
    #[test]
    fn the_residual_keeps_what_seen_says() {
        let n = INSTANTS;
        for (i, &nu) in NU.iter().enumerate() {
            let mut least = f64::INFINITY;
            for q in 0..3600 {
                let phi = PI * q as f64 / 3600.0;
                let (_, kept) = crate::array::tests::projected(n, &PERIODS, nu as f64, phi);
                least = least.min(libm::sqrt(kept.max(0.0) / 0.5));
            }
            let got = SEEN[i] as f64;
            assert!(
                got <= least + 1e-6 && got >= least - 1e-4,
                "ν {nu}: {got} vs {least}"
            );
        }
    }

    /// The frequencies are the half bins of the module's docs: each
    /// within half a bin of the mean or a tone, none on one, ascending.
    #[test]
    fn the_frequencies_cover_the_half_bins() {
        for w in NU.windows(2) {
            assert!(w[0] < w[1]);
        }
        for nu in NU {
            let near = core::iter::once(0)
                .chain(PERIODS)
                .any(|p| (nu - p as f32).abs() <= 0.5);
            let on = core::iter::once(0).chain(PERIODS).any(|p| nu == p as f32);
            assert!(near && !on, "{nu}");
        }
        assert_eq!(NEAR[..4], [0, 0, 0, 1]);
        assert_eq!(NEAR[6], 0b11);
        assert_eq!(NEAR[9], 0b10);
        assert_eq!(NEAR[POINTS - 1], 0b1_0000);
        for p in PERIODS {
            let step = |d: f32| NU.contains(&(p as f32 + d));
            assert!(step(-0.5) && step(-0.25) && step(0.25) && step(0.5), "{p}");
        }
    }
}
