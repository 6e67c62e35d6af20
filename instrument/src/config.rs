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

/// Frequency of set entry `i`, Hz.
/// An index beyond the set means its highest entry.
pub fn freq_hz(i: usize) -> f32 {
    PERIODS[index(i)] as f32 * SAMPLE_RATE_HZ / BLOCK_PAIRS as f32
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

/// The lock-in's reading of one block at set entry `i` (an index beyond
/// the set means its highest entry).
pub fn read(i: usize, pairs: &[[i16; 2]; BLOCK_PAIRS]) -> dsp_core::lockin::Reading {
    // A block of BLOCK_PAIRS pairs is what every lock-in of the set takes,
    // so this is never an error (an empty reading, flagged OPEN, if it
    // were).
    LOCKINS[index(i)].block(pairs).unwrap_or_default()
}
