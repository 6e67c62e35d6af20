//! The slot sequence of the acquisition, free of hardware, shared by the
//! board app and the QEMU app.
//!
//! The front end runs in slots of [`SLOT_PAIRS`] pairs: [`SETTLE_PAIRS`]
//! of multiplexer settling, then a [`BLOCK`]-pair block. Slot k measures
//! channel k mod [`CHANNELS`]. The DMA holds two slots (two halves); when
//! slot k completes, slot k + 1 is already playing from the other half, so
//! the half just finished is refilled with the waveform of slot k + 2:
//!
//! * select the multiplexer for slot k + 1 (it settles in that slot's
//!   first [`SETTLE_PAIRS`] pairs),
//! * process slot k at the frequency it was played with,
//! * prepare slot k + 2 at its channel's frequency now.
//!
//! A channel's frequency decision therefore reaches the excitation two
//! slots later; with [`CHANNELS`] > 2 that is before the channel's next
//! slot.

use crate::config::{BLOCK, CHANNELS, SETTLE_PAIRS, SLOT_PAIRS};
use crate::design::SAMPLE_RATE;

/// Duration of `pairs` ADC pairs, µs (exact for the configured rate).
pub const fn pairs_us(pairs: usize) -> u64 {
    pairs as u64 * 1_000_000 / SAMPLE_RATE as u64
}

/// One slot of the sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// Slot number since start.
    pub index: u64,
    /// The channel it measures.
    pub channel: u8,
    /// The frequency index its excitation plays.
    pub fidx: usize,
}

impl Slot {
    /// Middle of the slot's block since start, µs: the time of its record.
    pub const fn block_mid_us(&self) -> u64 {
        self.index * pairs_us(SLOT_PAIRS) + pairs_us(SETTLE_PAIRS) + pairs_us(BLOCK) / 2
    }
}

/// What to do when a slot completes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// The slot just completed: process it.
    pub done: Slot,
    /// The channel of the slot that begins now: select it.
    pub select: u8,
    /// The slot after next, to be written into the half just finished.
    pub prepare: Slot,
}

/// The sequence state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sequencer {
    /// The slot that completes next.
    next: u64,
    /// Frequency index played in the slots of each parity (DMA half).
    played: [usize; 2],
}

/// The channel slot `index` measures.
pub const fn channel_of(index: u64) -> u8 {
    (index % CHANNELS as u64) as u8
}

impl Sequencer {
    /// Start: slots 0 and 1, at the frequencies `freq_of(channel)` gives;
    /// the caller plays them and selects slot 0's channel.
    pub fn start(mut freq_of: impl FnMut(u8) -> usize) -> (Self, [Slot; 2]) {
        let slot = |index: u64, f: &mut dyn FnMut(u8) -> usize| {
            let channel = channel_of(index);
            Slot {
                index,
                channel,
                fidx: f(channel),
            }
        };
        let first = [slot(0, &mut freq_of), slot(1, &mut freq_of)];
        (
            Self {
                next: 0,
                played: [first[0].fidx, first[1].fidx],
            },
            first,
        )
    }

    /// The next slot has completed; `freq_of(channel)` is each channel's
    /// frequency index now.
    pub fn complete(&mut self, freq_of: impl FnOnce(u8) -> usize) -> Step {
        let k = self.next;
        self.next = k.saturating_add(1);
        let half = (k % 2) as usize;
        let done = Slot {
            index: k,
            channel: channel_of(k),
            fidx: self.played[half],
        };
        let ahead = k.saturating_add(2);
        let channel = channel_of(ahead);
        let prepare = Slot {
            index: ahead,
            channel,
            fidx: freq_of(channel),
        };
        self.played[half] = prepare.fidx;
        Step {
            done,
            select: channel_of(k.saturating_add(1)),
            prepare,
        }
    }

    /// The slot that completes next.
    pub fn next_index(&self) -> u64 {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_take_turns_and_play_what_was_prepared() {
        // Channel c wants frequency c % 5, until channel 3 switches to 0.
        let mut want = [0usize; CHANNELS];
        for (c, w) in want.iter_mut().enumerate() {
            *w = c % 5;
        }
        let (mut seq, first) = Sequencer::start(|c| want[c as usize]);
        assert_eq!(
            first.map(|s| (s.index, s.channel, s.fidx)),
            [(0, 0, 0), (1, 1, 1)]
        );
        let mut prepared = std::collections::BTreeMap::new();
        for s in first {
            prepared.insert(s.index, s);
        }
        for k in 0..100u64 {
            if k == 20 {
                want[3] = 0;
            }
            let st = seq.complete(|c| want[c as usize]);
            assert_eq!(st.done.index, k);
            assert_eq!(st.done.channel as u64, k % CHANNELS as u64);
            assert_eq!(st.select as u64, (k + 1) % CHANNELS as u64);
            assert_eq!(st.prepare.index, k + 2);
            // What completes is what was prepared for it.
            assert_eq!(prepared.remove(&k), Some(st.done));
            prepared.insert(st.prepare.index, st.prepare);
            if st.done.channel == 3 && k > 22 {
                assert_eq!(st.done.fidx, 0);
            }
        }
        assert_eq!(seq.next_index(), 100);
    }

    #[test]
    fn block_times_are_exact_microseconds() {
        let s = Slot {
            index: 0,
            channel: 0,
            fidx: 0,
        };
        assert_eq!(pairs_us(SLOT_PAIRS), 5440);
        assert_eq!(s.block_mid_us(), 320 + 2560);
        // A year of slots later, still to the microsecond.
        let year = 365 * 24 * 3600 * 1_000_000u64 / 5440;
        let s = Slot { index: year, ..s };
        assert_eq!(s.block_mid_us(), year * 5440 + 2880);
    }
}
