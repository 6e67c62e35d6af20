//! Candidate effects the baseline model lacks, each a physical mechanism
//! with one fitted parameter, applied consistently to the calibration (which
//! was measured through the same tabs and cables) and to the traces.
//!
//! * `contact_resistance` R_c per tab: the recorded end-to-end electrode
//!   resistances each include two tabs, so the line has R_top + R_bottom −
//!   4·R_c, and the capacitance path adds 2·R_c in series.
//! * `parasitic_capacitance` C_p in parallel with the sensor at the meter.
//!
//! (More mechanisms, model selection and the `identify` report are the rest
//! of issue 5.)

use crate::baseline::residuals;
use crate::dataset::{DataSet, Row, Table};
use anyhow::Result;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// An effect and its parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Effect {
    /// The uniform line alone.
    None,
    /// Contact resistance of each tab, Ω.
    ContactResistance(f64),
    /// Parasitic capacitance at the meter, F.
    ParasiticCapacitance(f64),
}

/// Continuous-line impedance in f64 (Ω): √(R/(jωC))·coth √(jωRC).
fn line(r: f64, c: f64, w: f64) -> Complex64 {
    let g = Complex64::new(0.0, w * r * c).sqrt();
    r / (g * g.tanh())
}

impl Effect {
    /// The series Cs (F) a meter reads at `f` on a line of recorded
    /// electrode resistances `r_recorded` (top + bottom, Ω) and true `c` (F).
    pub fn series_cs(&self, r_recorded: f64, c: f64, f: f64) -> f64 {
        let w = TAU * f;
        let z = match *self {
            Effect::None => line(r_recorded, c, w),
            Effect::ContactResistance(rc) => line((r_recorded - 4.0 * rc).max(1.0), c, w) + 2.0 * rc,
            Effect::ParasiticCapacitance(cp) => {
                (line(r_recorded, c, w).inv() + Complex64::new(0.0, w * cp)).inv()
            }
        };
        -1.0 / (w * z.im)
    }

    /// The same effect with parameter `p`.
    pub fn with(&self, p: f64) -> Effect {
        match self {
            Effect::None => Effect::None,
            Effect::ContactResistance(_) => Effect::ContactResistance(p),
            Effect::ParasiticCapacitance(_) => Effect::ParasiticCapacitance(p),
        }
    }
}

/// C(stretch) from the calibration under `effect`: each point's true C
/// solves effect.series_cs(R, C, f) = Cs measured; least-squares quadratic.
pub fn calibrate(cal: &Table, effect: Effect) -> Result<crate::baseline::Baseline> {
    let points = crate::baseline::debiased_points(cal, &format!("{effect:?}"), |r, c, f| {
        Some(effect.series_cs(r, c, f))
    })?;
    crate::baseline::Baseline::from_points(points)
}

/// Residual RMS (pF) over all traces under `effect`.
pub fn residual_rms(ds: &DataSet, effect: Effect) -> Result<f64> {
    let b = calibrate(&ds.calibration, effect)?;
    let (mut ss, mut n) = (0.0, 0usize);
    for t in &ds.traces {
        for r in &t.rows {
            let e = r.cs_pf() - predict_pf(&b, effect, r);
            ss += e * e;
            n += 1;
        }
    }
    Ok((ss / n.max(1) as f64).sqrt())
}

fn predict_pf(b: &crate::baseline::Baseline, effect: Effect, r: &Row) -> f64 {
    effect.series_cs(
        r.r_top_ohm() + r.r_bottom_ohm(),
        b.capacitance(r.stretch_mm()),
        r.freq_hz(),
    ) * 1e12
}

/// Fit the parameter of `effect` in [0, `max`] (golden-section search on
/// the residual RMS); returns the fitted effect and its residual RMS (pF).
pub fn fit(ds: &DataSet, effect: Effect, max: f64) -> Result<(Effect, f64)> {
    const G: f64 = 0.618_033_988_749_895;
    let f = |p: f64| residual_rms(ds, effect.with(p));
    let (mut a, mut b) = (0.0, max);
    let (mut c, mut d) = (b - G * (b - a), a + G * (b - a));
    let (mut fc, mut fd) = (f(c)?, f(d)?);
    for _ in 0..60 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - G * (b - a);
            fc = f(c)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + G * (b - a);
            fd = f(d)?;
        }
    }
    let p = 0.5 * (a + b);
    Ok((effect.with(p), f(p)?))
}

/// The noise floor of the data set (pF): RMS over traces of the successive
/// difference noise of the baseline residual.
pub fn noise_floor(ds: &DataSet) -> Result<f64> {
    let b = calibrate(&ds.calibration, Effect::None)?;
    let r = residuals(ds, &b);
    Ok((r.iter().map(|x| x.noise_pf * x.noise_pf).sum::<f64>() / r.len().max(1) as f64).sqrt())
}
