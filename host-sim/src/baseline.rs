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
pub use crate::numerics::noise_sigma;
use crate::numerics::quadratic_fit;
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
