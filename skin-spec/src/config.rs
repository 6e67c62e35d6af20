//! Fixed configuration of the front end.

use crate::design::SAMPLE_RATE;

/// The pair sample rate ([`crate::design::SAMPLE_RATE`]) as `f32`, Hz.
pub const SAMPLE_RATE_HZ: f32 = SAMPLE_RATE as f32;
/// log2 of the pairs in one demodulation block.
pub const BLOCK_LOG2: u32 = 10;
/// Pairs in one demodulation block (5.12 ms at 200 kSa/s).
pub const BLOCK_PAIRS: usize = 1 << BLOCK_LOG2;
/// Pairs discarded after each multiplexer switch (analog settling, 0.32 ms).
pub const SETTLE_PAIRS: usize = 64;
/// Pairs in one slot: settling, then the block.
pub const SLOT_PAIRS: usize = SETTLE_PAIRS + BLOCK_PAIRS;
/// Sensor channels behind the analog multiplexer.
pub const CHANNELS: usize = 8;
/// Address lines of the sensor multiplexer (A0..A2): one per bit of the
/// channel number.
pub const MUX_ADDRESS_LINES: usize = 3;
const _: () = assert!(1 << MUX_ADDRESS_LINES == CHANNELS);
/// Address lines of the transimpedance range switch: one per bit of the
/// range number.
pub const RANGE_ADDRESS_LINES: usize = 2;
const _: () = assert!(1 << RANGE_ADDRESS_LINES == crate::design::RANGES);
/// Block duration, s.
pub const BLOCK_S: f32 = BLOCK_PAIRS as f32 / SAMPLE_RATE_HZ;
/// One slot per channel: settling plus a block, s.
pub const SLOT_S: f32 = (BLOCK_PAIRS + SETTLE_PAIRS) as f32 / SAMPLE_RATE_HZ;

/// The excitation frequencies, as whole periods per block (k·f_s/N):
/// 586, 977, 1953, 3906, 5859 Hz. Ascending.
pub const PERIODS: [u32; 5] = [3, 5, 10, 20, 30];

/// The set's frequencies, Hz, ascending: k·f_s/N for each entry of
/// [`PERIODS`].
pub const FREQS_HZ: [f32; PERIODS.len()] = {
    let mut f = [0.0; PERIODS.len()];
    let mut i = 0;
    while i < PERIODS.len() {
        f[i] = PERIODS[i] as f32 * SAMPLE_RATE_HZ / BLOCK_PAIRS as f32;
        i += 1;
    }
    f
};

/// Frequency of set entry `i`, Hz.
/// An index beyond the set means its highest entry.
pub const fn freq_hz(i: usize) -> f32 {
    FREQS_HZ[index(i)]
}

/// Oscillator tuning word of set entry `i` (an index beyond the set means
/// its highest entry).
pub const fn ftw(i: usize) -> u32 {
    PERIODS[index(i)] << (32 - BLOCK_LOG2)
}

/// `i` as an index of the frequency set: saturated to its last entry.
pub const fn index(i: usize) -> usize {
    if i < PERIODS.len() {
        i
    } else {
        PERIODS.len() - 1
    }
}

/// The second tone of each frequency of the set (an index of the set):
/// every block carries two tones, the policy's and this one, so that one
/// line must explain both ([`dsp_core::twotone`]): the model check an
/// interferer at the tone's own frequency, an alias of it, or an
/// undeclared contact or cable capacitance cannot pass. A lower tone of
/// the set (a factor 2–4 below) where there is one at least five bins
/// away, so that neither tone reaches the other's lock-in
/// ([`dsp_core::lockin::STOP_BAND_BINS`]), else 1953 Hz above: 586 →
/// 1953, 977 → 1953, 1953 → 977, 3906 → 977, 5859 → 1953 Hz. Never the
/// 3-period tone, whose lock-in solves for the block's mean as well
/// (half again the second tone's work).
pub const COMPANION: [usize; PERIODS.len()] = [2, 2, 1, 1, 2];
const _: () = {
    let mut i = 0;
    while i < PERIODS.len() {
        let (a, b) = (PERIODS[i], PERIODS[COMPANION[i]]);
        assert!(a.abs_diff(b) >= 5);
        i += 1;
    }
};

/// Each tone's share of the excitation's amplitude, the policy's first:
/// together the designed amplitude ([`crate::design::EXCITATION_VOLT`]),
/// so the block's peak stays where one tone put it.
pub const TONE_SHARES: [f32; 2] = [0.6, 0.4];

/// Each tone's amplitude as the DAC's Q15 amplitude, the policy's first.
pub const DAC_AMPLITUDES_Q15: [i16; 2] = [
    (crate::design::DAC_AMPLITUDE_Q15 as f32 * TONE_SHARES[0] + 0.5) as i16,
    (crate::design::DAC_AMPLITUDE_Q15 as f32 * TONE_SHARES[1] + 0.5) as i16,
];

/// The set entries of the two tones a block at set entry `i` plays, the
/// policy's first (an index beyond the set means its highest entry).
pub const fn tones(i: usize) -> [usize; 2] {
    let i = index(i);
    [i, COMPANION[i]]
}

/// The two tones' frequencies at set entry `i`, Hz, the policy's first.
pub fn tones_hz(i: usize) -> [f32; 2] {
    tones(i).map(freq_hz)
}

/// Pairs in half a block: the lock-ins store half their reference.
pub const HALF_BLOCK: usize = BLOCK_PAIRS / 2;

/// What the lock-ins of the frequency set share: the rotation to their
/// guard bins and the window (3 KiB, in flash).
pub static BASIS: dsp_core::lockin::Basis<HALF_BLOCK> = dsp_core::lockin::Basis::new();

/// The lock-ins of the frequency set ([`dsp_core::lockin`]: Nuttall's
/// window, a guard bin either side), computed at compile time: their
/// references (2 KiB each) live in flash, and a frequency switch costs
/// nothing.
pub static LOCKINS: [dsp_core::lockin::Lockin<HALF_BLOCK>; PERIODS.len()] = [
    dsp_core::lockin::Lockin::new(PERIODS[0], &BASIS),
    dsp_core::lockin::Lockin::new(PERIODS[1], &BASIS),
    dsp_core::lockin::Lockin::new(PERIODS[2], &BASIS),
    dsp_core::lockin::Lockin::new(PERIODS[3], &BASIS),
    dsp_core::lockin::Lockin::new(PERIODS[4], &BASIS),
];

/// One block through the lock-ins of its two tones ([`tones`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Readings {
    /// The policy's tone, with its guards.
    pub tone: dsp_core::lockin::Reading,
    /// The second tone, alone.
    pub companion: dsp_core::lockin::Phasors,
}

/// The lock-ins' reading of one block at set entry `i` (an index beyond
/// the set means its highest entry).
pub fn read(i: usize, pairs: &[[i16; 2]; BLOCK_PAIRS]) -> Readings {
    let [a, b] = tones(i);
    // A block of BLOCK_PAIRS pairs is what every lock-in of the set takes,
    // so these are never errors (empty readings, flagged OPEN, if they
    // were).
    Readings {
        tone: LOCKINS[a].block(pairs).unwrap_or_default(),
        companion: LOCKINS[b].tone(pairs).unwrap_or_default(),
    }
}
