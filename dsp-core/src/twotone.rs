//! The line from two tones at once, and how well one uniform line
//! explains both.
//!
//! A block excited by two tones carries the impedance at two frequencies,
//! Z₁ at f₁ and Z₂ at f₂: four real numbers for the line's two unknowns,
//! R and C. The line that fits both best, weighted by each tone's noise,
//! is the joint estimate; what it leaves is a model check that no
//! single-frequency meter has:
//!
//! ```text
//! Z_k(R, C) = ζ(ω_k·R·C) / (ω_k·C)                       (the line, with leads)
//! χ² = Σ_k |Z_k,measured − Z_k(R, C)|² / σ_k²            (σ_k: 1σ of Re Z_k and of Im Z_k, Ω)
//! ```
//!
//! minimized over (ln R, ln C) by Gauss–Newton from the single-tone
//! inversions ([`Inverter`]). On a sensor that is a uniform line, χ² is
//! chi-squared with 4 − 2 = 2 degrees of freedom (mean 2; above
//! [`CHI2_FLAG`] one block in 10⁴ by chance). A contact resistance, a
//! parasitic capacitance or a disturbance that the line does not have
//! moves the two tones' lines apart and χ² up: the record is flagged
//! ([`Solution::consistent`]).
//!
//! A step whose second-order term is small (under 0.03σ, from ζ'' where
//! the model gives it exactly: the continuous line) is taken without
//! evaluating the model again, χ² there to second order: a tracked line
//! is solved in two evaluations, not three.
//!
//! The covariance of (ln R, ln C) is σ²-weighted (JᵀJ)⁻¹ at the optimum,
//! so [`Solution::sigma_ln_c`] is the joint estimate's 1σ relative error
//! of C.
//!
//! The noise σ_k of a tone's impedance follows from the block
//! ([`z_sigma`]): with N pairs, amplitudes A (counts) and residual r
//! (counts rms, what the tones do not explain) per channel, each
//! component of the phasor V has a relative 1σ of r·√2/(A·√N), and Z =
//! k·V/I adds the voltage's and the current's in quadrature.
//!
//! # The film's loss
//! A real film's C is C·(1 − j·tan δ) ([`crate::dielectric`]): the model
//! takes it in to first order, Z(R, C) + u·∂Z/∂ln C with
//! u = ln(1 − j·tan δ). Ignored, a tan δ of 10⁻³ moves the two tones'
//! lines apart by more than their noise on a strong signal, and one of
//! 10⁻² moves the joint C by 0.7 %.
//!
//! The film's tan δ is known only to within its material's spread, so it
//! is a third parameter of the fit with that knowledge as a prior:
//! (t − t₀)²/σ_t² joins χ² as a fifth residual. Four measured numbers and
//! one prior for three parameters leave χ² 2 degrees of freedom (nearer
//! 1 where the tones fix tan δ far better than its prior does), and
//! the σ of C from the 3×3 covariance carries what the loss is not known
//! to. An undeclared effect can hide in the loss only as far as its
//! frequency signature (a resistance ∝ 1/f) and the prior allow; a film
//! outside its prior raises χ² like any other effect the model lacks.
//! With σ_t = 0 ([`Dielectric::IDEAL`], or a film measured exactly) the
//! fit is of (R, C) alone.

use crate::dielectric::Dielectric;
use crate::fmath::{self, positive_finite};
use crate::invert::{InvertError, Inverter, Line};
use crate::Complex32;
use core::f32::consts::TAU;

/// χ² (2 degrees of freedom) above which a record is flagged: exceeded by
/// chance with probability e^(−χ²/2) = 10⁻⁴ on a uniform line.
pub const CHI2_FLAG: f32 = 18.42;

/// The χ² above which a record of a uniform line is flagged with
/// probability `p` when each tone's σ is estimated from the block's own
/// residual with `dof` degrees of freedom (N − 2K − 1 for K tones and a
/// mean over N instants): the statistic is then 2·F(2, dof), whose tail
/// is (1 + χ²/dof)^(−dof/2), so the flag is dof·(p^(−2/dof) − 1). For
/// large `dof` it tends to −2·ln p ([`CHI2_FLAG`] at p = 10⁻⁴); 89
/// degrees of freedom (the array's 100-instant blocks) need 20.5.
pub fn chi2_flag(p: f32, dof: u32) -> f32 {
    let d = dof.max(1) as f32;
    d * (libm::powf(p, -2.0 / d) - 1.0)
}

/// The χ² above which a record fitted to `tones` tones (2·K − 2 degrees
/// of freedom: 2·K measured numbers and the film's prior less three
/// parameters) is flagged with probability `p`, each tone's σ estimated
/// from the block's residual with `dof` degrees of freedom: the statistic
/// is m·F(m, dof), m = 2·K − 2, whose tail for even m is
/// x^(dof/2)·Σ_{j<m/2} C(dof/2 + j − 1, j)·(1 − x)^j with
/// x = dof/(dof + χ²), found by bisection on x. Two tones give
/// [`chi2_flag`]; three tones and 89 degrees of freedom need 26.6 (the
/// large-`dof` limit, chi-squared with 4 degrees of freedom, 23.5).
pub fn chi2_flag_of(p: f32, tones: u32, dof: u32) -> f32 {
    let (m, d) = (2 * tones.max(2) - 2, dof.max(1) as f32);
    let tail = |x: f32| {
        let (mut term, mut sum) = (1.0f32, 1.0f32);
        for j in 1..m / 2 {
            term *= (0.5 * d + j as f32 - 1.0) / j as f32 * (1.0 - x);
            sum += term;
        }
        libm::powf(x, 0.5 * d) * sum
    };
    // The tail grows with x (a smaller χ²): bisect for tail(x) = p.
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let x = 0.5 * (lo + hi);
    d * (1.0 / x - 1.0)
}

/// Gauss–Newton iterations at most (from the single-tone inversions it
/// converges in 2–3).
const ITERATIONS: usize = 6;

/// One tone of a block: its impedance and noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tone {
    /// Measured impedance, Ω.
    pub z: Complex32,
    /// Frequency, Hz.
    pub f_hz: f32,
    /// 1σ of Re Z and of Im Z, each, Ω ([`z_sigma`]).
    pub sigma_ohm: f32,
}

/// The joint line of two tones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    /// The line both tones fit best; `x` at the higher tone. Its `kappa`
    /// is not computed (NaN): a single tone's error amplification says
    /// nothing of the joint fit, whose error is [`Solution::sigma_ln_c`]
    /// ([`Inverter::kappa`] gives it, if wanted).
    pub line: Line,
    /// χ² of the fit, the film's prior included ([`Solution::dof`]
    /// degrees of freedom on a uniform line: 2 for two tones).
    pub chi2: f32,
    /// 1σ relative error of C from the fit's covariance.
    pub sigma_ln_c: f32,
    /// The film's loss tangent the fit found (its prior's mean when the
    /// prior's σ is 0).
    pub loss_tangent: f32,
    /// The most C can be off (relative) per unit of a one-tone error's
    /// share of the residual (√χ² without noise) when something the
    /// model lacks perturbs one tone alone (an interferer at a tone's
    /// frequency, which no residual sees). With noise the residual holds
    /// its share too: `instrument::joint::hidden` takes
    /// √max(χ², [`Solution::dof`]).
    pub hidden_ln_c: f32,
    /// How far each tone's own error moves C, squared: |∂ln C/∂z_k|²·σ_k²
    /// (relative, per unit of the tone's noise), lowest tone first (the
    /// first three; ∞ for all with more). A disturbance that shifts tone
    /// k by s_k σ moves ln C by at most Σ_k √(this)·s_k, which
    /// [`Solution::sigma_ln_c`] (their root sum of squares, the prior's
    /// share with them) bounds only for a shift of one tone.
    pub tone_ln_c2: [f32; 3],
    /// Degrees of freedom of χ² on a uniform line: 2·K − 2 for K tones
    /// (2·K measured numbers, and the film's prior when its loss is
    /// fitted, less the parameters).
    pub dof: f32,
}

impl Solution {
    /// One uniform line explains both tones of a two-tone solution within
    /// their noise (χ² ≤ [`CHI2_FLAG`], the flag of 2 degrees of freedom;
    /// a fit of more tones is judged by [`chi2_flag_of`] for its
    /// [`Solution::dof`]).
    pub fn consistent(&self) -> bool {
        self.chi2 <= CHI2_FLAG
    }
}

/// 1σ of each component of Z (Ω) for a tone of impedance `z` measured over
/// `n` pairs with voltage and current amplitudes `a_v`, `a_i` and
/// residuals `r_v`, `r_i` (counts): |Z|·√(2/n)·√((r_v/a_v)² + (r_i/a_i)²).
/// Infinite when an amplitude is 0 (no tone: no information).
pub fn z_sigma(z: Complex32, n: u32, a_v: f32, a_i: f32, r_v: f32, r_i: f32) -> f32 {
    if !(a_v > 0.0 && a_i > 0.0 && n > 0) {
        return f32::INFINITY;
    }
    let (ev, ei) = (r_v / a_v, r_i / a_i);
    // |Z|² < 10³⁸ for any impedance below 10¹⁹ Ω: no hypot needed.
    fmath::sqrt((z.re * z.re + z.im * z.im) * (2.0 / n as f32) * (ev * ev + ei * ei))
}

/// The line both `tones` fit, on a film `d` (its loss fitted within its
/// prior), starting from the single-tone
/// inversions (the branch chosen nearest `c_hint_farad`, as
/// [`Inverter::invert_near`]); an error when neither tone inverts, or a
/// σ is not finite and positive.
pub fn solve<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    tones: &[Tone; K],
    c_hint_farad: f32,
) -> Result<Solution, InvertError> {
    check(tones)?;
    // The highest tone resolves R best; the lowest starts where the
    // highest is ambiguous or out of range.
    let sorted = ordered(tones);
    let (lo, hi) = (sorted[0], sorted[K - 1]);
    let start = match inv.invert_near(hi.z, hi.f_hz, c_hint_farad) {
        Ok(l) => l,
        Err(e_hi) => match inv.invert_near(lo.z, lo.f_hz, c_hint_farad) {
            Ok(l) => l,
            Err(_) => return Err(e_hi),
        },
    };
    refine(inv, d, sorted, [start.r_ohm, start.c_farad, d.loss_tangent])
}

/// The line both `tones` fit, starting from a known line (`r_ohm`,
/// `c_farad` and the film's `loss_tangent`: the previous record's
/// [`Solution`], when a channel tracks its sensor), without the
/// single-tone inversions: half the work of [`solve`]. The start must lie
/// in the basin of the line (within ~30 % in R and C of it); a start
/// beyond x = [`crate::tline::X_MAX`] is an error. (The film's prior stays
/// `d`'s; the start's tan δ only saves iterations.)
pub fn solve_from<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    tones: &[Tone; K],
    r_ohm: f32,
    c_farad: f32,
    loss_tangent: f32,
) -> Result<Solution, InvertError> {
    check(tones)?;
    if !(positive_finite(r_ohm) && positive_finite(c_farad) && loss_tangent.is_finite()) {
        return Err(InvertError::BadPrior);
    }
    let t = if d.spread > 0.0 {
        loss_tangent
    } else {
        d.loss_tangent
    };
    refine(inv, d, ordered(tones), [r_ohm, c_farad, t])
}

fn check<const K: usize>(tones: &[Tone; K]) -> Result<(), InvertError> {
    if K < 2 {
        return Err(InvertError::BadFrequency);
    }
    for t in tones {
        if !positive_finite(t.sigma_ohm) {
            return Err(InvertError::NotCapacitive);
        }
        if !positive_finite(t.f_hz) {
            return Err(InvertError::BadFrequency);
        }
    }
    Ok(())
}

/// The tones, lowest frequency first (an insertion sort: K is 2 or 3).
fn ordered<const K: usize>(tones: &[Tone; K]) -> [Tone; K] {
    let mut t = *tones;
    for i in 1..K {
        let mut j = i;
        while j > 0 && t[j - 1].f_hz > t[j].f_hz {
            t.swap(j - 1, j);
            j -= 1;
        }
    }
    t
}

/// Gauss–Newton in (ln R, ln C, tan δ) from `start` (R Ω, C F,
/// tan δ); `tones` lower first. With the film's σ_t = 0, tan δ stays at
/// t₀ and the normal equations are those of (ln R, ln C) alone.
fn refine<const K: usize>(
    inv: &Inverter,
    film: &Dielectric,
    tones: [Tone; K],
    start: [f32; 3],
) -> Result<Solution, InvertError> {
    let hi = tones[K - 1];
    let fitted = film.spread > 0.0;
    // The parameters as (R, C, tan δ): a step in ln R, ln C scales R and
    // C by e^d (no logarithm, and no exponential for a small step).
    let mut p = start;
    let mut fit = evaluate(inv, film, &tones, p)?;
    for _ in 0..ITERATIONS {
        let Some(d) = step(&fit, fitted) else {
            break;
        };
        // Never more than a factor e per step in R and C (the start is
        // close), nor more than 10⁻² in tan δ; a NaN step stays NaN, and
        // its evaluation fails.
        let clamp = |v: f32, m: f32| fmath::clamp(v, -m, m);
        let dc = [clamp(d[0], 1.0), clamp(d[1], 1.0), clamp(d[2], 1e-2)];
        let q = [p[0] * exp_step(dc[0]), p[1] * exp_step(dc[1]), p[2] + dc[2]];
        // The step's gain in χ² as the linearized model predicts it, dᵀ·Jᵀr
        // (d solves JᵀJ·d = Jᵀr): under 10⁻³, the step is taken without
        // evaluating the model again (a tracked line, 4 ms on, is there
        // after one step; χ², the covariance and the hidden bound are the
        // start's, within that gain).
        let gain = d[0] * fit.jtr[0] + d[1] * fit.jtr[1] + d[2] * fit.jtr[2];
        let unclamped = d[0] == dc[0] && d[1] == dc[1] && d[2] == dc[2];
        if (0.0..1e-3).contains(&gain) && unclamped {
            p = q;
            let chi2 = fit.chi2 - gain;
            fit.chi2 = fmath::max(chi2, 0.0);
            break;
        }
        // So is a larger step whose second-order term is known and small
        // (see `second_order`): χ² there to second order, the covariance
        // and the hidden bound the start's (its Jacobian, within |d| ≤
        // 0.03 relative).
        if unclamped {
            if let Some(chi2) = second_order(inv, &fit, &d, p[2], film) {
                p = q;
                fit.chi2 = chi2;
                break;
            }
        }
        let Ok(next) = evaluate(inv, film, &tones, q) else {
            break;
        };
        if next.chi2 > fit.chi2 {
            break;
        }
        // Converged when χ² gains under 10⁻³ (the parameters are within
        // 0.03σ of the optimum) or the step is below 10⁻⁶ in ln R and ln C.
        let done = fit.chi2 - next.chi2 < 1e-3 || (libm::fabsf(d[0]) < 1e-6 && libm::fabsf(d[1]) < 1e-6);
        (p, fit) = (q, next);
        if done {
            break;
        }
    }
    Ok(solution::<K>(hi.f_hz, p, &fit, fitted))
}

/// The [`Solution`] at parameters `p` (R, C, tan δ) with the fit `fit`
/// there, its x at the highest tone `hi_hz`: the covariance's σ of ln C
/// and the one-tone bounds from JᵀJ (tan δ among the parameters where it
/// is `fitted`). (Inlined: one function with [`refine`].)
#[inline(always)]
fn solution<const K: usize>(hi_hz: f32, p: [f32; 3], fit: &Evaluated<K>, fitted: bool) -> Solution {
    let (r, c) = (p[0], p[1]);
    let ai = inverse(&fit.jtj, fitted);
    let var_c = ai.map_or(f32::INFINITY, |m| m[1][1]);
    let (hidden_ln_c, tone_ln_c2) =
        ai.map_or((f32::INFINITY, [f32::INFINITY; 3]), |m| hidden(fit, &m, fitted));
    Solution {
        line: Line {
            r_ohm: r,
            c_farad: c,
            x: TAU * hi_hz * r * c,
            kappa: f32::NAN,
        },
        chi2: fit.chi2,
        sigma_ln_c: fmath::sqrt(var_c),
        loss_tangent: p[2],
        hidden_ln_c,
        tone_ln_c2,
        dof: (2 * K - 2) as f32,
    }
}

/// Each tone's misfit to `sol`'s line, in units of its noise: |Z − Z(line)|/σ
/// (the tone's share of χ², square-rooted), for `tones` as [`solve`] takes
/// them and `sol` a line of the film `d` (its fitted tan δ); an error where a
/// tone lies outside the model's range on that line. A fit that left a
/// tone out ([`Tone::sigma_ohm`] unbounded) says here how far that tone
/// is from the line of the others, once it is given its own σ.
pub fn misfits<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    tones: &[Tone; K],
    sol: &Solution,
) -> Result<[f32; K], InvertError> {
    check(tones)?;
    let p = [sol.line.r_ohm, sol.line.c_farad, sol.loss_tangent];
    let fit = evaluate(inv, d, tones, p)?;
    Ok(fit.res.map(|r| fmath::sqrt(r.norm_sqr())))
}

/// What one disturbance does to every tone of a fit at once, for the two
/// quadratures of its phasor: `[k][0]` the change of tone k's Z for a
/// unit in-phase disturbance, `[k][1]` for a unit quadrature one, Ω per
/// unit (its scale is free: [`hidden_along`] is a ratio). An interferer
/// at a given frequency leaks into every tone of a comb so, by the
/// leak of its sinusoid into each tone's bin.
pub type Spread<const K: usize> = [[Complex32; 2]; K];

/// The most C can be off (relative) per unit of the residual's share
/// (√χ² without noise), as [`Solution::hidden_ln_c`] for one tone, where
/// one disturbance spreads over every tone along one of `family` (each
/// a [`Spread`]): for a spread B (2K×2 real, weighted by the tones'
/// noise), a disturbance B·a moves ln C by bᵀ·a (b = Bᵀ·g, g = J·A⁻¹·e_C)
/// and leaves aᵀ·Q·a in χ² (Q = Bᵀ·(I − J·A⁻¹·Jᵀ)·B), so by at most
/// √(bᵀ·Q⁻¹·b) per √χ²; the family's worst. The tones' Jacobian is taken
/// afresh at `sol`'s line on the film `d` (`tones` in the order the
/// spreads give them). 0 for an empty family (or spreads of nothing),
/// ∞ where a spread is one the fit can follow whatever it reads (Q
/// singular), or the line is out of the model's range.
///
/// A one-tone error is a spread on one tone; an interferer near a tone
/// also leaks into its neighbours, and together they can hide more
/// behind χ² than either alone (an interferer a quarter bin below the
/// lowest tone: twice; any error shared by the two lowest tones: four
/// times; docs/accuracy.md).
pub fn hidden_along<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    tones: &[Tone; K],
    sol: &Solution,
    family: impl IntoIterator<Item = Spread<K>>,
) -> f32 {
    bound_along(
        inv,
        d,
        tones,
        sol,
        1.0,
        family.into_iter().map(|s| (s, f32::INFINITY)),
    )
}

/// The most ln C can be off where one disturbance spreads over the tones
/// along one of `family`, each a spread and the most its amplitude |a|
/// can be (in the spread's units; ∞: unbounded), and leaves at most
/// `share` of the residual (√χ²): for each spread the lesser of
/// [`hidden_along`]'s √(bᵀ·Q⁻¹·b)·`share` and |b|·most (b = Bᵀ·g: what
/// a unit amplitude moves ln C by, at most), the family's worst. An
/// amplitude bound comes from what else sees the disturbance: a
/// sinusoid that leaves part of itself in the residual is no larger
/// than that part allows. 0 for an empty family; ∞ as
/// [`hidden_along`].
pub fn bound_along<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    tones: &[Tone; K],
    sol: &Solution,
    share: f32,
    family: impl IntoIterator<Item = (Spread<K>, f32)>,
) -> f32 {
    let weights: [Complex32; 3] = core::array::from_fn(|k| {
        // (A tone left out, σ unbounded, weighs nothing.)
        let w = tones.get(k).map_or(0.0, |t| 1.0 / t.sigma_ohm);
        Complex32::new(w, 0.0)
    });
    let along = crate::spread::reach(inv, d, tones, sol).along(&weights);
    let mut worst = 0.0f32;
    for (spread, most) in family {
        let kernel: [[Complex32; 2]; 3] =
            core::array::from_fn(|k| spread.get(k).copied().unwrap_or_default());
        worst = fmath::max(worst, along.bound(&kernel, share, most));
        if worst == f32::INFINITY || worst.is_nan() {
            return f32::INFINITY;
        }
    }
    worst
}

/// Largest second-order term (in units of the noise, over all tones) of
/// a step taken without evaluating the model again: the point it reaches
/// is then within this many σ (in the parameters' joint, Mahalanobis,
/// sense) of where one more evaluation would put it.
const SECOND_ORDER_MAX: f32 = 0.03;

/// χ² after the Gauss–Newton step `d` (in ln R, ln C, tan δ) from `fit`,
/// to second order, where the step's second-order term is small enough
/// to take it without evaluating the model: `None` where it is not, or
/// where the model has no exact ζ'' (a ladder).
///
/// Tone k's weighted model m = ζ(x)·s + u(t)·(ζ' − ζ)·s, s ∝ 1/C,
/// x = ωRC, moves under the step by J·d + R with, to second order (a, b,
/// t the step in ln R, ln C, tan δ; σ = a + b the step in ln x; ζ, ζ',
/// ζ'' weighted by s; u'' = 1/(1 − j·t)² ≈ 1)
///
/// ```text
/// R = ½·(σ²·ζ'' − 2b·σ·ζ' + b²·ζ) + t·u'·(a·(ζ'' − ζ') + b·(ζ'' − 2ζ' + ζ)) + ½·t²·(ζ' − ζ)
/// ```
///
/// (the loss's own share of the ζ terms, u·R, is tan δ of them, and
/// u'' is 1 within 2·tan δ). The step lands off the linearized optimum by
/// A⁻¹·Jᵀ·R, at most ‖R‖ in σ (a projection), and the Jacobian's change
/// over the step moves it by about |d|·√χ² more (|d| = |a| + |b| + |t|):
/// both must be under [`SECOND_ORDER_MAX`]. χ² is
/// then Σ|r − J·d − R|² plus the prior's (t₀ − t − t_d)²/σ_t², exact in t.
fn second_order<const K: usize>(
    inv: &Inverter,
    fit: &Evaluated<K>,
    d: &[f32; 3],
    tan_d: f32,
    film: &Dielectric,
) -> Option<f32> {
    let [a, b, t] = *d;
    let big = libm::fabsf(a) + libm::fabsf(b) + libm::fabsf(t);
    let du = Dielectric::u(tan_d).1;
    let mut chi2 = 0.0;
    let mut rr = 0.0;
    for k in 0..K {
        let [d_r, d_c, d_t] = fit.cols[k];
        // ζ'·s = d_r, (ζ' − ζ)·s = d_c, u'·(ζ' − ζ)·s = d_t.
        let (z1, z0) = (d_r, d_r - d_c);
        let (x, inv_scale) = fit.at[k];
        let z2 = inv.curvature(x, z0 * inv_scale, z1 * inv_scale)? / inv_scale;
        let sg = a + b;
        let mut r2 = (z2 * (sg * sg) - z1 * (2.0 * b * sg) + z0 * (b * b)) * 0.5;
        if t != 0.0 {
            r2 = r2 + du * ((z2 - z1) * a + (z2 - z1 * 2.0 + z0) * b) * t + d_c * (0.5 * t * t);
        }
        rr += r2.norm_sqr();
        let moved = fit.res[k] - (d_r * a + d_c * b + d_t * t) - r2;
        chi2 += moved.norm_sqr();
    }
    let ok =
        rr <= SECOND_ORDER_MAX * SECOND_ORDER_MAX && big * fmath::sqrt(fit.chi2 + 1.0) <= SECOND_ORDER_MAX;
    if !ok {
        return None;
    }
    if film.spread > 0.0 {
        let prior = fit.prior - t / film.spread;
        chi2 += prior * prior;
    }
    Some(chi2)
}

/// e^d for a Gauss–Newton step d in ln R or ln C: below 1/16 in size
/// by its Taylor series to d⁵ (what it leaves, d⁶/720 < 10⁻¹⁰, is far
/// below f32's rounding), `expf` beyond.
#[inline]
fn exp_step(d: f32) -> f32 {
    if d > -1.0 / 16.0 && d < 1.0 / 16.0 {
        1.0 + d * (1.0 + d * (0.5 + d * (1.0 / 6.0 + d * (1.0 / 24.0 + d * (1.0 / 120.0)))))
    } else {
        libm::expf(d)
    }
}

/// The most C can be off, relative, per unit of √χ², when what the model
/// lacks perturbs one tone alone (an interferer near it or at its alias,
/// a disturbance the residual check lets through): for tone k with
/// weighted Jacobian J_k (2×3 real) and A = JᵀJ (the prior's row in it),
/// a perturbation ε of tone k moves ln C by g·ε, g = J_k·A⁻¹·e_C, and
/// leaves εᵀ(I − J_k·A⁻¹·J_kᵀ)·ε in χ², so at most √(gᵀ·M⁻¹·g) per √χ²
/// (M = I − J_k·A⁻¹·J_kᵀ); the worse tone. ∞ where A or M is singular
/// (a tone that the fit can follow whatever it reads). With it, each
/// tone's |g|² ([`Solution::tone_ln_c2`]).
fn hidden<const K: usize>(fit: &Evaluated<K>, ai: &[[f32; 3]; 3], fitted: bool) -> (f32, [f32; 3]) {
    let mut worst = 0.0f32;
    let mut each = [if K > 3 { f32::INFINITY } else { 0.0 }; 3];
    for (k, cols) in fit.cols.iter().enumerate() {
        // J_k's two real rows.
        let mut rows = [
            [cols[0].re, cols[1].re, cols[2].re],
            [cols[0].im, cols[1].im, cols[2].im],
        ];
        if !fitted {
            rows[0][2] = 0.0;
            rows[1][2] = 0.0;
        }
        let times = |m: &[[f32; 3]; 3], v: &[f32; 3]| -> [f32; 3] {
            core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
        };
        let dot = |u: &[f32; 3], v: &[f32; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        // g = J_k·A⁻¹·e_C: A⁻¹'s column for ln C.
        let col_c = [ai[0][1], ai[1][1], ai[2][1]];
        let g = [dot(&rows[0], &col_c), dot(&rows[1], &col_c)];
        if K <= 3 {
            if let Some(e) = each.get_mut(k) {
                *e = g[0] * g[0] + g[1] * g[1];
            }
        }
        // M = I − J_k·A⁻¹·J_kᵀ.
        let w = [times(ai, &rows[0]), times(ai, &rows[1])];
        let m = [
            [1.0 - dot(&rows[0], &w[0]), -dot(&rows[0], &w[1])],
            [-dot(&rows[1], &w[0]), 1.0 - dot(&rows[1], &w[1])],
        ];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        if !positive_finite(det) {
            return (f32::INFINITY, [f32::INFINITY; 3]);
        }
        // gᵀ·M⁻¹·g.
        let q = (m[1][1] * g[0] * g[0] - (m[0][1] + m[1][0]) * g[0] * g[1] + m[0][0] * g[1] * g[1]) / det;
        // (A NaN q is passed over.)
        worst = fmath::max(worst, q);
    }
    (fmath::sqrt(worst), each)
}

/// The inverse of a 3×3 matrix by its cofactors; `None` when singular.
fn inverse3(m: &[[f32; 3]; 3]) -> Option<[[f32; 3]; 3]> {
    let det = det3(m);
    if !(det.is_finite() && det != 0.0) {
        return None;
    }
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    // (A⁻¹)_ij = C_ji / det.
    Some(core::array::from_fn(|i| core::array::from_fn(|j| c(j, i) / det)))
}

/// The Gauss–Newton step of the normal equations A·d = g, over
/// (ln R, ln C) or, with the loss `fitted`, (ln R, ln C, tan δ) (by
/// Cramer's rule; A symmetric positive definite at a fit that
/// constrains its parameters); `None` when A is singular.
fn step<const K: usize>(fit: &Evaluated<K>, fitted: bool) -> Option<[f32; 3]> {
    let (a, g) = (&fit.jtj, &fit.jtr);
    if !fitted {
        let det = a[0] * a[3] - a[1] * a[1];
        if !positive_finite(det) {
            return None;
        }
        return Some([
            (a[3] * g[0] - a[1] * g[1]) / det,
            (a[0] * g[1] - a[1] * g[0]) / det,
            0.0,
        ]);
    }
    let m = full(a);
    let det = det3(&m);
    if !positive_finite(det) {
        return None;
    }
    let col = |k: usize| {
        let mut mk = m;
        for (row, gv) in mk.iter_mut().zip(g) {
            row[k] = *gv;
        }
        det3(&mk) / det
    };
    Some([col(0), col(1), col(2)])
}

/// A⁻¹ over the fitted parameters (tan δ held: its row and column out,
/// 1 on the diagonal); `None` when A is singular.
pub(crate) fn inverse(a: &[f32; 6], fitted: bool) -> Option<[[f32; 3]; 3]> {
    let mut m = full(a);
    if !fitted {
        m[0][2] = 0.0;
        m[1][2] = 0.0;
        m[2][0] = 0.0;
        m[2][1] = 0.0;
        m[2][2] = 1.0;
    }
    inverse3(&m).filter(|m| m[0][0] > 0.0 && m[1][1] > 0.0)
}

/// The symmetric 3×3 matrix of its upper triangle [a₀₀, a₀₁, a₀₂, a₁₁,
/// a₁₂, a₂₂].
pub(crate) fn full(a: &[f32; 6]) -> [[f32; 3]; 3] {
    [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]]
}

fn det3(m: &[[f32; 3]; 3]) -> f32 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// χ², JᵀJ (symmetric, its upper triangle [a₀₀, a₀₁, a₀₂, a₁₁, a₁₂,
/// a₂₂]) and Jᵀr (r = measured − model, weighted by the noise) at
/// p = (ln R, ln C, tan δ): the film's loss u = ln(1 − j·tan δ) in the
/// model to first order (the R and C columns of the Jacobian left
/// lossless: an O(tan δ) change of the step, not of where it converges),
/// and the film's prior as a fifth residual. (`evaluate` takes
/// p = (R Ω, C F, tan δ).)
#[derive(Clone, Copy)]
pub(crate) struct Evaluated<const K: usize> {
    chi2: f32,
    pub(crate) jtj: [f32; 6],
    jtr: [f32; 3],
    /// Each tone's weighted derivatives in (ln R, ln C, tan δ).
    pub(crate) cols: [[Complex32; 3]; K],
    /// Each tone's weighted residual r.
    res: [Complex32; K],
    /// Each tone's x and 1/weight (ωCσ: ζ = model·ωCσ), for ζ''
    /// ([`second_order`]) where a step needs it.
    at: [(f32, f32); K],
    /// The film prior's residual (t₀ − t)/σ_t, 0 without the prior.
    prior: f32,
}

#[inline(always)]
pub(crate) fn evaluate<const K: usize>(
    inv: &Inverter,
    film: &Dielectric,
    tones: &[Tone; K],
    p: [f32; 3],
) -> Result<Evaluated<K>, InvertError> {
    let [r, c, t] = p;
    let (u, du) = Dielectric::u(t);
    // Each tone's x, ζ and ζ' first, then its columns and residual, each
    // array built whole (a zeroed `Evaluated` filled in place made the
    // compiler clear its 41 words on every call); the first tone out of
    // the model's range is the error.
    let at: [(f32, f32); K] = core::array::from_fn(|n| {
        let w = TAU * tones[n].f_hz;
        (w * r * c, w * c * tones[n].sigma_ohm)
    });
    let mut zs = [(Complex32::new(0.0, 0.0), Complex32::new(0.0, 0.0)); K];
    for (z, &(x, _)) in zs.iter_mut().zip(&at) {
        *z = inv.zeta_slope_at(x)?;
    }
    // Weighted derivatives in ln R, ln C and tan δ.
    let cols: [[Complex32; 3]; K] = core::array::from_fn(|n| {
        let (zeta, dz) = zs[n];
        let scale = 1.0 / at[n].1;
        let d_c = (dz - zeta) * scale;
        [dz * scale, d_c, du * d_c]
    });
    let res: [Complex32; K] = core::array::from_fn(|n| {
        let scale = 1.0 / at[n].1;
        let model = zs[n].0 * scale + u * cols[n][1];
        tones[n].z / tones[n].sigma_ohm - model
    });
    let mut e = Evaluated {
        chi2: 0.0,
        jtj: [0.0; 6],
        jtr: [0.0; 3],
        cols,
        res,
        at,
        prior: 0.0,
    };
    let dot = |a: Complex32, b: Complex32| a.re * b.re + a.im * b.im;
    for (cols, &res) in cols.iter().zip(&res) {
        e.chi2 += res.norm_sqr();
        let mut k = 0;
        for i in 0..3 {
            e.jtr[i] += dot(cols[i], res);
            for j in i..3 {
                e.jtj[k] += dot(cols[i], cols[j]);
                k += 1;
            }
        }
    }
    if film.spread > 0.0 {
        // The prior: (t₀ − t)/σ_t, its derivative in t 1/σ_t.
        let res = (film.loss_tangent - t) / film.spread;
        let d = 1.0 / film.spread;
        e.chi2 += res * res;
        e.prior = res;
        e.jtj[5] += d * d;
        e.jtr[2] += d * res;
    }
    if e.chi2.is_finite() {
        Ok(e)
    } else {
        Err(InvertError::OutOfRange)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flag_of_two_tones_is_the_closed_form() {
        for dof in [5, 20, 89, 1000] {
            let (a, b) = (chi2_flag(1e-4, dof), chi2_flag_of(1e-4, 2, dof));
            assert!((a / b - 1.0).abs() < 1e-4, "{dof}: {a} {b}");
        }
    }

    #[test]
    fn the_flag_of_three_tones_tends_to_chi_squared_with_four_degrees() {
        // χ²₄ tail: e^(−χ²/2)·(1 + χ²/2) = 10⁻⁴ at χ² = 23.513 (tables).
        let big = chi2_flag_of(1e-4, 3, 100_000);
        assert!((big - 23.513).abs() < 0.05, "{big}");
        // 4·F(4, 89) at 10⁻⁴: 26.581 (the F density integrated
        // numerically in f64).
        let block = chi2_flag_of(1e-4, 3, 89);
        assert!((block - 26.581).abs() < 0.02, "{block}");
    }
}
