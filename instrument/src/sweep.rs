//! A calibration step's sweep of the array's tone pairs
//! ([`link::Request::Sweep`]): for a while, every sensor's records step
//! through each pair of tones in turn, whatever the tone policy would
//! choose, so that a hold of a calibration sees each sensor at every
//! frequency the comb has; then the policy again. Nothing else changes:
//! the comb measures every tone in every block, so a forced pair needs
//! no settling, and the tracker and the policy follow each block as ever.

use crate::array::TONES;

/// The pairs a sweep steps through: the upper tone index of each
/// ([`crate::tones::ToneChannel::pair_of`]), every tone covered.
pub const PAIRS: [u8; TONES - 1] = {
    let mut p = [0u8; TONES - 1];
    let mut k = 0;
    while k < TONES - 1 {
        p[k] = k as u8 + 1;
        k += 1;
    }
    p
};

/// A sweep under way, or none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sweep {
    /// Blocks at each pair (0: no sweep).
    blocks_per_pair: u16,
    /// Blocks of the sweep done.
    done: u32,
}

impl Sweep {
    /// No sweep.
    pub const fn new() -> Self {
        Self {
            blocks_per_pair: 0,
            done: 0,
        }
    }

    /// Start a sweep of `blocks_per_pair` blocks at each pair (from the
    /// next block; a sweep under way starts over).
    pub fn start(&mut self, blocks_per_pair: u16) {
        *self = Self {
            blocks_per_pair,
            done: 0,
        };
    }

    /// The pair (its upper tone index) the next block is measured at, or
    /// None once the sweep is over (or none was asked); call once per
    /// block.
    pub fn next_block(&mut self) -> Option<u8> {
        if self.blocks_per_pair == 0 {
            return None;
        }
        let k = (self.done / u32::from(self.blocks_per_pair)) as usize;
        match PAIRS.get(k) {
            Some(&p) => {
                self.done += 1;
                Some(p)
            }
            None => {
                *self = Self::new();
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sweep_steps_through_every_pair_then_ends() {
        let mut s = Sweep::new();
        assert_eq!(s.next_block(), None);
        s.start(3);
        let seen: std::vec::Vec<Option<u8>> = (0..14).map(|_| s.next_block()).collect();
        let want: std::vec::Vec<Option<u8>> = [1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4]
            .iter()
            .map(|&p| Some(p))
            .chain([None, None])
            .collect();
        assert_eq!(seen, want);
        // Every tone is in some pair.
        let mut covered = [false; TONES];
        for p in PAIRS {
            for t in crate::tones::ToneChannel::pair_of(p) {
                covered[t] = true;
            }
        }
        assert!(covered.iter().all(|&c| c));
        // Started again mid-way: from the first pair.
        s.start(2);
        s.next_block();
        s.start(1);
        assert_eq!(s.next_block(), Some(1));
    }
}
