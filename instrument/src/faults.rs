//! Fault and status flags of a record. The firmware never stops for a
//! fault: it flags the record and keeps measuring; the flag clears with the
//! cause.

use crate::design;

/// Bit set of flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags(pub u16);

impl Flags {
    /// An ADC sample of the block hit a rail.
    pub const CLIPPED: u16 = 1 << 0;
    /// No current: the sensor is disconnected (open).
    pub const OPEN: u16 = 1 << 1;
    /// Not a lossy capacitor, or |Z| below the short threshold.
    pub const SHORTED: u16 = 1 << 2;
    /// The line inversion failed or was rejected (x beyond range, jump).
    pub const RANGE: u16 = 1 << 3;
    /// The channel or its frequency just changed: the block is discarded.
    pub const SETTLING: u16 = 1 << 4;
    /// C held from the previous block (ill-conditioned inversion): no new
    /// reading, so not valid.
    pub const HELD: u16 = 1 << 5;
    /// The block holds more than the excitation explains (mains hum, a
    /// step, a glitch): its residual after the fitted tone is above the
    /// threshold, so the tone itself may be off.
    pub const DISTURBED: u16 = 1 << 6;
    /// The line's C is not vouched for: the block's noise, and any
    /// disturbance the residual check lets through, times the inversion's
    /// error amplification κ at this ωRC, could move C by more than
    /// [`Thresholds::c_tolerance`] (near the peak of D, or a weak signal).
    pub const UNCERTAIN: u16 = 1 << 7;
    /// The two tones of the block disagree: no single uniform line
    /// explains both within their noise (χ² of
    /// [`dsp_core::twotone::Solution`] above its flag): a contact, a
    /// parasitic, a disturbance the line does not have.
    pub const MODEL: u16 = 1 << 8;
    /// Status, not a fault: the sensor has no stretch calibration of its
    /// own, so the record's stretch is not a measurement (it reads 0).
    /// C and R are the line's, and valid as the other bits say.
    pub const UNCALIBRATED: u16 = 1 << 9;
    /// Status, not a fault: C lies outside its sensor's calibrated span
    /// (below the table's first point or above its last by more than
    /// [`Thresholds::c_tolerance`]), so the stretch is an extrapolation;
    /// at rest, the sensor is not the one the table was measured on (a
    /// swapped sensor, or a table of another). C and R stand.
    pub const OFF_TABLE: u16 = 1 << 10;

    /// Every flag and its name, in bit order (as
    /// `docs/data-format.md` names them).
    pub const NAMES: [(u16, &'static str); 11] = [
        (Self::CLIPPED, "CLIPPED"),
        (Self::OPEN, "OPEN"),
        (Self::SHORTED, "SHORTED"),
        (Self::RANGE, "RANGE"),
        (Self::SETTLING, "SETTLING"),
        (Self::HELD, "HELD"),
        (Self::DISTURBED, "DISTURBED"),
        (Self::UNCERTAIN, "UNCERTAIN"),
        (Self::MODEL, "MODEL"),
        (Self::UNCALIBRATED, "UNCALIBRATED"),
        (Self::OFF_TABLE, "OFF_TABLE"),
    ];

    /// The names of the flags set, in bit order (bits without a name are
    /// left out).
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        Self::NAMES
            .into_iter()
            .filter(move |(bit, _)| self.has(*bit))
            .map(|(_, name)| name)
    }

    /// Is `bit` set?
    pub fn has(self, bit: u16) -> bool {
        self.0 & bit != 0
    }

    /// Set `bit`.
    pub fn set(&mut self, bit: u16) {
        self.0 |= bit;
    }

    /// True if the stretch of the record can be trusted: its C is valid,
    /// its sensor calibrated, and C within the calibrated span.
    pub fn stretch_valid(self) -> bool {
        self.valid() && self.0 & (Self::UNCALIBRATED | Self::OFF_TABLE) == 0
    }

    /// True if the capacitance of the record can be trusted.
    pub fn valid(self) -> bool {
        let bad = Self::CLIPPED
            | Self::OPEN
            | Self::SHORTED
            | Self::RANGE
            | Self::SETTLING
            | Self::DISTURBED
            | Self::UNCERTAIN
            | Self::HELD
            | Self::MODEL;
        self.0 & bad == 0
    }
}

/// The designed excitation at the voltage ADC, counts (amplitude).
const EXCITATION_COUNTS: f32 = (design::EXCITATION_VOLT * design::V_GAIN * design::ADC_OFFSET_CODE as f64
    / design::ADC_HALF_SCALE_VOLT) as f32;

/// The smallest tone of the array's excitation (its highest, 6 kHz) at
/// its voltage input, counts.
const ARRAY_TONE_COUNTS: f32 = (crate::array::TONE_VOLTS[crate::array::TONES - 1]
    / design::ADC_HALF_SCALE_VOLT
    * crate::array::HALF_SCALE as f64) as f32;

/// Thresholds of the fault checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    /// Current amplitude below which the sensor counts as open, ADC counts.
    pub open_counts: f32,
    /// Voltage amplitude below which there is no excitation, ADC counts.
    pub no_excitation_counts: f32,
    /// |Z| below which the sensor counts as shorted, Ω.
    pub short_ohm: f32,
    /// Line resistance above which the electrodes count as out of range
    /// (damaged or delaminated), Ω.
    pub r_max_ohm: f32,
    /// A channel's residual rms after the fitted tone
    /// ([`dsp_core::demod::Phasors::residual_rms`]) above which the block is
    /// disturbed, counts, whatever the tone's amplitude.
    pub residual_counts: f32,
    /// ... or above this fraction of the channel's tone amplitude, if that
    /// is larger.
    pub residual_rel: f32,
    /// Largest relative error of C a valid record may carry, by the bound
    /// of [`Thresholds::c_error_bound`].
    pub c_tolerance: f32,
    /// The ADC's white noise, rms counts: the part of a block's residual
    /// that is noise (its error is the 5σ term of
    /// [`Thresholds::c_error_bound`]); only what exceeds it counts as a
    /// disturbance that can leak into the tone's bin. A board noisier than
    /// this gets more pessimistic bounds, never optimistic ones.
    pub noise_counts: f32,
}

impl Thresholds {
    /// Defaults for the front end of [`crate::design`] (12-bit ADC of
    /// ±1.65 V, 1 V excitation, 100 kΩ transimpedance): the smallest real
    /// current, a 150 pF sensor at 586 Hz, gives ≈70 counts; the noise
    /// floor of a 1024-pair block is ≈0.05 counts, so 4 counts separates
    /// them widely. No excitation: below a sixth of the designed one.
    ///
    /// Disturbance: a clean block's residual is the ADC noise, ≈ 0.8 counts
    /// rms. A disturbance leaks into the tone's bin at most ≈ 1.1/k times
    /// its residual rms (a ramp: hum over a block shorter than its period;
    /// k ≥ 3 periods per block), so a residual below max(1.5 counts, 2 % of
    /// the tone) moves the tone by at most 0.55 counts or 0.75 % of it:
    /// ≤ 0.8 % at the smallest current (≈ 70 counts).
    pub const DEFAULT: Self = Self {
        open_counts: 4.0,
        no_excitation_counts: EXCITATION_COUNTS / 6.0,
        short_ohm: 1_000.0,
        r_max_ohm: 5.0e6,
        residual_counts: 1.5,
        residual_rel: 0.02,
        c_tolerance: 0.008,
        // 0.7 LSB of input noise (the STM32G4 ADC's typical, 12-bit) and
        // 0.29 LSB of quantization: 0.76 LSB rms, rounded up.
        noise_counts: 1.0,
    };

    /// Thresholds for the array ([`crate::array`]: 16-bit oversampled
    /// results, tones of 0.69 V at 500 Hz falling as 1/√f to 0.20 V at
    /// 6 kHz, 330 kΩ transimpedance). The smallest real current, the
    /// paper's cycled sensor (≈ 1.9 MΩ) at 500 Hz, gives ≈ 2300 counts and
    /// the excitation's smallest tone ≈ 3930; a clean block's residual is
    /// the ADC's ≈ 3.05 counts. Open below 60 counts, no excitation below a
    /// sixth of the smallest tone; disturbed above 6.4 counts (2.1× the
    /// noise, as the board's 1.5 against 0.76) or 2 % of the largest tone.
    pub const ARRAY: Self = Self {
        open_counts: 60.0,
        no_excitation_counts: ARRAY_TONE_COUNTS / 6.0,
        short_ohm: 1_000.0,
        r_max_ohm: 5.0e6,
        residual_counts: 6.4,
        residual_rel: 0.02,
        c_tolerance: 0.008,
        noise_counts: crate::array::NOISE_COUNTS,
    };

    /// A bound on the relative error of C from one block. A channel's
    /// residual rms r (after the fitted tone) is white noise of at most
    /// σ = [`Thresholds::noise_counts`] and a disturbance of rms
    /// δ = √(max(0, r² − σ²)). Its phase is then off by at most
    ///
    /// ```text
    /// φ = (5·r·√(2/N) + 1.1·δ/k) / A
    /// ```
    ///
    /// (five standard deviations of the noise on a tone of amplitude A over
    /// N pairs, plus the most a disturbance leaks into the bin of k
    /// periods); D = Re Z/(−Im Z) moves by (1 + D²)/D times the phase error
    /// (relative), and C by `kappa` times that, plus the amplitude errors,
    /// each at most φ. `d` is the block's D, `periods` its k.
    pub fn c_error_bound(&self, ph: &dsp_core::demod::Phasors, d: f32, kappa: f32, periods: u32) -> f32 {
        let n = (ph.n as f32).max(1.0);
        let k = periods.max(1) as f32;
        let sigma = self.noise_counts;
        let channel = |r: f32, a: f32| {
            let delta = libm::sqrtf((r * r - sigma * sigma).max(0.0));
            (5.0 * r * libm::sqrtf(2.0 / n) + 1.1 * delta / k) / a
        };
        let [rv, ri] = ph.residual_rms();
        let phase = channel(rv, ph.v_amplitude()) + channel(ri, ph.i_amplitude());
        let e = kappa * (1.0 + d * d) / d * phase + phase;
        // NaN (no signal) is no bound.
        if e.is_nan() {
            f32::INFINITY
        } else {
            e
        }
    }

    /// Is a block with these phasors disturbed (see the fields)?
    pub fn disturbed(&self, ph: &dsp_core::demod::Phasors) -> bool {
        let [rv, ri] = ph.residual_rms();
        let limit = |amplitude: f32| self.residual_counts.max(self.residual_rel * amplitude);
        // NaN never passes.
        !(rv <= limit(ph.v_amplitude()) && ri <= limit(ph.i_amplitude()))
    }
}

#[cfg(test)]
mod names_tests {
    use super::Flags;

    #[test]
    fn every_flag_has_its_name_in_bit_order() {
        for (k, (bit, _)) in Flags::NAMES.iter().enumerate() {
            assert_eq!(*bit, 1 << k);
        }
        let f = Flags(Flags::OPEN | Flags::MODEL | Flags::OFF_TABLE | 1 << 14);
        assert_eq!(
            f.names().collect::<std::vec::Vec<_>>(),
            ["OPEN", "MODEL", "OFF_TABLE"]
        );
        assert_eq!(Flags(0).names().count(), 0);
    }
}
