//! Stretch from capacitance: a calibration table (capacitance → stretch)
//! stored in flash, inverted by linear interpolation; and a skin's
//! tables, one per sensor where a sensor has its own
//! ([`Calibrations`], a fixed-capacity `heapless` map).

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

    /// Capacitance at rest (stretch 0), F: the prior of the line tracker.
    pub fn rest_capacitance(&self) -> f32 {
        let () = Self::TWO_POINTS;
        self.points[0].0
    }
}

/// Why a sensor's table was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalError {
    /// The table's capacitances do not ascend (or one is not finite), so
    /// stretch would not be a function of C.
    NotAscending,
    /// The map holds as many sensors as it can.
    Full,
}

/// A skin's calibration: each sensor's own table where it has one, the
/// `default` table for every other. Sensors are made one by one and their
/// rest capacitances differ by tens of percent, so one table for all
/// reads a different stretch on each at rest; the map holds up to `S`
/// own tables in place (no heap).
#[derive(Clone, Debug)]
pub struct Calibrations<'a, const N: usize, const S: usize> {
    default: &'a CalTable<N>,
    own: heapless::LinearMap<u8, CalTable<N>, S>,
}

impl<'a, const N: usize, const S: usize> Calibrations<'a, N, S> {
    /// Every sensor on `default`.
    pub const fn new(default: &'a CalTable<N>) -> Self {
        Self {
            default,
            own: heapless::LinearMap::new(),
        }
    }

    /// Give `sensor` its own table (replacing the one it had). Refused
    /// if the capacitances do not strictly ascend or if `S` sensors
    /// already have theirs; the map is then as it was.
    pub fn insert(&mut self, sensor: u8, table: CalTable<N>) -> Result<(), CalError> {
        let ascending = table.points.iter().all(|p| p.0.is_finite() && p.1.is_finite())
            && table.points.windows(2).all(|w| w[0].0 < w[1].0);
        if !ascending {
            return Err(CalError::NotAscending);
        }
        match self.own.insert(sensor, table) {
            Ok(_) => Ok(()),
            Err(_) => Err(CalError::Full),
        }
    }

    /// Sensor `sensor`'s table.
    pub fn of(&self, sensor: u8) -> &CalTable<N> {
        self.own.get(&sensor).unwrap_or(self.default)
    }

    /// How many sensors have their own table.
    pub fn own_tables(&self) -> usize {
        self.own.len()
    }
}

#[cfg(test)]
mod calibrations_tests {
    use super::*;

    #[test]
    fn each_sensor_reads_its_own_table_or_the_default() {
        let mut cals = Calibrations::<POINTS, 2>::new(&REFERENCE);
        let small = CalTable::linear(150e-12, 100.0);
        let large = CalTable::linear(290e-12, 100.0);
        assert_eq!(cals.insert(3, small), Ok(()));
        assert_eq!(cals.insert(9, large), Ok(()));
        // Full: refused, the map unchanged; replacing a table is not
        // adding one.
        assert_eq!(cals.insert(4, small), Err(CalError::Full));
        assert_eq!(cals.insert(9, large), Ok(()));
        assert_eq!(cals.own_tables(), 2);
        assert_eq!(cals.of(3), &small);
        assert_eq!(cals.of(9), &large);
        assert_eq!(cals.of(4), &REFERENCE);
        // The same capacitance, three stretches: each sensor's own.
        let c = 165e-12f32;
        assert!((cals.of(3).stretch(c) - 10.0).abs() < 1e-3);
        assert!(cals.of(9).stretch(c) < -40.0);
        assert!(cals.of(0).stretch(c) < -20.0);
        // A table whose capacitance does not ascend is refused.
        let mut bad = small;
        bad.points.swap(2, 3);
        let mut one = Calibrations::<POINTS, 4>::new(&REFERENCE);
        assert_eq!(one.insert(0, bad), Err(CalError::NotAscending));
        bad = small;
        bad.points[5].0 = f32::NAN;
        assert_eq!(one.insert(0, bad), Err(CalError::NotAscending));
        assert_eq!(one.own_tables(), 0);
    }
}
