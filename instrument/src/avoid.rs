//! Moving off a tone an interferer occupies: the array's channel
//! ([`crate::tones::ToneChannel`]) reads its line from three of the
//! comb's [`TONES`]; when the model check keeps singling out one of them
//! (records rescued from the other two: [`crate::joint::rescue`]), an
//! interferer in its bin, a mains harmonic or an alias on it, the
//! channel reads at three others and flags its records
//! [`crate::faults::Flags::TONE_MOVED`].
//!
//! * **Evidence.** [`VOTES`] records rescued without the same tone
//!   within [`WINDOW_S`]; one without another tone starts over. A clean
//!   record is never rescued (its χ² passed), nor one whose misfit is
//!   spread over its tones, so on a clean skin, or one with wiring or a
//!   film the line lacks, nothing moves.
//! * **The move.** The tones left: the three highest at or below the
//!   policy's upper tone, or, with fewer there, the lowest three
//!   ([`Avoidance::fitted`]). Nothing settles: every tone is in every
//!   block. The records are checked as any (χ², bounds): a move vouches
//!   for nothing by itself.
//! * **Back.** After [`HOLD_S`] the tone is tried again; an interferer
//!   still there is found again within a few records. Another tone
//!   singled out while one is avoided replaces it after [`MIN_HOLD_S`].
//!
//! The 1 ms layout rescues nothing (no pair flag: no time for it), so it
//! never suspects a tone and never moves.

use crate::array::TONES;
use crate::tones::ToneChannel;

/// Suspicions of one tone that move the channel off it.
pub const VOTES: u8 = 8;
/// Within this many seconds of the first, s.
pub const WINDOW_S: f32 = 1.0;
/// How long a tone is avoided before it is tried again, s.
pub const HOLD_S: f32 = 10.0;
/// The least time one avoided tone is kept before another replaces it, s.
pub const MIN_HOLD_S: f32 = 1.0;

/// "No tone" for [`Avoidance`]'s tone fields.
const NONE: u8 = u8::MAX;

/// A channel's avoided tone and the evidence gathered for the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Avoidance {
    /// The comb tone avoided, or [`NONE`].
    tone: u8,
    /// The tone suspected lately, or [`NONE`].
    suspect: u8,
    /// Its suspicions so far in this window.
    votes: u8,
    /// Seconds since the window's first suspicion.
    clock_s: f32,
    /// Seconds since the move.
    held_s: f32,
}

impl Default for Avoidance {
    fn default() -> Self {
        Self::new()
    }
}

impl Avoidance {
    /// No tone avoided, no evidence.
    pub const fn new() -> Self {
        Self {
            tone: NONE,
            suspect: NONE,
            votes: 0,
            clock_s: 0.0,
            held_s: 0.0,
        }
    }

    /// The comb tone avoided, if any.
    pub fn tone(&self) -> Option<usize> {
        (self.tone != NONE).then_some(usize::from(self.tone))
    }

    /// Nothing avoided and no evidence pending: [`Avoidance::update`]
    /// without a suspect changes nothing (the record's path skips it).
    #[inline]
    pub fn idle(&self) -> bool {
        self.tone == NONE && self.votes == 0
    }

    /// What a channel reads its block at, whose policy chose the pair of
    /// upper tone `hi` ([`ToneChannel::pair_of`]): the pair its record
    /// reports, the three tones fitted, and whether they moved off the
    /// policy's ([`ToneChannel::fitted_of`]) — to three others
    /// ([`Avoidance::fitted`]), whose ends are the pair. (Out of line, in
    /// flash: the boards' fast RAM holds the rest of the record's path,
    /// which calls this only while a tone is avoided.)
    #[inline(never)]
    pub fn read_at(&self, hi: u8) -> ([usize; 2], [usize; 3], bool) {
        let pair = ToneChannel::pair_of(hi);
        let natural = ToneChannel::fitted_of(pair);
        let fitted = self.fitted(natural);
        if fitted == natural {
            (pair, natural, false)
        } else {
            ([fitted[0], fitted[2]], fitted, true)
        }
    }

    /// The three comb tones to fit, lowest first: `natural` (the
    /// policy's, whose highest is its upper tone) where it does not hold
    /// the avoided tone; else the three highest others at or below the
    /// upper tone, or, with fewer there, the lowest three others.
    pub fn fitted(&self, natural: [usize; 3]) -> [usize; 3] {
        let Some(k) = self.tone() else {
            return natural;
        };
        if !natural.contains(&k) {
            return natural;
        }
        let top = natural[2];
        let mut out = [0usize; 3];
        let mut n = 0;
        // The highest at or below the top, downwards.
        for t in (0..=top).rev() {
            if t != k && n < 3 {
                out[2 - n] = t;
                n += 1;
            }
        }
        if n == 3 {
            return out;
        }
        n = 0;
        for t in 0..TONES {
            if t != k && n < 3 {
                out[n] = t;
                n += 1;
            }
        }
        out
    }

    /// One record's evidence, `dt_s` after the previous: `suspect`, the
    /// tone of the record's `fitted` (its index there) it was rescued
    /// without (None: none). True when the channel moved (onto other
    /// tones, or back to its own). (Out of line, in flash, as
    /// [`Avoidance::read_at`].)
    #[inline(never)]
    pub fn update(&mut self, suspect: Option<usize>, fitted: &[usize; 3], dt_s: f32) -> bool {
        self.update_on(suspect.and_then(|j| fitted.get(j).copied()), dt_s)
    }

    /// [`Avoidance::update`] with the comb tone `suspect` itself.
    pub fn update_on(&mut self, suspect: Option<usize>, dt_s: f32) -> bool {
        self.held_s += dt_s;
        self.clock_s += dt_s;
        if self.tone != NONE && self.held_s >= HOLD_S {
            *self = Self::new();
            return true;
        }
        if self.votes > 0 && self.clock_s > WINDOW_S {
            self.votes = 0;
        }
        let Some(k) = suspect else {
            return false;
        };
        let k = k.min(usize::from(NONE) - 1) as u8;
        if k == self.tone {
            return false;
        }
        if self.votes == 0 || k != self.suspect {
            (self.suspect, self.votes, self.clock_s) = (k, 1, 0.0);
        } else {
            self.votes = self.votes.saturating_add(1);
        }
        let free = self.tone == NONE || self.held_s >= MIN_HOLD_S;
        if self.votes >= VOTES && free {
            *self = Self {
                tone: k,
                held_s: 0.0,
                ..Self::new()
            };
            return true;
        }
        false
    }
}
