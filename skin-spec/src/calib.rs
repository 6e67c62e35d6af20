//! Stretch from capacitance: a calibration table (capacitance → stretch),
//! inverted by linear interpolation. Each sensor has its own
//! (`instrument::sensor::Sensor`).

use crate::design;

/// Points of a linear calibration table ([`CalTable::linear`]): every
/// [`STEP_MM`] from 0 to 30 mm.
pub const POINTS: usize = 11;
/// Stretch between the points of a linear calibration table, mm.
pub const STEP_MM: f64 = 3.0;

/// A monotone table of (capacitance F, stretch mm) points, ascending in
/// capacitance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalTable<const N: usize> {
    /// (C, stretch) points.
    pub points: [(f32, f32); N],
}

/// The reference sensor's static calibration ([`crate::design`]: C =
/// C_rest·(1 + s/length)) every 3 mm from 0 to 30 mm (the line-corrected
/// C, so no low-frequency bias; see host-sim's `calibration`).
pub const REFERENCE: CalTable<POINTS> =
    CalTable::linear(design::SENSOR_C_REST_FARAD, design::SENSOR_REST_LENGTH_MM);

impl CalTable<POINTS> {
    /// The calibration of a sensor whose line capacitance grows linearly
    /// with stretch, C = `c_rest_farad`·(1 + s/`length_mm`), every 3 mm
    /// from 0 to 30 mm (a uniaxial stretch of an incompressible film; the
    /// paper's sensor is linear this way within 0.3 % over 0…30 mm).
    pub const fn linear(c_rest_farad: f64, length_mm: f64) -> Self {
        let mut points = [(0.0f32, 0.0f32); POINTS];
        let mut k = 0;
        while k < POINTS {
            let s = STEP_MM * k as f64;
            let c = c_rest_farad * (1.0 + s / length_mm);
            points[k] = (c as f32, s as f32);
            k += 1;
        }
        CalTable { points }
    }
}

impl<const N: usize> CalTable<N> {
    /// A table needs two points: a smaller one is a compile-time error
    /// wherever it is used.
    const TWO_POINTS: () = assert!(N >= 2, "a calibration table needs at least two points");

    /// Stretch (mm) for capacitance `c` (F), extrapolating linearly beyond
    /// the ends. Where two points share a capacitance (a vertical step in
    /// stretch), that capacitance reads as one of the step's stretches,
    /// never ±∞; NaN for a NaN `c`.
    pub fn stretch(&self, c: f32) -> f32 {
        let () = Self::TWO_POINTS;
        let p = &self.points;
        let k = p.partition_point(|q| q.0 <= c).clamp(1, N - 1);
        let (a, b) = (p[k - 1], p[k]);
        let dc = b.0 - a.0;
        if dc == 0.0 {
            return if c.is_nan() { f32::NAN } else { a.1 };
        }
        a.1 + (b.1 - a.1) * (c - a.0) / dc
    }

    /// True if `c` (F) lies within the table's span of capacitance, give
    /// or take `margin` (relative): beyond it stretch is extrapolated.
    pub fn covers(&self, c: f32, margin: f32) -> bool {
        let () = Self::TWO_POINTS;
        let (lo, hi) = (self.points[0].0, self.points[N - 1].0);
        c >= lo * (1.0 - margin) && c <= hi * (1.0 + margin)
    }

    /// Capacitance at rest (stretch 0), F: the prior of the line tracker.
    pub fn rest_capacitance(&self) -> f32 {
        let () = Self::TWO_POINTS;
        self.points[0].0
    }
}
