//! De-embedding the sensor's wiring: the static effects `identify` finds
//! (`host-sim identify`; `instrument::effects::EffectSet::fixture` turns
//! them into a [`Fixture`]), written as a calibration the firmware applies
//! before the line inversion, as an impedance analyzer's open/short
//! compensation does.
//!
//! The measured impedance is the line behind two contacts and a parasitic
//! capacitance at the meter:
//!
//! ```text
//! Z_meas = 1 / (1/(Z_line + R_s) + jω·C_p),   R_s = 2·R_c (two tabs)
//! Z_line = 1 / (1/Z_meas − jω·C_p) − R_s
//! ```
//!
//! Declared range: C_p ≤ 100 pF, R_s ≤ 1 MΩ, f ≤ 50 kHz, |Z_meas| within
//! the line model's range (1 kΩ..10 GΩ). In `f32` the result is within
//! 1·10⁻⁵ relative of an f64 reference wherever the line keeps at least
//! 10 % of the measured admittance (tests in `tests/fixture.rs`).

use crate::twotone::Tone;
use crate::Complex32;
use core::f32::consts::TAU;

/// The wiring between the meter and the sensor's line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fixture {
    /// Capacitance in parallel at the meter (cable, fixture), F.
    pub parallel_farad: f32,
    /// Resistance in series with the line (both tabs' contacts), Ω.
    pub series_ohm: f32,
}

/// Why a measured impedance cannot be de-embedded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FixtureError {
    /// The parasitic capacitance alone explains the reading, or more: no
    /// line is left behind it (an open sensor, or a wrong calibration).
    NothingLeft,
}

impl core::fmt::Display for FixtureError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the parasitic capacitance explains the whole reading: no line is left behind it")
    }
}

impl core::error::Error for FixtureError {}

impl Fixture {
    /// No wiring effects.
    pub const NONE: Fixture = Fixture {
        parallel_farad: 0.0,
        series_ohm: 0.0,
    };

    /// The line's impedance (Ω) behind the wiring, from the measured
    /// impedance `z` (Ω) at `f_hz`.
    pub fn remove(&self, z: Complex32, f_hz: f32) -> Result<Complex32, FixtureError> {
        self.remove_scaled(z, f_hz).map(|(z, _)| z)
    }

    /// [`Fixture::remove`], and how much a small change of `z` grows
    /// behind the wiring, |[`Fixture::slope`]| = 1/|1 − jωC_p·Z|² (1
    /// without wiring): the scale of the measured noise's σ.
    #[inline(always)]
    fn remove_scaled(&self, z: Complex32, f_hz: f32) -> Result<(Complex32, f32), FixtureError> {
        if *self == Self::NONE {
            return Ok((z, 1.0));
        }
        // 1/Z − jωCp, written out so that nothing overflows for |Z| up to
        // 10 GΩ: y = conj(z)/|z|².
        let n = z.norm_sqr();
        let y = Complex32::new(z.re / n, -z.im / n - TAU * f_hz * self.parallel_farad);
        let m = y.norm_sqr();
        // The line's admittance must stay capacitive (Im y > 0) and not be
        // lost in rounding.
        if !(y.im > 1e-4 * (z.im / n).abs() && m.is_finite() && m > 0.0) {
            return Err(FixtureError::NothingLeft);
        }
        // 1 − jωC_p·Z = Z·y: |slope| = 1/(|Z|²·|y|²).
        Ok((
            Complex32::new(y.re / m - self.series_ohm, -y.im / m),
            1.0 / (n * m),
        ))
    }

    /// `tones` as measured, each impedance taken behind the wiring
    /// ([`Fixture::remove`]) and its σ with it: the noise of a measured
    /// phasor is round (the same σ on each component), and the map
    /// behind the wiring is conformal, so it stays round, its σ scaled by
    /// |[`Fixture::slope`]| (up to 1.3 times at 20 pF before a line of
    /// several MΩ, where the fit would otherwise take the noise for
    /// misfit).
    pub fn behind<const K: usize>(&self, tones: &[Tone; K]) -> Result<[Tone; K], FixtureError> {
        let mut out = *tones;
        self.take_out(&mut out)?;
        Ok(out)
    }

    /// [`Fixture::behind`] in place: on an error, the tones before the
    /// one that failed are taken behind the wiring, the rest not.
    pub fn take_out<const K: usize>(&self, tones: &mut [Tone; K]) -> Result<(), FixtureError> {
        for t in tones.iter_mut() {
            let (z, scale) = self.remove_scaled(t.z, t.f_hz)?;
            t.z = z;
            t.sigma_ohm *= scale;
        }
        Ok(())
    }

    /// How a small change of the measured impedance `z` (Ω) at `f_hz`
    /// moves the line's behind the wiring: d(Z_line)/d(Z_meas) =
    /// 1/(1 − jωC_p·Z_meas)² (the series resistance only shifts it); 1
    /// without a parasitic capacitance.
    pub fn slope(&self, z: Complex32, f_hz: f32) -> Complex32 {
        let one = Complex32::new(1.0, 0.0);
        if self.parallel_farad == 0.0 {
            return one;
        }
        let wc = TAU * f_hz * self.parallel_farad;
        // 1 − jωC_p·Z.
        let zy = Complex32::new(1.0 + wc * z.im, -wc * z.re);
        one / (zy * zy)
    }
}
