//! The sensor's own static curves, from its calibration.

use crate::dataset::Table;
use crate::numerics::{interp, quadratic_fit};
use anyhow::{bail, Result};

/// The sensor's own static curves, from the calibration: the shape of
/// C(s) and R(s) along a nonuniformly stretched sensor.
#[derive(Clone, Debug)]
pub struct Shape {
    /// Raw C(s) quadratic (any unit: only ratios are used).
    pub(crate) c: [f64; 3],
    /// (stretch mm, R_top + R_bottom Ω), ascending.
    pub(crate) r: Vec<(f64, f64)>,
    /// `r`'s stretches and resistances apart, its end quadratics (the
    /// four points at each end) and its largest R: what [`Shape::r_at`]
    /// needs on every call, computed once.
    rs: Vec<f64>,
    rr: Vec<f64>,
    below: [f64; 3],
    above: [f64; 3],
    top: f64,
}

impl Shape {
    /// From a calibration table (at least two stretch points).
    pub fn from_calibration(cal: &Table) -> Result<Self> {
        let mut pts: Vec<(f64, f64)> = cal.rows.iter().map(|r| (r.stretch_mm(), r.cs_pf())).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 3 {
            bail!(
                "{}: a calibration needs at least three stretch points",
                cal.path.display()
            );
        }
        let mut r: Vec<(f64, f64)> = cal.rows.iter().map(|x| (x.stretch_mm(), x.r_rec())).collect();
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(Self::new(quadratic_fit(&pts), r))
    }

    /// From the C(s) quadratic and the R(s) points (at least one,
    /// ascending in stretch).
    pub(crate) fn new(c: [f64; 3], r: Vec<(f64, f64)>) -> Self {
        let n = r.len();
        let (rs, rr): (Vec<f64>, Vec<f64>) = r.iter().copied().unzip();
        Self {
            c,
            below: quadratic_fit(&r[..n.min(4)]),
            above: quadratic_fit(&r[n.saturating_sub(4)..]),
            top: rr.iter().copied().fold(0.0, f64::max),
            rs,
            rr,
            r,
        }
    }

    /// The local curves of a sensor stretched nonuniformly, with the
    /// profile φ(ξ) of `p` (`EffectSet::stretch_profile`: linear mode u,
    /// symmetric mode v): the calibration recorded each curve's mean along
    /// the sensor, so the local ones are found by undoing that mean. C:
    /// exact for the quadratic (c2 → c2/mean φ², mean φ² = 1 + u²/3 +
    /// v²/5 for the modes, which are orthogonal; with a bump, by the
    /// midpoint rule on 512 points). R: fixed-point iteration
    /// ρ ← ρ·R_cal/mean_ξ ρ(s·φ(ξ)) at the calibration points, R_cal the
    /// film's (the recorded totals less the contacts of `p`).
    pub fn local(&self, p: &crate::model::Params) -> Shape {
        use crate::model::Effect;
        let (u, v) = (p.get(Effect::NonuniformStretch), p.get(Effect::StretchBulge));
        // The film's own R(s): the recorded totals less the tabs' contacts
        // (R_el = R_rec − 4·R_c), which do not stretch.
        let rc4 = 4.0 * p.get(Effect::ContactResistance);
        let film: Vec<(f64, f64)> = self
            .r
            .iter()
            .map(|&(s, r)| (s, (r - rc4).max(1e-3 * r)))
            .collect();
        let [a, b, c2] = self.c;
        let mean_sq = if p.has(Effect::StretchBump) {
            const M: usize = 512;
            (0..M)
                .map(|i| p.stretch_profile((i as f64 + 0.5) / M as f64).powi(2))
                .sum::<f64>()
                / M as f64
        } else {
            1.0 + u * u / 3.0 + v * v / 5.0
        };
        let mut out = Shape::new([a, b, c2 / mean_sq], film.clone());
        for _ in 0..6 {
            let next: Vec<(f64, f64)> = film
                .iter()
                .zip(&out.r)
                .map(|(&(s, r_cal), &(_, rho))| {
                    const K: usize = 32;
                    let mean = (0..K)
                        .map(|i| out.r_at(s * p.stretch_profile((i as f64 + 0.5) / K as f64)))
                        .sum::<f64>()
                        / K as f64;
                    (s, rho * r_cal / mean)
                })
                .collect();
            out = Shape::new(out.c, next);
        }
        out
    }

    /// The same R(s) with the C(s) quadratic `c` (any unit).
    pub fn with_c(&self, c: [f64; 3]) -> Shape {
        Shape::new(c, self.r.clone())
    }

    pub(crate) fn c_at(&self, s: f64) -> f64 {
        let [a, b, c] = self.c;
        (a + s * (b + s * c)).max(1e-9 * a.abs())
    }

    /// Static R at `s`: Akima through the calibration points inside
    /// their range; outside it, the least-squares quadratic through the
    /// four end points (the curve's smooth continuation); at least 5 % of
    /// the largest.
    pub(crate) fn r_at(&self, s: f64) -> f64 {
        let (t, n) = (&self.rs, self.rs.len());
        let v = if s < t[0] {
            let q = self.below;
            q[0] + s * (q[1] + s * q[2])
        } else if s > t[n - 1] {
            let q = self.above;
            q[0] + s * (q[1] + s * q[2])
        } else {
            interp(t, &self.rr, &[], s)
        };
        v.max(0.05 * self.top)
    }
}
