//! Excitation oscillator: a phase accumulator and the [`cossin`] source.
//!
//! Configuration ([`Oscillator`], the frequency tuning word) is split from
//! the mutable state ([`OscillatorState`], the phase), as in idsp.
//!
//! Frequency: f = ftw·f_s/2³² with an unsigned 32-bit tuning word `ftw`,
//! so the resolution is f_s/2³² (47 µHz at 200 kSa/s).

use crate::cossin::cossin;

/// Why a requested excitation frequency cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FreqError {
    /// Outside [`Oscillator::F_MIN_HZ`]..=[`Oscillator::F_MAX_HZ`], not finite,
    /// or not below the Nyquist frequency f_s/2.
    OutOfRange,
    /// The block is too short to hold a whole excitation period, or longer
    /// than 2¹⁶ samples.
    BadBlock,
}

impl core::fmt::Display for FreqError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FreqError::OutOfRange => "frequency outside the oscillator's range or not below Nyquist",
            FreqError::BadBlock => "the block holds no whole period, or is longer than 2^16 samples",
        })
    }
}

impl core::error::Error for FreqError {}

/// Oscillator configuration: the phase increment per sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Oscillator {
    ftw: u32,
}

/// Oscillator state: the current phase (`i32::MIN` = −π).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OscillatorState {
    /// Phase of the next sample, one turn = 2³².
    pub phase: i32,
}

impl Oscillator {
    /// Lowest supported excitation frequency, Hz.
    pub const F_MIN_HZ: f32 = 100.0;
    /// Highest supported excitation frequency, Hz.
    pub const F_MAX_HZ: f32 = 50_000.0;

    /// Oscillator at `freq_hz` (rounded to the nearest f_s/2³²) for the
    /// sample rate `sample_rate_hz`.
    pub fn new(freq_hz: f32, sample_rate_hz: f32) -> Result<Self, FreqError> {
        check(freq_hz, sample_rate_hz)?;
        let ftw = freq_hz as f64 / sample_rate_hz as f64 * 4_294_967_296.0 + 0.5;
        Ok(Self { ftw: ftw as u32 })
    }

    /// Oscillator coherent with blocks of 2^`block_log2` samples: the
    /// frequency is snapped to the nearest k·f_s/2^`block_log2` (k ≥ 1), so
    /// every block holds exactly k whole periods and the demodulator rejects
    /// DC and all harmonics exactly.
    ///
    /// ```
    /// use dsp_core::Oscillator;
    /// let osc = Oscillator::coherent(6000.0, 200e3, 11).unwrap();
    /// assert_eq!(osc.periods_per_block(11), 61); // 5957.03 Hz
    /// ```
    pub fn coherent(freq_hz: f32, sample_rate_hz: f32, block_log2: u32) -> Result<Self, FreqError> {
        check(freq_hz, sample_rate_hz)?;
        if !(1..=16).contains(&block_log2) {
            return Err(FreqError::BadBlock);
        }
        let n = (1u32 << block_log2) as f64;
        let k = (freq_hz as f64 / sample_rate_hz as f64 * n + 0.5) as u32;
        if k == 0 || 2 * k >= 1 << block_log2 {
            return Err(FreqError::BadBlock);
        }
        Ok(Self {
            ftw: k << (32 - block_log2),
        })
    }

    /// Oscillator from a raw tuning word (f = ftw·f_s/2³²).
    pub const fn from_ftw(ftw: u32) -> Self {
        Self { ftw }
    }

    /// The frequency tuning word (phase increment per sample).
    pub const fn ftw(&self) -> u32 {
        self.ftw
    }

    /// The exact frequency in Hz at the sample rate `sample_rate_hz`.
    pub fn freq_hz(&self, sample_rate_hz: f32) -> f32 {
        (self.ftw as f64 * sample_rate_hz as f64 / 4_294_967_296.0) as f32
    }

    /// Whole periods in a block of 2^`block_log2` samples, if the
    /// oscillator is coherent with such blocks; 0 for `block_log2`
    /// outside 1..=32 (no whole period fits, or the count overflows).
    pub const fn periods_per_block(&self, block_log2: u32) -> u32 {
        if block_log2 == 0 || block_log2 > 32 {
            return 0;
        }
        self.ftw >> (32 - block_log2)
    }

    /// Cosine and sine (Q31) at the current phase, then advance one sample.
    #[inline]
    pub fn next(&self, state: &mut OscillatorState) -> (i32, i32) {
        let cs = cossin(state.phase);
        state.phase = state.phase.wrapping_add(self.ftw as i32);
        cs
    }

    /// Next code for an unsigned `bits`-bit DAC (`bits` in 1..=16): mid-scale
    /// plus `amplitude` (Q15, 2¹⁵ = 1.0) times the sine, rounded.
    pub fn next_dac(&self, state: &mut OscillatorState, bits: u32, amplitude: i16) -> u16 {
        let (_, s) = self.next(state);
        dac_code(s, bits, amplitude)
    }
}

/// DAC code of a Q31 sample `s` for an unsigned `bits`-bit DAC
/// (`bits` in 1..=16) at `amplitude` (Q15, 2¹⁵ = 1.0; negative reads as 0):
/// code = 2^(bits−1) + round(s/2³¹ · amplitude/2¹⁵ · 2^(bits−1)), saturated
/// to the DAC range 0..2^bits − 1.
#[inline]
pub fn dac_code(s: i32, bits: u32, amplitude: i16) -> u16 {
    dac_code_of_sum(&[(s, amplitude)], bits)
}

/// DAC code of a sum of tones, each a Q31 sample at its Q15 amplitude
/// (as [`dac_code`] of one): 2^(bits−1) + round(Σ sₖ·aₖ/2⁴⁶ ·
/// 2^(bits−1)), saturated to the DAC range. Amplitudes that sum to at
/// most 2¹⁵ never saturate.
#[inline]
pub fn dac_code_of_sum(tones: &[(i32, i16)], bits: u32) -> u16 {
    let bits = bits.clamp(1, 16);
    let half = 1i64 << (bits - 1);
    // Each s·a is Q46, below 2⁶²: a few of them sum without overflow.
    let sum: i64 = tones.iter().map(|&(s, a)| s as i64 * a.max(0) as i64).sum();
    // Back to Q31, scaled by the half range, rounded to integer codes.
    let v = sum >> 15;
    let code = half + ((v * half + (1 << 30)) >> 31);
    code.clamp(0, (1i64 << bits) - 1) as u16
}

fn check(freq_hz: f32, sample_rate_hz: f32) -> Result<(), FreqError> {
    let ok = freq_hz.is_finite()
        && sample_rate_hz.is_finite()
        && (Oscillator::F_MIN_HZ..=Oscillator::F_MAX_HZ).contains(&freq_hz)
        && 2.0 * freq_hz < sample_rate_hz;
    if ok {
        Ok(())
    } else {
        Err(FreqError::OutOfRange)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequency_resolution_and_range() {
        for f in [100.0f32, 500.0, 2000.0, 6000.0, 31_415.9, 50_000.0] {
            let o = Oscillator::new(f, 200e3).unwrap();
            assert!((o.freq_hz(200e3) - f).abs() < 1e-4 * f, "{f}");
        }
        assert_eq!(Oscillator::new(99.0, 200e3), Err(FreqError::OutOfRange));
        assert_eq!(Oscillator::new(50_001.0, 200e3), Err(FreqError::OutOfRange));
        assert_eq!(Oscillator::new(6e3, 10e3), Err(FreqError::OutOfRange));
        assert_eq!(Oscillator::new(f32::NAN, 200e3), Err(FreqError::OutOfRange));
        assert_eq!(Oscillator::coherent(6e3, 200e3, 0), Err(FreqError::BadBlock));
        assert_eq!(Oscillator::coherent(100.0, 200e3, 8), Err(FreqError::BadBlock));
    }

    #[test]
    fn coherent_blocks_hold_whole_periods() {
        let o = Oscillator::coherent(2000.0, 200e3, 11).unwrap();
        let mut st = OscillatorState::default();
        for _ in 0..2048 {
            o.next(&mut st);
        }
        assert_eq!(st.phase, 0);
        assert_eq!(o.periods_per_block(11), 20);
        // Outside 1..=32: no whole period, not a panic.
        assert_eq!(
            (
                o.periods_per_block(0),
                o.periods_per_block(33),
                o.periods_per_block(u32::MAX)
            ),
            (0, 0, 0)
        );
        assert_eq!(o.periods_per_block(32), o.ftw);
    }

    #[test]
    fn dac_codes_saturate_and_center() {
        assert_eq!(dac_code(0, 12, 32767), 2048);
        assert_eq!(dac_code(i32::MAX, 12, 32767), 4095);
        assert_eq!(dac_code(i32::MIN, 12, 32767), 0);
        assert_eq!(dac_code(i32::MAX, 12, 16384), 3072);
        assert_eq!(dac_code(i32::MAX, 16, 32767), 65535);
        assert_eq!(dac_code(i32::MIN, 16, 32767), 1); // 32767 = 1 − 2⁻¹⁵
        assert_eq!(dac_code(i32::MAX, 12, -5), 2048);
        assert_eq!(dac_code(i32::MIN, 1, 32767), 0);
    }
}
