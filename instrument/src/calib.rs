//! Stretch from capacitance: a calibration table (capacitance → stretch)
//! stored in flash, inverted by linear interpolation.

/// A monotone table of (capacitance F, stretch mm) points, ascending in
/// capacitance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalTable<const N: usize> {
    /// (C, stretch) points.
    pub points: [(f32, f32); N],
}

/// The reference sensor's static calibration: C = 210 pF·(1 + s/100 mm)
/// every 3 mm from 0 to 30 mm (the line-corrected C, so no low-frequency
/// bias; see host-sim's `calibration`).
pub const REFERENCE: CalTable<11> = CalTable {
    points: [
        (210.0e-12, 0.0),
        (216.3e-12, 3.0),
        (222.6e-12, 6.0),
        (228.9e-12, 9.0),
        (235.2e-12, 12.0),
        (241.5e-12, 15.0),
        (247.8e-12, 18.0),
        (254.1e-12, 21.0),
        (260.4e-12, 24.0),
        (266.7e-12, 27.0),
        (273.0e-12, 30.0),
    ],
};

impl<const N: usize> CalTable<N> {
    /// Stretch (mm) for capacitance `c` (F), extrapolating linearly beyond
    /// the ends.
    pub fn stretch(&self, c: f32) -> f32 {
        let p = &self.points;
        if N < 2 {
            return p.first().map_or(0.0, |q| q.1);
        }
        let k = p.partition_point(|q| q.0 <= c).clamp(1, N - 1);
        let (a, b) = (p[k - 1], p[k]);
        a.1 + (b.1 - a.1) * (c - a.0) / (b.0 - a.0)
    }

    /// Capacitance at rest (stretch 0), F: the prior of the line tracker.
    pub fn rest_capacitance(&self) -> f32 {
        self.points[0].0
    }
}
