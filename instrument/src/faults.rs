//! Fault and status flags of a record. The firmware never stops for a
//! fault: it flags the record and keeps measuring; the flag clears with the
//! cause.

use crate::design;
use dsp_core::lockin::Reading;

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
    /// step, a glitch, an interferer near the tone): on the multiplexed
    /// channel, what its lock-in's guards see near the tone; on the array,
    /// its residual after the fitted tones. Above the threshold, the tone
    /// itself may be off.
    pub const DISTURBED: u16 = 1 << 6;
    /// The line's C is not vouched for: the block's noise, and any
    /// disturbance the check above lets through, times the inversion's
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
    /// The block took longer than its period, from the end of its
    /// acquisition to its last record (the CPU fell behind): the next
    /// block's samples may have overwritten its own, so nothing of it is
    /// vouched for. Counted in the link's status frames.
    pub const LATE: u16 = 1 << 11;
    /// Status, not a fault: of the record's three tones, one disagreed
    /// with the line and the other two agree on it (an interferer in its
    /// bin, a mains harmonic or an alias on it): C and R are the line of
    /// those two, vouched for by their own check and bound.
    pub const TONE_LEFT_OUT: u16 = 1 << 12;
    /// Status, not a fault: the channel moved its tones off one that an
    /// interferer occupies (the tone its checks kept singling out): the
    /// record is read at three others, with the same checks as any
    /// (the array's; `crate::tones::Avoidance`).
    pub const TONE_MOVED: u16 = 1 << 13;
    /// The power-up self-test failed on a path the record rests on (the
    /// excitation's, the reference's check of the chain, or its sensor's
    /// stage: [`crate::selftest`]): refused, whatever the record's own
    /// checks say. The start frame says which paths failed.
    pub const SELF_TEST: u16 = 1 << 14;

    /// Every flag and its name, in bit order (as
    /// `docs/data-format.md` names them).
    pub const NAMES: [(u16, &'static str); 15] = [
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
        (Self::LATE, "LATE"),
        (Self::TONE_LEFT_OUT, "TONE_LEFT_OUT"),
        (Self::TONE_MOVED, "TONE_MOVED"),
        (Self::SELF_TEST, "SELF_TEST"),
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

    /// The faults: every flag but the statuses ([`Flags::UNCALIBRATED`],
    /// [`Flags::OFF_TABLE`], [`Flags::TONE_LEFT_OUT`], [`Flags::TONE_MOVED`]).
    pub const FAULTS: u16 = Self::CLIPPED
        | Self::OPEN
        | Self::SHORTED
        | Self::RANGE
        | Self::SETTLING
        | Self::DISTURBED
        | Self::UNCERTAIN
        | Self::HELD
        | Self::MODEL
        | Self::LATE
        | Self::SELF_TEST;

    /// True if the capacitance of the record can be trusted: no fault.
    pub fn valid(self) -> bool {
        self.0 & Self::FAULTS == 0
    }
}

/// The designed excitation at the voltage ADC, counts (amplitude).
const EXCITATION_COUNTS: f32 = (design::EXCITATION_VOLT * design::V_GAIN * design::ADC_OFFSET_CODE as f64
    / design::ADC_HALF_SCALE_VOLT) as f32;

/// The smallest tone of the array's excitation (the highest, 6 kHz, of
/// the smaller of the two layouts') at its voltage input, counts.
const ARRAY_TONE_COUNTS: f32 = ({
    let top = crate::array::TONES - 1;
    let (a, b) = (
        crate::array::Layout::BLOCK_4MS.tone_volts()[top],
        crate::array::Layout::BLOCK_1MS.tone_volts()[top],
    );
    if a < b {
        a
    } else {
        b
    }
} / design::ADC_HALF_SCALE_VOLT
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
    /// The array's comb: a channel's residual rms after its fitted tones
    /// (`dsp_core::comb::Tones::residual_rms`) above which the block is
    /// disturbed, counts, whatever the tones' amplitude.
    pub residual_counts: f32,
    /// ... or above this fraction of the channel's largest tone, if that
    /// is larger.
    pub residual_rel: f32,
    /// The multiplexed channel's lock-in: what lies near its tone beyond
    /// the noise (the larger guard's excess, [`Thresholds::near_excess`])
    /// above which the block is disturbed, counts, whatever the tone's
    /// amplitude.
    pub near_counts: f32,
    /// ... or above this fraction of the channel's tone, if that is larger.
    pub near_rel: f32,
    /// Largest relative error of C a valid record may carry, by the bound
    /// each channel puts on its records (five σ of the noise, what a
    /// disturbance could move, what the model check could hide).
    pub c_tolerance: f32,
    /// The ADC's white noise, rms counts: the part of a block's residual
    /// that is noise (its error is the 5σ term of a record's bound); only what exceeds it counts as a
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
    /// Disturbance: energy far from the tone (4.5 bins, 880 Hz, and more)
    /// does not reach the lock-in's phasor, and is not looked at. What
    /// lies near it shows in the guards: a clean block's are noise, 0.037
    /// counts per component, so an excess of 0.25 counts (about seven of
    /// that σ, beyond the noise's own share) is something there; it moves
    /// the tone by at most [`dsp_core::lockin::GUARD_BOUND`] times itself.
    /// Disturbed
    /// above max(0.25 counts, 0.15 % of the tone): the tone could be 0.5 %
    /// off. Less than that joins the error bound
    /// ([`Thresholds::near_shift`]).
    pub const DEFAULT: Self = Self {
        open_counts: 4.0,
        no_excitation_counts: EXCITATION_COUNTS / 6.0,
        short_ohm: 1_000.0,
        r_max_ohm: 5.0e6,
        residual_counts: 1.5,
        residual_rel: 0.02,
        near_counts: 0.25,
        near_rel: 0.0015,
        c_tolerance: 0.008,
        // 0.7 LSB of input noise (the STM32G4 ADC's typical, 12-bit) and
        // 0.29 LSB of quantization: 0.76 LSB rms, rounded up (a noisier
        // board's guards show more, and that is taken).
        noise_counts: 0.8,
    };

    /// Thresholds for the array ([`crate::array`]: 16-bit oversampled
    /// results, tones of 0.974 V at 250 Hz falling as f^−0.75 to 0.122 V
    /// at 4 kHz, 330 kΩ transimpedance). The smallest real current, the
    /// paper's cycled sensor (≈ 1.9 MΩ) at 250 Hz, gives ≈ 1650 counts and
    /// the excitation's smallest tone ≈ 2400; a clean block's residual is
    /// the ADC's ≈ 3.05 counts. Open below 60 counts, no excitation below a
    /// sixth of the smallest tone; disturbed above 6.4 counts (2.1× the
    /// noise, as the board's 1.5 against 0.76) or 2 % of the largest tone.
    /// The near thresholds are the multiplexed channel's (the comb has no
    /// guards) scaled to these counts. The electrodes are out of range
    /// above 10 MΩ: the documented sensors (electrodes up to twice the
    /// paper's) reach 6.3 MΩ at the peak of a 50 mm/s stretch, and the
    /// 4 ms comb's 250 Hz tone still reads 10 MΩ at x = 4.6 with the
    /// design's largest C (290 pF).
    pub const ARRAY: Self = Self {
        open_counts: 60.0,
        no_excitation_counts: ARRAY_TONE_COUNTS / 6.0,
        short_ohm: 1_000.0,
        r_max_ohm: 10.0e6,
        residual_counts: 6.4,
        residual_rel: 0.02,
        near_counts: 0.25 * crate::array::NOISE_COUNTS,
        near_rel: 0.0015,
        c_tolerance: 0.008,
        noise_counts: crate::array::NOISE_COUNTS,
    };

    /// Thresholds for the array in 1 ms blocks
    /// ([`crate::array::Layout::BLOCK_1MS`]): as [`Thresholds::ARRAY`]
    /// but for the tolerance. A record of a quarter of the conversions
    /// has twice the noise, and its bound (five σ, what the model check
    /// could hide) doubles with it: at the paper sensor's resistance peak
    /// it passes 0.8 % on four records in ten whose error stays under
    /// 0.35 %. The tolerance doubles too: a valid record is vouched for
    /// within 1.6 %.
    pub const ARRAY_1MS: Self = Self {
        c_tolerance: 0.016,
        ..Self::ARRAY
    };

    /// The array's thresholds for blocks of `layout`.
    pub fn array(layout: &crate::array::Layout) -> Self {
        if layout.instants() == crate::array::SHORT_INSTANTS {
            Self::ARRAY_1MS
        } else {
            Self::ARRAY
        }
    }

    /// What lies near a channel's tone beyond the noise, counts: the
    /// larger guard's excess √(max(0, |g|² − 2σ_g²)), `sigma_g` the guards'
    /// noise per component, counts.
    fn excess(guards: &[dsp_core::Complex32; 2], sigma_g: f32) -> f32 {
        let g2 = guards[0].norm_sqr().max(guards[1].norm_sqr());
        libm::sqrtf((g2 - 2.0 * sigma_g * sigma_g).max(0.0))
    }

    /// Each channel's noise, counts rms: the ADC's
    /// ([`Thresholds::noise_counts`]), or what the guards show if more (a
    /// noisier board, or energy near the tone).
    pub fn sigma(&self, r: &Reading, c: usize) -> f32 {
        let [p, m] = r.guards[c];
        let seen =
            libm::sqrtf((p.norm_sqr() + m.norm_sqr()) / 4.0) / r.guard_noise_gain.max(f32::MIN_POSITIVE);
        self.noise_counts.max(seen)
    }

    /// What lies near each channel's tone beyond the noise,
    /// `[voltage, current]`, counts: the larger guard's excess over what
    /// the channel's noise ([`Thresholds::noise_counts`] or more) puts
    /// there.
    pub fn near_excess(&self, r: &Reading) -> [f32; 2] {
        [0, 1].map(|c| Self::excess(&r.guards[c], self.noise_counts * r.guard_noise_gain))
    }

    /// The most what lies near the tone can have moved its V/I,
    /// relative: δ beyond the noise in each channel's larger guard moves
    /// that channel's phasor by at most
    /// [`GUARD_BOUND`](dsp_core::lockin::GUARD_BOUND)·δ counts, so V/I by
    ///
    /// ```text
    /// GUARD_BOUND·(δ_v/A_v + δ_i/A_i)
    /// ```
    ///
    /// Energy in the stop band moves it by less than −92 dB and is not
    /// counted; energy within half a bin of the tone is not seen (a second
    /// tone at the same frequency: the model check of the block's two
    /// tones sees it, [`crate::joint::hidden`]). Infinite without a tone.
    pub fn near_shift(&self, r: &Reading) -> f32 {
        let [dv, di] = self.near_excess(r);
        let e = dsp_core::lockin::GUARD_BOUND * (dv / r.v_amplitude() + di / r.i_amplitude());
        // NaN (no signal) is no bound.
        if e.is_nan() {
            f32::INFINITY
        } else {
            e
        }
    }

    /// Is a block with this reading disturbed: something near the tone
    /// beyond [`Thresholds::near_counts`] and [`Thresholds::near_rel`] of
    /// the tone?
    pub fn disturbed(&self, r: &Reading) -> bool {
        let [dv, di] = self.near_excess(r);
        let limit = |amplitude: f32| self.near_counts.max(self.near_rel * amplitude);
        // NaN never passes.
        !(dv <= limit(r.v_amplitude()) && di <= limit(r.i_amplitude()))
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
        let f = Flags(Flags::OPEN | Flags::MODEL | Flags::OFF_TABLE | 1 << 15);
        assert_eq!(
            f.names().collect::<std::vec::Vec<_>>(),
            ["OPEN", "MODEL", "OFF_TABLE"]
        );
        assert_eq!(Flags(0).names().count(), 0);
    }
}
