//! The sensor's own static curves, from its calibration.

use crate::dataset::Table;
use crate::numerics::{hermite, quadratic_fit, tangent};
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
    /// [`crate::numerics::interp`]'s tangent at each point (no corners:
    /// the same on both sides), Ω/mm.
    rm: Vec<f64>,
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
        let rm = (0..if n > 1 { n } else { 0 })
            .map(|i| tangent(&rs, &rr, &[], i, i + 1 < n))
            .collect();
        Self {
            rm,
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
    /// v²/5 for the modes, which are orthogonal; with a bump or a bulge
    /// of another power than the parabola's, by the midpoint rule on 512
    /// points). R: fixed-point iteration
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
        let power = p.get(Effect::BulgePower);
        let parabola = power == 0.0 || power == 1.0 || v == 0.0;
        let mean_sq = if p.has(Effect::StretchBump) || !parabola {
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
        } else if n == 1 || s <= t[0] {
            self.rr[0]
        } else if s >= t[n - 1] {
            self.rr[n - 1]
        } else {
            // `interp` with the tangents computed once.
            let k = t.partition_point(|&v| v <= s).clamp(1, n - 1) - 1;
            hermite(t, &self.rr, k, (self.rm[k], self.rm[k + 1]), s)
        };
        v.max(0.05 * self.top)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::interp;

    /// [`Shape::r_at`] with its tangents computed once is
    /// [`interp`] inside the calibration, to the bit, on uneven points.
    #[test]
    fn r_at_is_interp_inside_the_calibration() {
        let r: Vec<(f64, f64)> = [0.0, 1.5, 4.0, 9.0, 15.0, 16.0, 22.0, 30.0]
            .iter()
            .map(|&s: &f64| (s, 711e3 - 3e3 * s + 0.4e3 * s * s - 30.0 * s.powi(3) / 3.0))
            .collect();
        for pts in [&r[..], &r[..2], &r[..3]] {
            let sh = Shape::new([210.0, 2.1, 0.0], pts.to_vec());
            let (t, y): (Vec<f64>, Vec<f64>) = pts.iter().copied().unzip();
            let top = pts.last().unwrap().0;
            for k in 0..=600 {
                let s = top * k as f64 / 600.0;
                let want = interp(&t, &y, &[], s).max(0.05 * sh.top);
                assert_eq!(
                    sh.r_at(s).to_bits(),
                    want.to_bits(),
                    "{} points, {s} mm",
                    pts.len()
                );
            }
        }
    }
}
