//! How a fit of up to three tones ([`crate::twotone`]) answers one
//! disturbance spread over them ([`crate::twotone::Spread`]): its
//! [`Reach`], taken at the fit's line, and the bound of one spread given
//! as a kernel times each tone's factor ([`Along::bound`]), which
//! [`crate::twotone::bound_along`] takes for whole spreads and the
//! array's channels for an interferer's (`instrument::spread`). Apart
//! from the solve: a record asks for it only once its line is fitted
//! and passed (and on a board it runs from flash, not from the fast RAM
//! the solve runs in).
//!
//! For a spread B (the tones' weighted changes, 2K×2 real, for a
//! disturbance's two quadratures a) a disturbance B·a moves ln C by bᵀ·a
//! (b = Bᵀ·g, g = J·A⁻¹·e_C) and leaves aᵀ·Q·a in χ²
//! (Q = BᵀB − (JᵀB)ᵀ·A⁻¹·JᵀB), J the fit's weighted Jacobian and
//! A = JᵀJ its normal matrix (the film's prior in it).

use crate::dielectric::Dielectric;
use crate::fmath::{self, positive_finite};
use crate::invert::Inverter;
use crate::twotone::{evaluate, full, inverse, Solution, Tone};
use crate::Complex32;

/// How a fit of up to three tones answers one disturbance spread over
/// them ([`crate::twotone::Spread`]), in the tones' weighted units (each tone's Z over
/// its σ): the fit's Jacobian and covariance at its line ([`reach`]);
/// NaN for a fit of more than three tones or without a covariance (no
/// bound: ∞).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reach {
    /// J: per tone (lowest first) the weighted Z's derivatives in ln R,
    /// ln C and tan δ (tan δ's 0 where the film's loss is held).
    pub jacobian: [[Complex32; 3]; 3],
    /// A⁻¹, the parameters' covariance (A = JᵀJ, the film's prior in
    /// it), its upper triangle [00, 01, 02, 11, 12, 22]; tan δ's row and
    /// column 0 where the loss is held.
    pub covariance: [f32; 6],
}

impl Reach {
    /// No reach: every bound from it is ∞.
    pub const NONE: Self = Self {
        jacobian: [[Complex32::new(f32::NAN, f32::NAN); 3]; 3],
        covariance: [f32::NAN; 6],
    };

    /// The reach for spreads given as a kernel times each tone's
    /// `factor` (a spread's tone k is factor_k·kernel_k, in units of the
    /// tone's σ: the factor takes the weight 1/σ_k): each tone's
    /// Jacobian and C's gradient g = J·A⁻¹·e_C turned by the factor
    /// once, so that a spread costs only its kernel's products
    /// ([`Along::bound`]).
    pub fn along(&self, factor: &[Complex32; 3]) -> Along {
        let c = &self.covariance;
        let col_c = [c[1], c[3], c[4]];
        Along {
            grad: core::array::from_fn(|k| {
                let j = &self.jacobian[k];
                (j[0] * col_c[0] + j[1] * col_c[1] + j[2] * col_c[2]).conj() * factor[k]
            }),
            jacobian: core::array::from_fn(|k| self.jacobian[k].map(|d| d.conj() * factor[k])),
            weight: factor.map(|f| f.norm_sqr()),
            covariance: full(c),
        }
    }
}

/// A [`Reach`] turned by each tone's factor ([`Reach::along`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Along {
    grad: [Complex32; 3],
    jacobian: [[Complex32; 3]; 3],
    weight: [f32; 3],
    covariance: [[f32; 3]; 3],
}

impl Along {
    /// The most ln C can be off where one disturbance spreads over the
    /// tones along factor_k·`kernel`_k (k the tone, `kernel[k][0]` for
    /// the disturbance's in-phase unit, `[1]` its quadrature's), with an
    /// amplitude of at most `most` and at most `share` of the residual
    /// (√χ²): the lesser of √(bᵀ·Q⁻¹·b)·share and |b|·most, as
    /// [`crate::twotone::bound_along`]; ∞ where the fit can follow the spread (Q
    /// singular) or a number is NaN; 0 for a spread of nothing.
    pub fn bound(&self, kernel: &[[Complex32; 2]; 3], share: f32, most: f32) -> f32 {
        self.bound_above(kernel, share, most, 0.0)
    }

    /// [`Along::bound`] where it exceeds `floor`; where the amplitude's
    /// bound |b|·`most` does not, that (at most `floor`), without the
    /// spread's χ² (what a search for the worst spread above a known
    /// bound spares).
    pub fn bound_above(&self, kernel: &[[Complex32; 2]; 3], share: f32, most: f32, floor: f32) -> f32 {
        // Re(a·b): the real dot product of conj(a) and b.
        let re = |a: Complex32, b: Complex32| a.re * b.re - a.im * b.im;
        let mut b = [0.0f32; 2];
        for (g, e) in self.grad.iter().zip(kernel) {
            b[0] += re(*g, e[0]);
            b[1] += re(*g, e[1]);
        }
        let b2 = b[0] * b[0] + b[1] * b[1];
        // (A spread that moves nothing bounds by 0.)
        let by_size = if b2 == 0.0 { 0.0 } else { fmath::sqrt(b2) * most };
        if by_size <= floor {
            return by_size;
        }
        let h2 = self.h2(kernel, b, b2);
        // (A spread that shows nothing bounds by 0.)
        let by_chi2 = if h2 == 0.0 { 0.0 } else { fmath::sqrt(h2) * share };
        let bound = if by_size < by_chi2 { by_size } else { by_chi2 };
        if bound.is_nan() {
            f32::INFINITY
        } else {
            bound
        }
    }

    /// bᵀ·Q⁻¹·b for one spread whose b = Bᵀ·g is `b` (|b|² `b2`): 0 for a
    /// spread of nothing, ∞ where Q is singular, or NaN.
    fn h2(&self, kernel: &[[Complex32; 2]; 3], b: [f32; 2], b2: f32) -> f32 {
        let re = |a: Complex32, b: Complex32| a.re * b.re - a.im * b.im;
        // Jᵀ·B (3×2) and Bᵀ·B (its upper triangle).
        let mut jb = [[0.0f32; 2]; 3];
        let mut bb = [0.0f32; 3];
        for ((e, jacobian), &w) in kernel.iter().zip(&self.jacobian).zip(&self.weight) {
            for (row, &d) in jb.iter_mut().zip(jacobian) {
                row[0] += re(d, e[0]);
                row[1] += re(d, e[1]);
            }
            bb[0] += w * e[0].norm_sqr();
            bb[1] += w * (e[0].re * e[1].re + e[0].im * e[1].im);
            bb[2] += w * e[1].norm_sqr();
        }
        if bb[0] + bb[2] == 0.0 {
            return 0.0;
        }
        // Q = BᵀB − (JᵀB)ᵀ·A⁻¹·JᵀB.
        let ai = &self.covariance;
        let u: [[f32; 2]; 3] = core::array::from_fn(|i| {
            core::array::from_fn(|q| ai[i][0] * jb[0][q] + ai[i][1] * jb[1][q] + ai[i][2] * jb[2][q])
        });
        let proj = |p: usize, q: usize| jb[0][p] * u[0][q] + jb[1][p] * u[1][q] + jb[2][p] * u[2][q];
        let q = [bb[0] - proj(0, 0), bb[1] - proj(0, 1), bb[2] - proj(1, 1)];
        let unbounded = if b2 == 0.0 { 0.0 } else { f32::INFINITY };
        // Quadratures along one line (a disturbance of one phase): the
        // larger one alone.
        let gram = bb[0] * bb[2] - bb[1] * bb[1];
        if !positive_finite(gram - 1e-6 * bb[0] * bb[2]) {
            let i = usize::from(bb[2] > bb[0]);
            let qi = q[2 * i];
            return if positive_finite(qi - 1e-6 * bb[2 * i]) {
                b[i] * b[i] / qi
            } else {
                unbounded
            };
        }
        // A spread the fit can follow leaves (next to) nothing in χ²: Q's
        // determinant at f32's rounding of BᵀB's.
        let det = q[0] * q[2] - q[1] * q[1];
        if !positive_finite(det - 1e-6 * gram) {
            return unbounded;
        }
        (q[2] * b[0] * b[0] - 2.0 * q[1] * b[0] * b[1] + q[0] * b[1] * b[1]) / det
    }
}

/// How the fit of `sol` to `tones` on the film `d` answers one
/// disturbance spread over them ([`Reach`]): the tones' Jacobian and the
/// covariance taken afresh at its line (one evaluation of the model);
/// [`Reach::NONE`] for more than three tones, a line out of the model's
/// range or a fit without a covariance.
pub fn reach<const K: usize>(inv: &Inverter, d: &Dielectric, tones: &[Tone; K], sol: &Solution) -> Reach {
    let p = [sol.line.r_ohm, sol.line.c_farad, sol.loss_tangent];
    let fitted = d.spread > 0.0;
    if K > 3 {
        return Reach::NONE;
    }
    let Ok(fit) = evaluate(inv, d, tones, p) else {
        return Reach::NONE;
    };
    let Some(ai) = inverse(&fit.jtj, fitted) else {
        return Reach::NONE;
    };
    let mut r = Reach {
        covariance: [ai[0][0], ai[0][1], ai[0][2], ai[1][1], ai[1][2], ai[2][2]],
        ..Reach::default()
    };
    if !fitted {
        r.covariance[5] = 0.0;
    }
    for (j, cols) in r.jacobian.iter_mut().zip(&fit.cols) {
        *j = *cols;
        if !fitted {
            j[2] = Complex32::new(0.0, 0.0);
        }
    }
    r
}
