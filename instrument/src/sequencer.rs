//! The slot sequence of the acquisition, free of hardware, shared by the
//! board app and the QEMU app.
//!
//! The front end runs in slots of [`SLOT_PAIRS`] pairs: [`SETTLE_PAIRS`]
//! of multiplexer settling, then a [`BLOCK_PAIRS`]-pair block. Slot k measures
//! channel k mod [`CHANNELS`]. The DMA holds two slots (two halves); when
//! slot k completes, slot k + 1 is already playing from the other half, so
//! the half just finished is refilled with the waveform of slot k + 2:
//!
//! * select the multiplexer for slot k + 1 (it settles in that slot's
//!   first [`SETTLE_PAIRS`] pairs),
//! * process slot k at the frequency it was played with,
//! * prepare slot k + 2 at its channel's frequency and range now (the
//!   range's switch is set with the multiplexer when the slot is selected).
//!
//! A channel's frequency and range decisions therefore reach the front end
//! two slots later; with [`CHANNELS`] > 2 that is before the channel's
//! next slot.

use crate::config::{BLOCK_PAIRS, CHANNELS, SETTLE_PAIRS, SLOT_PAIRS};
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
    /// The transimpedance range its current is read through.
    pub range: u8,
}

/// What a channel wants for its next slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// Frequency index.
    pub fidx: usize,
    /// Transimpedance range ([`crate::ranging`]).
    pub range: u8,
}

/// A slot's period, µs.
pub const SLOT_US: u32 = pairs_us(SLOT_PAIRS) as u32;

/// Slots a second, rounded: how many a status of the CPU's time counts
/// ([`crate::busy`]).
pub const SLOTS_PER_S: u32 = (1_000_000 + SLOT_US / 2) / SLOT_US;

impl Slot {
    /// Middle of the slot's block since start, µs: the time of its record.
    pub const fn block_mid_us(&self) -> u64 {
        self.index * pairs_us(SLOT_PAIRS) + pairs_us(SETTLE_PAIRS) + pairs_us(BLOCK_PAIRS) / 2
    }
}

/// What to do when a slot completes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// The slot just completed: process it.
    pub done: Slot,
    /// The channel of the slot that begins now: select it.
    pub select: u8,
    /// The range of the slot that begins now: switch to it with the
    /// channel.
    pub select_range: u8,
    /// The slot after next, to be written into the half just finished.
    pub prepare: Slot,
}

/// The sequence state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sequencer {
    /// The slot that completes next.
    next: u64,
    /// The plan of the slots of each parity (DMA half) in flight.
    played: [Plan; 2],
}

/// The channel slot `index` measures.
pub const fn channel_of(index: u64) -> u8 {
    (index % CHANNELS as u64) as u8
}

impl Sequencer {
    /// Start: slots 0 and 1, as `plan_of(channel)` plans them; the caller
    /// plays them and selects slot 0's channel and range.
    pub fn start(mut plan_of: impl FnMut(u8) -> Plan) -> (Self, [Slot; 2]) {
        let mut slot = |index: u64| {
            let channel = channel_of(index);
            let p = plan_of(channel);
            Slot {
                index,
                channel,
                fidx: p.fidx,
                range: p.range,
            }
        };
        let first = [slot(0), slot(1)];
        let plan = |s: &Slot| Plan {
            fidx: s.fidx,
            range: s.range,
        };
        (
            Self {
                next: 0,
                played: [plan(&first[0]), plan(&first[1])],
            },
            first,
        )
    }

    /// The next slot has completed; `plan_of(channel)` is what each
    /// channel wants now.
    pub fn complete(&mut self, plan_of: impl FnOnce(u8) -> Plan) -> Step {
        let k = self.next;
        self.next = k.saturating_add(1);
        let half = (k % 2) as usize;
        let done = Slot {
            index: k,
            channel: channel_of(k),
            fidx: self.played[half].fidx,
            range: self.played[half].range,
        };
        let ahead = k.saturating_add(2);
        let channel = channel_of(ahead);
        let p = plan_of(channel);
        let prepare = Slot {
            index: ahead,
            channel,
            fidx: p.fidx,
            range: p.range,
        };
        self.played[half] = p;
        Step {
            done,
            select: channel_of(k.saturating_add(1)),
            select_range: self.played[1 - half].range,
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
        let plan = |f: usize| Plan {
            fidx: f,
            range: (f % 4) as u8,
        };
        let (mut seq, first) = Sequencer::start(|c| plan(want[c as usize]));
        assert_eq!(
            first.map(|s| (s.index, s.channel, s.fidx, s.range)),
            [(0, 0, 0, 0), (1, 1, 1, 1)]
        );
        let mut selected = first[0].range;
        let mut prepared = std::collections::BTreeMap::new();
        for s in first {
            prepared.insert(s.index, s);
        }
        for k in 0..100u64 {
            if k == 20 {
                want[3] = 0;
            }
            let st = seq.complete(|c| plan(want[c as usize]));
            assert_eq!(st.done.index, k);
            // The range the slot was read through is the one selected
            // with it, which is the one planned for it.
            assert_eq!(st.done.range, selected);
            selected = st.select_range;
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
            range: 0,
        };
        assert_eq!(pairs_us(SLOT_PAIRS), 5440);
        assert_eq!(s.block_mid_us(), 320 + 2560);
        // A year of slots later, still to the microsecond.
        let year = 365 * 24 * 3600 * 1_000_000u64 / 5440;
        let s = Slot { index: year, ..s };
        assert_eq!(s.block_mid_us(), year * 5440 + 2880);
    }
}
