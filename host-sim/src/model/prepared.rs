//! A data set prepared for fast model evaluation, and its predictions.

use super::search::Search;
use super::{has_time, timed::timed, Averaging, Line, Model, Params, Shape};
use crate::dataset::{DataSet, Kind, Table};
use crate::numerics::quadratic_fit;
use anyhow::Result;

use super::file::file_of;
pub use super::file::{File, MIN_TRACE_ROWS};

/// The most rows of one trace a model is evaluated on: a longer trace is
/// decimated to every k-th row (k = ⌈rows / this⌉), which bounds the
/// work of `identify` whatever the recording's length. Its effect: the
/// time effects are resolved to k sampling intervals (the meter window is
/// averaged over k-times sparser samples), and the statistics count the
/// rows kept; the noise floor (from second differences) is that of the
/// rows kept, which for white noise is the same.
pub const MAX_TRACE_ROWS: usize = 4000;

/// A data set prepared for fast model evaluation.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Static curves.
    pub shape: Shape,
    /// The static calibration.
    calibration: Table,
    /// Files whose residual is modelled: the traces, then the sweep.
    pub files: Vec<File>,
    /// The ranges searched on these data (the time effects' scaled to the
    /// traces).
    pub search: Search,
}

impl Prepared {
    /// Prepare `ds`; the sweep is modelled too when `sweep` is set.
    pub fn new(ds: &DataSet, sweep: bool) -> Result<Self> {
        Self::with_max_rows(ds, sweep, MAX_TRACE_ROWS)
    }

    /// [`Prepared::new`] with each trace decimated to at most `max_rows`
    /// rows (at least [`MIN_TRACE_ROWS`]): `identify` scans its grids on
    /// such a coarse copy and refines on the full one.
    pub fn with_max_rows(ds: &DataSet, sweep: bool, max_rows: usize) -> Result<Self> {
        for t in &ds.traces {
            anyhow::ensure!(
                t.rows.len() >= MIN_TRACE_ROWS,
                "{}: {} rows; a trace needs at least {MIN_TRACE_ROWS} to be modelled (noise floor, time effects)",
                t.path.display(),
                t.rows.len()
            );
        }
        let search = Search::of(&ds.traces);
        let mut files: Vec<File> = ds.traces.iter().map(|t| file_of(t, max_rows, &search)).collect();
        if let (true, Some(sw)) = (sweep, &ds.sweep) {
            files.push(file_of(sw, max_rows, &search));
        }
        Ok(Self {
            search,
            shape: Shape::from_calibration(&ds.calibration)?,
            calibration: ds.calibration.clone(),
            files,
        })
    }

    /// C(s) = c0 + c1·s + c2·s² (F) from the calibration de-biased under
    /// `m` ([`crate::baseline::debiased_points`] with `m.cs`).
    pub fn calibrate(&self, m: &Model) -> Result<[f64; 3]> {
        let what = format!("{} with {:?}", m.line, m.params);
        let pts = crate::baseline::debiased_points(&self.calibration, &what, |r, c| {
            m.cs(r.r_rec(), c, r.stretch_mm(), r.freq_hz())
        })?;
        Ok(quadratic_fit(&pts))
    }

    /// Predicted Cs (pF) of every row of every file under `line` and
    /// `params`, after de-biasing the calibration under the same model; a
    /// meter that averages the admittance.
    pub fn predict(&self, line: Line, params: Params) -> Result<Vec<Vec<f64>>> {
        self.predict_as(line, params, Averaging::Admittance)
    }

    /// [`Prepared::predict`] with the meter's `averaging` domain.
    pub fn predict_as(&self, line: Line, params: Params, averaging: Averaging) -> Result<Vec<Vec<f64>>> {
        self.with_model(line, params, |at| {
            self.files
                .iter()
                .map(|file| {
                    if file.kind == Kind::Trace && has_time(&params) {
                        timed(file, &params, averaging, at)
                    } else {
                        (0..file.cs.len())
                            .map(|k| {
                                at(file.r[k], file.s[k], file.f[k])
                                    .map_or(f64::NAN, |z| Model::series(z, file.f[k]) * 1e12)
                            })
                            .collect()
                    }
                })
                .collect()
        })
    }

    /// Static Cs (pF) under `line` and `params` at arbitrary points
    /// (recorded R Ω, stretch mm, frequency Hz): what a sweep there would
    /// read, the calibration de-biased under the same model.
    pub fn predict_points(&self, line: Line, params: Params, points: &[(f64, f64, f64)]) -> Result<Vec<f64>> {
        self.with_model(line, params, |at| {
            points
                .iter()
                .map(|&(r, s, f)| at(r, s, f).map_or(f64::NAN, |z| Model::series(z, f) * 1e12))
                .collect()
        })
    }

    /// The model of `line` and `params` on this data set's shape (the
    /// local one under a nonuniform stretch), its C(s) from the
    /// calibration de-biased under it, handed to `use_it` as the
    /// impedance at (recorded R, stretch, frequency).
    fn with_model<T>(
        &self,
        line: Line,
        params: Params,
        use_it: impl FnOnce(&dyn Fn(f64, f64, f64) -> Option<num_complex::Complex64>) -> T,
    ) -> Result<T> {
        let stretched = params.stretched();
        let mut local = stretched.then(|| self.shape.local(&params));
        // The calibration's raw Cs carries the line's bias, which grows
        // with R along the stretch: the local C(s) is un-averaged from the
        // de-biased curve instead (once: the bias under the refined shape
        // moves it by far less). Rig-sim, an exponential stretch profile:
        // 0.25 → 0.08 pF at 30 mm.
        if let Some(sh) = &local {
            let m0 = Model::new(line, params, sh);
            let c = self.calibrate(&m0)?;
            local = Some(self.shape.with_c(c).local(&params));
        }
        let m = Model::new(line, params, local.as_ref().unwrap_or(&self.shape));
        let [a, b, c2] = self.calibrate(&m)?;
        let cap = |s: f64| a + s * (b + s * c2);
        let at = |r: f64, s: f64, f: f64| m.impedance(r, cap(s), s, f);
        Ok(use_it(&at))
    }

    /// The calibration's points: (recorded R Ω, stretch mm).
    pub fn calibration_points(&self) -> Vec<(f64, f64)> {
        self.calibration
            .rows
            .iter()
            .map(|r| (r.r_rec(), r.stretch_mm()))
            .collect()
    }
}
