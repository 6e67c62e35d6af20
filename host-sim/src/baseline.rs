//! The baseline model of a measured data set (the paper's simulation, done
//! right): C(stretch) from the static calibration with the calibration's
//! own low-frequency bias taken out, R = R_top + R_bottom as recorded, the
//! uniform line, read as a series meter would; and the residual
//! (measured − model) with an estimate of the noise floor.
//!
//! De-biasing: the calibration's Cs was read by a series meter at a finite
//! frequency through the recorded resistances, so each point's true C
//! solves Cs_model(R, C, f) = Cs_measured (a fixed-point iteration on the
//! ratio Cs/C, which is smooth and close to 1).

use crate::dataset::{DataSet, Row, Table};
use anyhow::{bail, Result};
use dsp_core::lumped::SeriesRc;
use dsp_core::tline::LineModel;

/// What a series meter reads on line R (Ω), C (F) at f (Hz), F.
pub fn series_cs(model: LineModel, r: f64, c: f64, f: f64) -> Option<f64> {
    let z = model.impedance(r as f32, c as f32, f as f32).ok()?;
    SeriesRc::from_impedance(z, f as f32)
        .ok()
        .map(|m| m.cs_farad as f64)
}

/// The calibration's (stretch mm, true C F) points: each C solves
/// `series(row, C) = Cs measured` for the row's recorded R, stretch and
/// frequency (fixed-point iteration on the ratio Cs/C, smooth and close to
/// 1), where `series` is what the meter reads (F) under the model named
/// `what`.
pub fn debiased_points(
    cal: &Table,
    what: &str,
    series: impl Fn(&Row, f64) -> Option<f64>,
) -> Result<Vec<(f64, f64)>> {
    let mut points = vec![];
    for r in &cal.rows {
        let cs = r.cs_pf() * 1e-12;
        let mut c = cs;
        for _ in 0..40 {
            match series(r, c) {
                Some(m) if m.is_finite() && m > 0.0 => c *= cs / m,
                _ => bail!(
                    "{}:{}: the model ({what}) cannot explain this point",
                    cal.path.display(),
                    r.line
                ),
            }
        }
        points.push((r.stretch_mm(), c));
    }
    Ok(points)
}

/// The baseline model.
#[derive(Clone, Debug)]
pub struct Baseline {
    /// Line model.
    pub model: LineModel,
    /// (stretch mm, true C F), ascending in stretch.
    pub points: Vec<(f64, f64)>,
    /// C(s) = c0 + c1·s + c2·s², least squares through `points` (F, F/mm,
    /// F/mm²): a smooth curve averages the calibration meter's noise
    /// instead of passing it on point by point.
    pub fit: [f64; 3],
}

impl Baseline {
    /// From a calibration table; `debias` takes the meter's own bias out.
    pub fn from_calibration(cal: &Table, model: LineModel, debias: bool) -> Result<Self> {
        let points = if debias {
            debiased_points(cal, &format!("{model:?}"), |r, c| {
                series_cs(model, r.r_rec(), c, r.freq_hz())
            })?
        } else {
            cal.rows
                .iter()
                .map(|r| (r.stretch_mm(), r.cs_pf() * 1e-12))
                .collect()
        };
        if points.len() < 3 {
            bail!(
                "{}: a calibration needs at least three stretch points",
                cal.path.display()
            );
        }
        Ok(Self {
            model,
            ..Self::from_points(points)?
        })
    }

    /// From (stretch mm, true C F) points (at least three), continuous line.
    pub fn from_points(mut points: Vec<(f64, f64)>) -> Result<Self> {
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        if points.len() < 3 {
            bail!("a calibration needs at least three stretch points");
        }
        let fit = quadratic_fit(&points);
        Ok(Self {
            model: LineModel::Continuous,
            points,
            fit,
        })
    }

    /// True C (F) at `stretch` mm, from the quadratic fit.
    pub fn capacitance(&self, stretch: f64) -> f64 {
        let [a, b, c] = self.fit;
        a + stretch * (b + stretch * c)
    }

    /// Predicted Cs (pF) of a trace row.
    pub fn predict_pf(&self, row: &Row) -> f64 {
        let c = self.capacitance(row.stretch_mm());
        series_cs(self.model, row.r_rec(), c, row.freq_hz()).map_or(f64::NAN, |cs| cs * 1e12)
    }
}

/// The residual of one trace.
#[derive(Clone, Debug)]
pub struct Residual {
    /// File name.
    pub file: String,
    /// Rows.
    pub n: usize,
    /// RMS of measured − model, pF.
    pub rms_pf: f64,
    /// Largest |measured − model|, pF.
    pub max_pf: f64,
    /// Noise floor, pF: the median absolute second difference of the
    /// residual, scaled to σ for Gaussian noise (×1.4826/√6). White noise
    /// passes, smooth model errors cancel, and sparse jumps (motion stops)
    /// do not move a median.
    pub noise_pf: f64,
}

/// Residuals of every trace of `ds` against `baseline`.
pub fn residuals(ds: &DataSet, baseline: &Baseline) -> Vec<Residual> {
    ds.traces
        .iter()
        .map(|t| {
            let e: Vec<f64> = t
                .rows
                .iter()
                .map(|r| r.cs_pf() - baseline.predict_pf(r))
                .collect();
            let n = e.len();
            let rms = (e.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            let max = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            Residual {
                file: t
                    .path
                    .file_name()
                    .map_or(String::new(), |f| f.to_string_lossy().into_owned()),
                n,
                rms_pf: rms,
                max_pf: max,
                noise_pf: noise_sigma(&e),
            }
        })
        .collect()
}

/// Robust noise σ of a residual series (its unit): the median absolute
/// second difference ×1.4826/√6. White noise passes, smooth model errors
/// cancel, and sparse jumps do not move a median.
pub fn noise_sigma(e: &[f64]) -> f64 {
    let mut d2: Vec<f64> = e.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs()).collect();
    d2.sort_by(f64::total_cmp);
    d2.get(d2.len() / 2).copied().unwrap_or(f64::NAN) * 1.4826 / 6f64.sqrt()
}

/// Least-squares c0 + c1·x + c2·x² through `pts` (normal equations,
/// centred and scaled for conditioning).
pub(crate) fn quadratic_fit(pts: &[(f64, f64)]) -> [f64; 3] {
    let n = pts.len() as f64;
    let xm = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let xs = pts
        .iter()
        .map(|p| (p.0 - xm).abs())
        .fold(0.0, f64::max)
        .max(1e-12);
    let ym = pts.iter().map(|p| p.1).sum::<f64>() / n;
    // Fit y − ym = a + b·u + c·u², u = (x − xm)/xs.
    let mut m = [[0.0f64; 4]; 3];
    for &(x, y) in pts {
        let u = (x - xm) / xs;
        let row = [1.0, u, u * u];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += row[i] * row[j];
            }
            m[i][3] += row[i] * (y - ym);
        }
    }
    // Gaussian elimination with partial pivoting.
    for col in 0..3 {
        let piv = (col..3)
            .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
            .unwrap_or(col);
        m.swap(col, piv);
        for r in 0..3 {
            if r != col && m[col][col] != 0.0 {
                let f = m[r][col] / m[col][col];
                let pivot = m[col];
                for (v, p) in m[r].iter_mut().zip(pivot).skip(col) {
                    *v -= f * p;
                }
            }
        }
    }
    let s = |i: usize| if m[i][i] != 0.0 { m[i][3] / m[i][i] } else { 0.0 };
    let (a, b, c) = (s(0), s(1), s(2));
    // Back to x: y = ym + a + b(x − xm)/xs + c(x − xm)²/xs².
    let (b1, c1) = (b / xs, c / (xs * xs));
    [ym + a - b1 * xm + c1 * xm * xm, b1 - 2.0 * c1 * xm, c1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_fit_recovers_an_exact_quadratic() {
        let f = |x: f64| 210e-12 + 2.1e-12 * x - 0.01e-12 * x * x;
        let pts: Vec<(f64, f64)> = (0..=10).map(|k| (3.0 * k as f64, f(3.0 * k as f64))).collect();
        let [a, b, c] = quadratic_fit(&pts);
        for x in [0.0, 7.5, 30.0] {
            let got = a + x * (b + x * c);
            assert!((got / f(x) - 1.0).abs() < 1e-12, "{x}: {got} vs {}", f(x));
        }
    }
}
