//! How the device's CPU keeps up with its blocks: the time from the end
//! of each block's acquisition to its last record queued, counted on the
//! device's clock (the board's cycle counter; in QEMU, instructions),
//! summed into a [`link::Status`] about once a second. A block that took
//! longer than its period is late: the DMA may have overwritten its
//! samples with the next block's, so its records are flagged
//! [`Flags::LATE`](crate::faults::Flags::LATE); a block that arrived
//! while another was still due is missed. Neither is ever silent.

use link::{Clock, Status};

/// The counts since the last status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Busy {
    clock: Clock,
    clock_hz: u32,
    /// A block's period, clock units.
    period: u32,
    /// Blocks between two statuses.
    every: u32,
    blocks: u32,
    sum: u64,
    max: u32,
    late: u32,
    missed: u32,
}

impl Busy {
    /// Counts on `clock` at `clock_hz` for blocks of `block_us`, a
    /// status every `every` blocks (at least one).
    pub const fn new(clock: Clock, clock_hz: u32, block_us: u32, every: u32) -> Self {
        let period = (clock_hz as u64 * block_us as u64 / 1_000_000) as u32;
        Self {
            clock,
            clock_hz,
            period,
            every: if every == 0 { 1 } else { every },
            blocks: 0,
            sum: 0,
            max: 0,
            late: 0,
            missed: 0,
        }
    }

    /// A block's period, clock units.
    pub fn period(&self) -> u32 {
        self.period
    }

    /// A block took `spent` from its acquisition's end to its last
    /// record: whether it was late (longer than its period).
    pub fn block(&mut self, spent: u32) -> bool {
        self.blocks = self.blocks.saturating_add(1);
        self.sum = self.sum.saturating_add(u64::from(spent));
        self.max = self.max.max(spent);
        let late = spent > self.period;
        if late {
            self.late = self.late.saturating_add(1);
        }
        late
    }

    /// A block never processed (the one before was still due).
    pub fn missed(&mut self) {
        self.missed = self.missed.saturating_add(1);
    }

    /// The status due after the block at `t_us`, if one is (every
    /// `every` blocks): the counts since the last, which start again.
    pub fn due(&mut self, t_us: u64) -> Option<Status> {
        if self.blocks < self.every {
            return None;
        }
        let status = Status {
            t_us,
            clock: self.clock,
            clock_hz: self.clock_hz,
            period: self.period,
            blocks: self.blocks,
            mean: (self.sum / u64::from(self.blocks)) as u32,
            max: self.max,
            late: self.late,
            missed: self.missed,
        };
        *self = Self::new_like(self);
        Some(status)
    }

    /// The same settings, no counts.
    const fn new_like(b: &Self) -> Self {
        Self {
            blocks: 0,
            sum: 0,
            max: 0,
            late: 0,
            missed: 0,
            ..*b
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_status_every_n_blocks_with_mean_max_late_and_missed() {
        // 4 ms blocks at 170 MHz: 680 000 cycles; a status a second.
        let mut b = Busy::new(Clock::Cycles, 170_000_000, 4000, 250);
        assert_eq!(b.period(), 680_000);
        for k in 0..249u32 {
            assert!(!b.block(100_000 + k));
            assert_eq!(b.due(u64::from(k)), None);
        }
        b.missed();
        assert!(b.block(700_000));
        let s = b.due(999).unwrap();
        assert_eq!(
            (s.blocks, s.late, s.missed, s.max, s.t_us),
            (250, 1, 1, 700_000, 999)
        );
        let sum: u64 = (0..249u64).map(|k| 100_000 + k).sum::<u64>() + 700_000;
        assert_eq!(u64::from(s.mean), sum / 250);
        assert_eq!(
            (s.clock, s.clock_hz, s.period),
            (Clock::Cycles, 170_000_000, 680_000)
        );
        // The counts start again.
        assert!(!b.block(5));
        assert_eq!(b.due(1), None);
    }

    #[test]
    fn saturates_and_never_divides_by_zero() {
        let mut b = Busy::new(Clock::Instructions, 170_000_000, 1000, 0);
        assert_eq!(b.due(0), None);
        assert!(b.block(u32::MAX));
        let s = b.due(0).unwrap();
        assert_eq!((s.blocks, s.mean, s.max, s.late), (1, u32::MAX, u32::MAX, 1));
    }
}
