//! Fault and status flags of a record. The firmware never stops for a
//! fault: it flags the record and keeps measuring; the flag clears with the
//! cause.

use crate::design;

/// Bit set of flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags(pub u8);

impl Flags {
    /// An ADC sample of the block hit a rail.
    pub const CLIPPED: u8 = 1 << 0;
    /// No current: the sensor is disconnected (open).
    pub const OPEN: u8 = 1 << 1;
    /// Not a lossy capacitor, or |Z| below the short threshold.
    pub const SHORTED: u8 = 1 << 2;
    /// The line inversion failed or was rejected (x beyond range, jump).
    pub const RANGE: u8 = 1 << 3;
    /// The channel or its frequency just changed: the block is discarded.
    pub const SETTLING: u8 = 1 << 4;
    /// C held from the previous block (ill-conditioned inversion).
    pub const HELD: u8 = 1 << 5;

    /// Is `bit` set?
    pub fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }

    /// Set `bit`.
    pub fn set(&mut self, bit: u8) {
        self.0 |= bit;
    }

    /// True if the capacitance of the record can be trusted.
    pub fn valid(self) -> bool {
        self.0 & (Self::CLIPPED | Self::OPEN | Self::SHORTED | Self::RANGE | Self::SETTLING) == 0
    }
}

/// The designed excitation at the voltage ADC, counts (amplitude).
const EXCITATION_COUNTS: f32 = (design::EXCITATION_VOLT * design::V_GAIN * design::ADC_OFFSET_CODE as f64
    / design::ADC_HALF_SCALE_VOLT) as f32;

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
}

impl Thresholds {
    /// Defaults for the front end of [`crate::design`] (12-bit ADC of
    /// ±1.65 V, 1 V excitation, 100 kΩ transimpedance): the smallest real
    /// current, a 150 pF sensor at 586 Hz, gives ≈70 counts; the noise
    /// floor of a 1024-pair block is ≈0.05 counts, so 4 counts separates
    /// them widely. No excitation: below a sixth of the designed one.
    pub const DEFAULT: Self = Self {
        open_counts: 4.0,
        no_excitation_counts: EXCITATION_COUNTS / 6.0,
        short_ohm: 1_000.0,
        r_max_ohm: 5.0e6,
    };
}
