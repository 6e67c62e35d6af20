//! The front end's design parameters, in one place: the board's bring-up,
//! the simulated front end (`skin_sim::frontend`), the fault thresholds and
//! the reference calibration all read them.
//!
//! ```text
//! DAC (12 bit, 0..3.3 V) ─ buffer ─► top tab ┄ sensor ┄ bottom tab ─► TIA (R_f) ─► ADC2
//!        └──────────────────────────────────────────────────────────────────────► ADC1
//! ```
//!
//! The TIA's feedback resistor is one of [`TIA_RANGES_OHM`], chosen by a
//! 4:1 analog switch (a TMUX1104-class part, its two address lines on PB5
//! and PB6) as an LCR meter switches ranges: sensors from ~0.2 MΩ (the
//! reference sensor at 6 kHz) to ~3 MΩ (the paper's, with its tab leads,
//! after cycling) all fill the ADC ([`crate::ranging`]).
//!
//! Both ADC inputs and the DAC output are biased at mid-supply
//! ([`BIAS_VOLT`]); the ADCs read ±[`ADC_HALF_SCALE_VOLT`] around it as
//! codes 0..[`ADC_MAX_CODE`], the bias at [`ADC_OFFSET_CODE`] (DC, which the
//! demodulator rejects exactly).

/// Pair sample rate of the ADCs (voltage and current together), Hz.
pub const SAMPLE_RATE: u32 = 200_000;
/// System clock of the board, Hz (the timer that paces the samples runs
/// on it).
pub const SYSCLK_HZ: u32 = 170_000_000;
/// Analog supply and ADC/DAC reference, V.
pub const VREF_VOLT: f64 = 3.3;
/// Mid-supply bias of the excitation and of both ADC inputs, V.
pub const BIAS_VOLT: f64 = VREF_VOLT / 2.0;
/// Excitation amplitude at the sensor, V (peak).
pub const EXCITATION_VOLT: f64 = 1.0;
/// Gain from the excitation to the voltage ADC channel, V/V.
pub const V_GAIN: f64 = 1.0;
/// Feedback resistances of the inverting transimpedance stage, one per
/// range, Ω (E6 steps of about 2.2×; the switch's ~50 Ω on-resistance
/// is inside the loop's Kelvin sense, and each range's complex gain is a
/// calibration constant of the board).
pub const TIA_RANGES_OHM: [f64; RANGES] = [100e3, 220e3, 470e3, 1e6];
/// Number of transimpedance ranges.
pub const RANGES: usize = 4;
/// Feedback resistance of the lowest range (the front end at reset), Ω.
pub const TIA_LOWEST_RANGE_OHM: f64 = TIA_RANGES_OHM[0];
/// Resolution of one ADC conversion, bits.
pub const CONVERSION_BITS: u32 = 12;
/// Largest ADC code (a sample at 0 or here sits on a rail).
pub const ADC_MAX_CODE: u16 = (1 << CONVERSION_BITS) - 1;
/// ADC code of the bias.
pub const ADC_OFFSET_CODE: u16 = 1 << (CONVERSION_BITS - 1);
/// ADC input span around the bias, V (±).
pub const ADC_HALF_SCALE_VOLT: f64 = BIAS_VOLT;
/// DAC resolution, bits.
pub const DAC_BITS: u32 = 12;
/// The excitation as the DAC's Q15 amplitude (2¹⁵ = the DAC's half
/// scale, [`BIAS_VOLT`]).
pub const DAC_AMPLITUDE_Q15: i16 = (EXCITATION_VOLT / BIAS_VOLT * 32768.0) as i16;

/// The reference sensor the default calibration describes: capacitance
/// at rest (prestretched, 0 mm), F.
pub const SENSOR_C_REST_FARAD: f64 = 210e-12;
/// The reference sensor's electrode resistance at rest, both electrodes
/// end to end, Ω (the paper's carbon-black electrodes, ≈ 350 kΩ each).
pub const SENSOR_R_REST_OHM: f64 = 700e3;
/// The reference sensor's active length at rest, mm: C = C_rest·(1 +
/// s/length) (uniaxial stretch of an incompressible film).
pub const SENSOR_REST_LENGTH_MM: f64 = 100.0;

/// Does an ADC code sit on a rail?
pub const fn on_rail(code: u16) -> bool {
    code == 0 || code >= ADC_MAX_CODE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_values() {
        assert_eq!((ADC_MAX_CODE, ADC_OFFSET_CODE), (4095, 2048));
        // 1 V of the DAC's ±1.65 V.
        assert_eq!(DAC_AMPLITUDE_Q15, 19_859);
        assert_eq!(SYSCLK_HZ % SAMPLE_RATE, 0, "the timer divides exactly");
        assert!(on_rail(0) && on_rail(4095) && !on_rail(1) && !on_rail(4094));
    }
}
