//! The film between the electrodes: its dielectric loss, in the line.
//!
//! A real film loses a little of what it stores: its permittivity is
//! ε'·(1 − j·tan δ), tan δ ≈ 1–5·10⁻³ for silicone and 1–5·10⁻² for
//! acrylic films, so the line's C is C·(1 − j·tan δ) and, to first order
//! in u = ln(1 − j·tan δ),
//!
//! ```text
//! Z(R, C·(1 − j·tan δ)) = Z(R, C) + u·∂Z/∂ln C + O(u²)
//! ```
//!
//! (the O(u²) term is below 5·10⁻⁵ of |Z| for tan δ ≤ 10⁻²). A lossless
//! inversion of a lossy film's impedance reads the loss as line: at
//! x = ωRC = 5.5, tan δ = 10⁻³ moves C by 0.24 % and 10⁻² by 2.6 %.
//!
//! Two tones fit tan δ with the line ([`crate::twotone`]), the film's
//! [`Dielectric`] as its prior. One tone cannot: [`correct`] takes the
//! film's tan δ as its material gives it and removes its first-order
//! effect from a lossless inversion, and says how far C would move per
//! unit of tan δ, for the error bound of a film known only to its spread.

use crate::invert::{InvertError, Inverter, Line};
use crate::Complex32;
use core::f32::consts::TAU;

/// What the fit assumes of the film between the electrodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// The film's loss tangent tan δ as its material gives it (0:
    /// lossless): the two-tone fit's prior mean t₀.
    pub loss_tangent: f32,
    /// 1σ of the film's tan δ about `loss_tangent`: the two-tone fit's
    /// prior σ_t (0 holds tan δ at `loss_tangent`), and a single tone's
    /// error bound.
    pub spread: f32,
}

impl Dielectric {
    /// A lossless film, exactly: the fit of the bare line.
    pub const IDEAL: Self = Self {
        loss_tangent: 0.0,
        spread: 0.0,
    };

    /// A silicone film (the paper's, and most DE sensors'): tan δ =
    /// 3·10⁻³ ± 1·10⁻³ (1σ): silicone elastomers measure 1–5·10⁻³ over
    /// 0.1–10 kHz at room temperature, with filler, stretch and
    /// temperature.
    pub const SILICONE: Self = Self {
        loss_tangent: 3e-3,
        spread: 1e-3,
    };
}

impl Dielectric {
    /// u = ln(1 − j·tan δ) and ∂u/∂tan δ = −j/(1 − j·tan δ) at
    /// tan δ = `t`, by their series (arctan t = t − t³/3 + t⁵/5,
    /// ln(1 + t²)/2 = t²/2 − t⁴/4): within 2·10⁻⁷ for |t| ≤ 0.1, the
    /// loss tangents of real films, and no transcendental function linked
    /// into the firmware.
    pub fn u(t: f32) -> (Complex32, Complex32) {
        let t2 = t * t;
        let u = Complex32::new(t2 * (0.5 - 0.25 * t2), -t * (1.0 - t2 * (1.0 / 3.0 - 0.2 * t2)));
        (u, Complex32::new(t, -1.0) / (1.0 + t2))
    }
}

/// A lossless inversion's line with the film's loss taken out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corrected {
    /// The line on a film of tan δ = [`Dielectric::loss_tangent`].
    pub line: Line,
    /// |∂ ln C/∂ tan δ| at this line: how far C moves (relative) per unit
    /// of tan δ the film differs from the one assumed (within 10 %).
    pub dlnc_dtan: f32,
}

/// The line on film `d` behind a lossless inversion's `line` of one tone
/// at `f_hz` (its R, C and x; the inverter's model and leads). The
/// measured impedance is the lossless line's, Z₀ = ζ(x₀)/(ωC₀); the
/// lossy line (R, C) meets it where
///
/// ```text
/// F(ln R, ln C) = Z(R, C) + u·Z_C(R, C) − Z₀ = 0,   Z_R = ∂Z/∂ln R, Z_C = ∂Z/∂ln C
/// ```
///
/// solved by two Newton steps from the lossless line (F = u·Z_C there),
/// each a·Z_R + b·Z_C = −F for real a, b: the first is the first-order
/// correction, the second takes the error left near the peak of D (where
/// the first order's u² term is amplified) from 50·tan²δ of C to 3·10⁻⁵
/// for a silicone (tan δ ≤ 3·10⁻³) and 2·10⁻⁴ at tan δ = 10⁻² (tested to
/// x = 6). Declared for tan δ ≤ 10⁻²: an acrylic film's 2·10⁻² near the
/// peak of D needs the loss's own terms in the Jacobian (it is corrected
/// from 11 % to 4 % only), and two tones, which fit the loss, read it. An error where ζ is not defined or Z_R and
/// Z_C are parallel (exactly at the peak of D, where one tone cannot
/// tell R from C).
pub fn correct(inv: &Inverter, line: &Line, f_hz: f32, d: &Dielectric) -> Result<Corrected, InvertError> {
    let (u, du) = Dielectric::u(d.loss_tangent);
    let w = TAU * f_hz;
    // Impedances in Ω·(ωC₀): the measured one is ζ(x₀).
    let (c0, z0) = (line.c_farad, inv.zeta_at(line.x)?);
    let (mut ln_r, mut ln_c) = (0.0f32, 0.0f32);
    let mut dlnc_dtan = 0.0;
    for step in 0..2 {
        let x = line.x * libm::expf(ln_r + ln_c);
        let k = libm::expf(-ln_c);
        let (zeta, dz) = inv.zeta_slope_at(x)?;
        let (zr, zc) = (dz * k, (dz - zeta) * k);
        let det = zr.re * zc.im - zr.im * zc.re;
        if !(det.is_finite() && det != 0.0) {
            return Err(InvertError::OutOfRange);
        }
        // a·Z_R + b·Z_C = v for real a, b.
        let solve = |v: Complex32| {
            (
                (v.re * zc.im - v.im * zc.re) / det,
                (zr.re * v.im - zr.im * v.re) / det,
            )
        };
        let f = zeta * k + u * zc - z0;
        let (a, b) = solve(-f);
        ln_r += a;
        ln_c += b;
        if step == 1 {
            dlnc_dtan = libm::fabsf(solve(du * zc).1);
        }
    }
    let (r, c) = (line.r_ohm * libm::expf(ln_r), c0 * libm::expf(ln_c));
    Ok(Corrected {
        line: Line {
            r_ohm: r,
            c_farad: c,
            x: w * r * c,
            kappa: line.kappa,
        },
        dlnc_dtan,
    })
}
