//! The lumped series R-C reading (Cs–Rs), as an LCR meter reports it.
//!
//! A series model Z = Rs + 1/(jωCs) gives Rs = Re Z and Cs = −1/(ω·Im Z);
//! the dissipation factor is D = Rs·ω·Cs = Re Z/(−Im Z).

use crate::Complex32;
use core::f32::consts::TAU;

/// Why an impedance has no series R-C reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LumpedError {
    /// Im Z ≥ 0 or Re Z < 0: not a lossy capacitor (e.g. a short or an
    /// inductive or active reading), a non-finite value, or a capacitance
    /// beyond `f32`.
    NotCapacitive,
    /// The frequency is not finite and positive.
    BadFrequency,
}

impl core::fmt::Display for LumpedError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            LumpedError::NotCapacitive => "not a lossy capacitor (Im Z ≥ 0, Re Z < 0 or not finite)",
            LumpedError::BadFrequency => "the frequency is not finite and positive",
        })
    }
}

impl core::error::Error for LumpedError {}

/// Series capacitance and resistance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeriesRc {
    /// Series capacitance Cs, F.
    pub cs_farad: f32,
    /// Series resistance Rs, Ω.
    pub rs_ohm: f32,
}

impl SeriesRc {
    /// The series reading of impedance `z` (Ω) at `f_hz`.
    pub fn from_impedance(z: Complex32, f_hz: f32) -> Result<Self, LumpedError> {
        if !(f_hz.is_finite() && f_hz > 0.0) {
            return Err(LumpedError::BadFrequency);
        }
        if !(z.re.is_finite() && z.im.is_finite() && z.im < 0.0 && z.re >= 0.0) {
            return Err(LumpedError::NotCapacitive);
        }
        // |Im Z| so small (or ω|Im Z| so large) that Cs leaves f32's
        // normal range, to ∞ or to 0: no reading.
        let cs_farad = -1.0 / (TAU * f_hz * z.im);
        if !cs_farad.is_normal() {
            return Err(LumpedError::NotCapacitive);
        }
        Ok(Self {
            cs_farad,
            rs_ohm: z.re,
        })
    }

    /// The impedance of this series R-C at `f_hz`, Ω.
    pub fn impedance(&self, f_hz: f32) -> Complex32 {
        Complex32::new(self.rs_ohm, -1.0 / (TAU * f_hz * self.cs_farad))
    }

    /// Dissipation factor D = Rs·ω·Cs at `f_hz` (dimensionless).
    pub fn dissipation(&self, f_hz: f32) -> f32 {
        self.rs_ohm * TAU * f_hz * self.cs_farad
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let m = SeriesRc {
            cs_farad: 200e-12,
            rs_ohm: 240e3,
        };
        let z = m.impedance(2e3);
        let back = SeriesRc::from_impedance(z, 2e3).unwrap();
        assert!((back.cs_farad / m.cs_farad - 1.0).abs() < 1e-6);
        assert!((back.rs_ohm / m.rs_ohm - 1.0).abs() < 1e-6);
        assert!((m.dissipation(2e3) - 0.603_185_8).abs() < 1e-5);
        let bad = [
            Complex32::new(1.0, 0.0),
            Complex32::new(-1.0, -1.0),
            Complex32::new(f32::NAN, -1.0),
            // Cs = 1/(ω·1e-45) is beyond f32.
            Complex32::new(1.0, -1e-45),
        ];
        for z in bad {
            assert_eq!(SeriesRc::from_impedance(z, 1e3), Err(LumpedError::NotCapacitive));
        }
        assert_eq!(SeriesRc::from_impedance(z, 0.0), Err(LumpedError::BadFrequency));
    }
}
