//! The multiplexed board's excitation: the DAC plays each slot's two
//! tones from a ring of two quarter slots, and DMA1 channel 2's half- and
//! full-transfer interrupts refill the quarter just played with the one
//! after next ([`Feed`]). Two whole slots of codes would be 4.25 KiB of
//! RAM; the ring is 1.06 KiB.
//!
//! Every slot's waveform starts its block at phase 0 and its settling
//! pairs lead into it ([`fill_quarter`]); its frequency is the one the
//! sequencer planned for it, handed over at the end of the slot two
//! before ([`Feed::plan`]). A plan that comes too late (the acquisition's
//! interrupt a slot late) leaves its slot played at a stale frequency:
//! the feed says so ([`Feed::played_as_planned`]) and that slot gives no
//! record.

use dsp_core::cossin::sin_nearest;
use dsp_core::osc::dac_code_of_sum;
use instrument::config::{ftw, tones, DAC_AMPLITUDES_Q15, SETTLE_PAIRS, SLOT_PAIRS};
use instrument::design;

/// Quarters of a slot.
pub const QUARTERS: usize = 4;

/// Codes in a quarter slot (272: 1.36 ms at 200 kSa/s).
pub const QUARTER: usize = SLOT_PAIRS / QUARTERS;
const _: () = assert!(
    SLOT_PAIRS % QUARTERS == 0,
    "a slot must split into whole quarters"
);

/// The DAC's ring: two quarter slots of codes.
pub type DacRing = [u16; 2 * QUARTER];

/// Write quarter `quarter` (0..4) of a slot at frequency index `fidx`
/// into `buf`: its two tones ([`instrument::config::tones`]) at their
/// amplitudes ([`DAC_AMPLITUDES_Q15`]); the settling pairs lead into the
/// block, where both start at phase 0. Each tone has whole periods in a
/// block of 1024 pairs, so its phases fall on the sine table's points
/// and [`sin_nearest`] reads them exactly.
pub fn fill_quarter(buf: &mut [u16; QUARTER], fidx: usize, quarter: usize) {
    let [a, b] = tones(fidx);
    let first = (quarter % QUARTERS * QUARTER) as u32;
    // Phase of pair 0 of the quarter: the block starts at SETTLE_PAIRS.
    let start = |k: usize| ftw(k).wrapping_mul(first.wrapping_sub(SETTLE_PAIRS as u32));
    let (step_a, step_b) = (ftw(a), ftw(b));
    let (mut pa, mut pb) = (start(a), start(b));
    for code in buf.iter_mut() {
        *code = dac_code_of_sum(
            &[
                (sin_nearest(pa as i32), DAC_AMPLITUDES_Q15[0]),
                (sin_nearest(pb as i32), DAC_AMPLITUDES_Q15[1]),
            ],
            design::DAC_BITS,
        );
        pa = pa.wrapping_add(step_a);
        pb = pb.wrapping_add(step_b);
    }
}

/// What the DAC plays next, and which slots were played as planned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Feed {
    /// Quarters written into the ring so far: the next one written is
    /// quarter `written % 4` of slot `written / 4`, into half
    /// `written % 2`.
    written: u64,
    /// Slot and frequency index of the two slots ahead, at `slot % 2`.
    plans: [(u64, u8); 2],
    /// The frequency index of the slot being written (taken from its
    /// plan at its first quarter).
    fidx: u8,
    /// Slots played at a stale frequency (their plan came late): bit
    /// `s % 32` for slot `s`, set or cleared as the slot's first quarter
    /// is written, so it speaks for the last [`Feed::REMEMBERED`] slots.
    stale: u32,
    /// The ring lost step or its DMA failed: what plays is not known.
    stopped: bool,
}

impl Feed {
    /// Slots 0 and 1 at frequency indices `first`; the ring's two halves
    /// filled with slot 0's first two quarters, ready for the DMA.
    pub fn start(first: [usize; 2], ring: &mut DacRing) -> Self {
        let first = first.map(narrow);
        let mut feed = Self {
            written: 0,
            plans: [(0, first[0]), (1, first[1])],
            fidx: first[0],
            stale: 0,
            stopped: false,
        };
        feed.refill(ring, 0);
        feed.refill(ring, 1);
        feed
    }

    /// Slot `slot` plays at frequency index `fidx` (the sequencer's plan,
    /// two slots ahead).
    pub fn plan(&mut self, slot: u64, fidx: usize) {
        self.plans[(slot % 2) as usize] = (slot, narrow(fidx));
    }

    /// The half the DMA finishes next (the one to refill then).
    pub fn expected(&self) -> usize {
        (self.written % 2) as usize
    }

    /// Half `half` was played: write the quarter after next into it.
    /// Returns false, writing nothing and stopping the feed
    /// ([`Feed::stopped`]), if the feed was stopped or `half` is not the
    /// half expected (the ring lost step: a quarter played twice).
    pub fn refill(&mut self, ring: &mut DacRing, half: usize) -> bool {
        if self.stopped || half != self.expected() {
            self.stopped = true;
            return false;
        }
        let (slot, quarter) = (
            self.written / QUARTERS as u64,
            (self.written % QUARTERS as u64) as usize,
        );
        if quarter == 0 {
            let (planned, fidx) = self.plans[(slot % 2) as usize];
            // Still the plan of the slot two before: the whole slot plays
            // its frequency, and is said to.
            let bit = 1 << (slot % 32);
            match planned == slot {
                true => self.stale &= !bit,
                false => self.stale |= bit,
            }
            self.fidx = fidx;
        }
        let (first, second) = ring.split_at_mut(QUARTER);
        let buf = if half == 0 { first } else { second };
        if let Ok(buf) = <&mut [u16; QUARTER]>::try_from(buf) {
            fill_quarter(buf, self.fidx as usize, quarter);
        }
        self.written += 1;
        true
    }

    /// How many slots back [`Feed::played_as_planned`] can tell.
    pub const REMEMBERED: u64 = 16;

    /// Slot `slot`, one of the last [`Feed::REMEMBERED`] begun, was played
    /// throughout at the frequency planned for it (false for a slot not
    /// begun or further back: not vouched for).
    pub fn played_as_planned(&self, slot: u64) -> bool {
        let begun = self.written.div_ceil(QUARTERS as u64);
        slot < begun && begun - slot <= Self::REMEMBERED && self.stale >> (slot % 32) & 1 == 0
    }

    /// The ring's DMA failed or an interrupt came too late to tell which
    /// half was played: the excitation is not what the slots planned from
    /// here on (the board stops feeding its watchdog).
    pub fn stop(&mut self) {
        self.stopped = true;
    }

    /// The feed stopped ([`Feed::stop`], or a refill out of step).
    pub fn stopped(&self) -> bool {
        self.stopped
    }
}

/// A frequency index as the feed keeps it (an index beyond the set
/// reads as its last entry, [`instrument::config::index`]).
fn narrow(fidx: usize) -> u8 {
    instrument::config::index(fidx) as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use dsp_core::osc::{Oscillator, OscillatorState};
    use instrument::config::PERIODS;
    use std::vec::Vec;

    /// A slot's codes as the board wrote them with two oscillators
    /// (cossin, interpolating) before the ring: the reference.
    fn slot_by_oscillators(fidx: usize) -> [u16; SLOT_PAIRS] {
        let [a, b] = tones(fidx);
        let start = |k: usize| OscillatorState {
            phase: (ftw(k).wrapping_mul(SETTLE_PAIRS as u32) as i32).wrapping_neg(),
        };
        let (osc_a, osc_b) = (Oscillator::from_ftw(ftw(a)), Oscillator::from_ftw(ftw(b)));
        let (mut st_a, mut st_b) = (start(a), start(b));
        core::array::from_fn(|_| {
            let (_, sa) = osc_a.next(&mut st_a);
            let (_, sb) = osc_b.next(&mut st_b);
            dac_code_of_sum(
                &[(sa, DAC_AMPLITUDES_Q15[0]), (sb, DAC_AMPLITUDES_Q15[1])],
                design::DAC_BITS,
            )
        })
    }

    fn slot_by_quarters(fidx: usize) -> [u16; SLOT_PAIRS] {
        let mut out = [0u16; SLOT_PAIRS];
        for (q, chunk) in out.chunks_exact_mut(QUARTER).enumerate() {
            fill_quarter(chunk.try_into().unwrap(), fidx, q);
        }
        out
    }

    #[test]
    fn quarters_are_the_oscillators_slot_bit_for_bit() {
        for fidx in 0..PERIODS.len() {
            assert_eq!(slot_by_quarters(fidx), slot_by_oscillators(fidx), "fidx {fidx}");
        }
    }

    /// Against the f64 waveform: within half a code plus the sine
    /// table's rounding (the phases are exact), and 0 at the block's
    /// start, where both tones are at phase 0.
    #[test]
    fn quarters_hold_the_two_tones() {
        let half = (1u32 << (design::DAC_BITS - 1)) as f64;
        for fidx in 0..PERIODS.len() {
            let [a, b] = tones(fidx);
            let codes = slot_by_quarters(fidx);
            for (j, &code) in codes.iter().enumerate() {
                let n = j as f64 - SETTLE_PAIRS as f64;
                let tone = |k: usize, amp: i16| {
                    let cycles = ftw(k) as f64 / 2f64.powi(32);
                    (2.0 * core::f64::consts::PI * cycles * n).sin() * amp as f64 / 32768.0
                };
                let want = half + half * (tone(a, DAC_AMPLITUDES_Q15[0]) + tone(b, DAC_AMPLITUDES_Q15[1]));
                assert!(
                    (code as f64 - want).abs() <= 0.5 + 1e-6,
                    "fidx {fidx} pair {j}: {code} vs {want}"
                );
            }
            assert_eq!(codes[SETTLE_PAIRS] as u32, 1 << (design::DAC_BITS - 1));
        }
    }

    /// The DMA's halves as the interrupts see them: the slots' codes come
    /// out of the ring in order, each slot at the frequency planned two
    /// slots ahead.
    #[test]
    fn the_ring_plays_each_slot_as_planned() {
        let fidx_of = |slot: u64| ((slot * 3 + 1) % PERIODS.len() as u64) as usize;
        let mut ring = [0u16; 2 * QUARTER];
        let mut feed = Feed::start([fidx_of(0), fidx_of(1)], &mut ring);
        let mut played = Vec::new();
        for event in 0u64..4 * 12 {
            let half = (event % 2) as usize;
            played.extend_from_slice(&ring[half * QUARTER..(half + 1) * QUARTER]);
            assert!(feed.refill(&mut ring, half));
            // The end of slot s (its last quarter played): the sequencer
            // plans slot s + 2.
            if event % 4 == 3 {
                let s = event / 4;
                feed.plan(s + 2, fidx_of(s + 2));
            }
        }
        for (s, slot) in played.chunks_exact(SLOT_PAIRS).enumerate() {
            assert_eq!(slot, slot_by_quarters(fidx_of(s as u64)), "slot {s}");
            assert!(feed.played_as_planned(s as u64));
        }
    }

    /// A plan that comes a slot late: its slot plays the stale frequency
    /// and is marked; the slots after it play as planned again.
    #[test]
    fn a_late_plan_marks_its_slot() {
        let mut ring = [0u16; 2 * QUARTER];
        let mut feed = Feed::start([0, 1], &mut ring);
        let mut played = Vec::new();
        for event in 0u64..4 * 6 {
            let half = (event % 2) as usize;
            played.extend_from_slice(&ring[half * QUARTER..(half + 1) * QUARTER]);
            assert!(feed.refill(&mut ring, half));
            if event % 4 == 3 {
                let s = event / 4;
                match s {
                    // The end of slot 1 served a slot late, with slot 2's.
                    1 => {}
                    2 => {
                        feed.plan(3, 4);
                        feed.plan(4, 2);
                    }
                    _ => feed.plan(s + 2, 2),
                }
            }
        }
        let slots: Vec<&[u16]> = played.chunks_exact(SLOT_PAIRS).collect();
        // Slot 3's plan came at its end: it played slot 1's frequency.
        assert_eq!(slots[3], slot_by_quarters(1));
        assert!(!feed.played_as_planned(3));
        assert_eq!(slots[4], slot_by_quarters(2));
        assert!(feed.played_as_planned(4) && feed.played_as_planned(2));
    }

    /// Plans late for two slots running (the acquisition's interrupt held
    /// off for two slots): both are marked, each asked about later still
    /// says so; a slot far back or not begun is not vouched for.
    #[test]
    fn two_late_plans_running_mark_both_slots() {
        let mut ring = [0u16; 2 * QUARTER];
        let mut feed = Feed::start([0, 1], &mut ring);
        for event in 0u64..4 * 8 {
            assert!(feed.refill(&mut ring, (event % 2) as usize));
            if event % 4 == 3 {
                let s = event / 4;
                match s {
                    // The ends of slots 1 and 2 served late, at slot 3's.
                    1 | 2 => {}
                    3 => {
                        for k in 3..=5 {
                            feed.plan(k, 2);
                        }
                    }
                    _ => feed.plan(s + 2, 2),
                }
            }
        }
        // Quarters of slot 8 are being written.
        assert!(!feed.played_as_planned(3) && !feed.played_as_planned(4));
        assert!(feed.played_as_planned(2) && feed.played_as_planned(5));
        assert!(!feed.played_as_planned(9), "not begun");
        for _ in 0..4 * Feed::REMEMBERED {
            let half = feed.expected();
            assert!(feed.refill(&mut ring, half));
            let s = feed.written / 4;
            feed.plan(s + 2, 2);
        }
        assert!(!feed.played_as_planned(5), "too far back to tell");
    }

    #[test]
    fn a_half_out_of_step_is_refused() {
        let mut ring = [0u16; 2 * QUARTER];
        let mut feed = Feed::start([0, 0], &mut ring);
        let before = ring;
        assert!(!feed.stopped());
        assert!(!feed.refill(&mut ring, 1));
        assert_eq!(ring, before);
        assert!(feed.stopped());
        // Stopped for good: the next refill writes nothing either.
        assert!(!feed.refill(&mut ring, 0));
        assert_eq!(ring, before);
    }
}
