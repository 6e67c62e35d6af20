//! The decisions every channel makes once its block's tones are read:
//! from the tones' impedances to the line a record reports, its flags,
//! and the policy's next step. The multiplexed channel
//! ([`crate::channel`]) and the array's ([`crate::tones`]) differ only in
//! how they read their tones (lock-ins with guards; a comb with its
//! residual); from there on both run [`Course::decide`], in this order:
//!
//! 1. A block flagged open, shorted, clipped or disturbed has biased
//!    tones, or none: no line; the tracked line and the policy stay.
//! 2. The line the tones leave behind the sensor's wiring
//!    ([`Joint::solve_behind`]). None: OPEN (the wiring explains the
//!    tones) or RANGE (no line inverts), and out of range a free channel
//!    falls back to its lowest frequency.
//! 3. The stretch from the sensor's calibration, and its status.
//! 4. χ² above the flag: of three tones, the line of the two that agree
//!    where the third alone disagrees ([`crate::joint::rescue`]:
//!    [`Flags::TONE_LEFT_OUT`]); else MODEL, and the line is not tracked.
//! 5. The error bound: five σ of the block's noise, what a disturbance
//!    the reader sees could have moved C by, and what an error at one
//!    tone nothing sees could hide behind χ² ([`crate::joint::hidden`]),
//!    as large as the block's own χ² or, where the last blocks at these
//!    tones were calm, their mean allows ([`Quiet`]); where one
//!    interferer spread over all the tones hides more (a record of the
//!    4 ms comb neither rescued nor moved off a tone: [`crate::spread`]),
//!    that. Beyond the
//!    tolerance, or NaN: UNCERTAIN.
//! 6. R beyond the electrodes' range, or not positive: RANGE, the line is
//!    lost and a free channel falls back.
//! 7. Otherwise the line is tracked (when χ² passed) and the policy
//!    moves on it.

use crate::faults::{Flags, Thresholds};
use crate::joint::{hidden, own_share, rescue, Joint, Quiet, Rescue, Unsolved};
use crate::policy::{Policy, PolicyState};
use crate::sensor::Sensor;
use dsp_core::dielectric::Dielectric;
use dsp_core::twotone::{Solution, Tone};

/// The bound of a spread over the tones ([`Course::decide`]'s `spread`)
/// a channel without one passes: a record of two tones has none (one
/// interferer spread over two tones is what the model check and the
/// one-tone bound see).
pub const NO_SPREAD: Option<fn(&Solution, f32, f32) -> f32> = None;

/// What a channel's decisions read: its sensor and the settings every
/// channel of its front end shares.
#[derive(Clone, Copy, Debug)]
pub struct Rules<'a, const N: usize> {
    /// The sensor: its wiring, its line's inversion, its stretch table.
    pub sensor: &'a Sensor<N>,
    /// The film between the electrodes: the sensor's where it was
    /// measured, else the material's ([`Sensor::film`]).
    pub dielectric: &'a Dielectric,
    /// Fault thresholds (the tolerance and the electrodes' range).
    pub thresholds: &'a Thresholds,
    /// χ² above which a record is flagged [`Flags::MODEL`].
    pub chi2_flag: f32,
    /// What a record of three tones that fails the check may be rescued
    /// from two of them by ([`crate::joint::rescue`]).
    pub rescue: Rescue,
    /// Frequency policy.
    pub policy: &'a Policy,
    /// The frequencies the policy moves on, Hz, ascending.
    pub set_hz: &'a [f32],
    /// What an error at one tone that nothing sees may hide in a record
    /// is bounded by the calm blocks before it ([`Quiet`]); false: by the
    /// block's own χ² alone.
    pub quiet: bool,
    /// The block's inputs show a disturbance the bound must take
    /// (`disturbance` of [`Course::decide`] is asked only then, or for a
    /// record rescued without a tone).
    pub seen: bool,
}

/// The line a record reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reading {
    /// Line capacitance, F.
    pub c_farad: f32,
    /// Line resistance (both electrodes), Ω.
    pub r_ohm: f32,
    /// χ² of the tones against one uniform line.
    pub chi2: f32,
    /// 1σ of ln C from the block's noise (relative error of C).
    pub sigma_ln_c: f32,
    /// Stretch from the calibration, mm (0 without one).
    pub stretch_mm: f32,
}

impl Reading {
    /// (C, R, χ², σ of ln C, stretch): what a record reports of the line.
    #[inline(always)]
    pub fn fields(&self) -> (f32, f32, f32, f32, f32) {
        (
            self.c_farad,
            self.r_ohm,
            self.chi2,
            self.sigma_ln_c,
            self.stretch_mm,
        )
    }
}

/// A channel's line from block to block: the last one vouched for, where
/// a fresh one starts, when the last block was, and whether the policy
/// may move the frequency.
#[derive(Clone, Copy, Debug)]
pub struct Course {
    joint: Joint,
    /// The model check's χ² over the last blocks at these tones.
    quiet: Quiet,
    prior_farad: f32,
    last_t_us: Option<u64>,
    pinned: bool,
    /// The tone the last block's rescued record left out
    /// ([`crate::joint::rescue`]'s `suspect`); [`NO_SUSPECT`]: none.
    suspect: u8,
}

/// [`Course::suspect`]'s "none".
const NO_SUSPECT: u8 = u8::MAX;

impl Course {
    /// A channel whose sensor rests at `prior_farad` (F); `pinned`: its
    /// frequency is held whatever the policy says.
    pub const fn new(prior_farad: f32, pinned: bool) -> Self {
        Self {
            joint: Joint::new(),
            quiet: Quiet::new(),
            prior_farad,
            last_t_us: None,
            pinned,
            suspect: NO_SUSPECT,
        }
    }

    /// Of the last block's tones (their index in `decide`'s `tones`),
    /// the one its record was rescued without (the other two agree, both
    /// pairs that keep it fail tenfold): where an interferer may sit.
    /// Evidence for [`crate::avoid`], not a verdict: the record is
    /// flagged as `decide` says.
    pub fn suspect(&self) -> Option<usize> {
        (self.suspect != NO_SUSPECT).then_some(usize::from(self.suspect))
    }

    /// Seconds since the previous block (0 for the first), block time
    /// `t_us` (µs) remembered for the next. f32 is exact enough for a
    /// difference, whatever the uptime.
    pub fn elapsed(&mut self, t_us: u64) -> f32 {
        let dt = self.last_t_us.map_or(0.0, |t0| {
            let us = t_us.saturating_sub(t0).min(i64::MAX as u64) as i64;
            dsp_core::fmath::i64_to_f32(us) * 1e-6
        });
        self.last_t_us = Some(t_us);
        dt
    }

    /// The decisions of the module's docs on a block's `tones` (as
    /// measured, Ω, each with its noise; lowest first), `dt_s` seconds
    /// after the previous block: the line with `flags` set, or None where
    /// there is none (`flags` says why). `disturbance(k, out)` gives what
    /// a disturbance the reader sees could have shifted tone `k` of
    /// `tones` by, in units of the tone's noise σ, where tone `out` was
    /// left out of the record (a rescue: an interferer near it may leak
    /// more into its neighbours): the part bounded tone by tone, and the
    /// part one disturbance shares among the tones (`disturbed`).
    /// `spread(sol, share, room)`, where the channel has one, gives what
    /// one interferer spread over the tones could hide behind the χ² of
    /// a record `sol` of all of them that passed ([`crate::spread`]),
    /// `share` the residual's share it may have, as
    /// [`crate::joint::hidden`]'s: ln C, relative; any value beyond
    /// `room` (what the tolerance leaves) may stand for all beyond it.
    #[allow(clippy::too_many_arguments)]
    pub fn decide<const N: usize, const K: usize>(
        &mut self,
        rules: &Rules<'_, N>,
        policy: &mut PolicyState,
        tones: [Tone; K],
        disturbance: impl Fn(usize, Option<usize>) -> [f32; 2],
        spread: Option<impl Fn(&Solution, f32, f32) -> f32>,
        dt_s: f32,
        flags: &mut Flags,
    ) -> Option<Reading> {
        const BIASED: u16 = Flags::OPEN | Flags::SHORTED | Flags::CLIPPED | Flags::DISTURBED;
        self.suspect = NO_SUSPECT;
        if flags.0 & BIASED != 0 {
            return None;
        }
        let th = rules.thresholds;
        let sensor = rules.sensor;
        let solved =
            self.joint
                .solve_behind(sensor, rules.dielectric, tones, self.prior_farad, rules.chi2_flag);
        let sol = match solved {
            Ok(sol) => sol,
            Err(why) => {
                self.lose(rules.policy, policy, why == Unsolved::Range);
                flags.set(why.flag());
                return None;
            }
        };
        let pair = self.rescued(rules, &tones, &sol, &disturbance);
        let share = self.share(rules, &tones, &sol, pair.as_ref());
        let (sol, chi2_flag) = match &pair {
            Some(p) => {
                flags.set(Flags::TONE_LEFT_OUT);
                (p, rules.rescue.pair_flag)
            }
            None => (&sol, rules.chi2_flag),
        };
        let line = sol.line;
        let out = pair.as_ref().and(self.suspect());
        let seen = rules.seen || out.is_some();
        let (stretch_mm, consistent) = check(
            sensor,
            th,
            sol,
            chi2_flag,
            share,
            seen.then_some(|k| disturbance(k, out)),
            spread.as_ref().filter(|_| pair.is_none()),
            flags,
        );
        let reading = Reading {
            c_farad: line.c_farad,
            r_ohm: line.r_ohm,
            chi2: sol.chi2,
            sigma_ln_c: sol.sigma_ln_c,
            stretch_mm,
        };
        self.follow(rules, policy, sol, consistent, dt_s, flags);
        Some(reading)
    }

    /// Where the three `tones`' line `sol` fails the model check, the line
    /// of the two that agree ([`rescue`], each tone's shift by what
    /// `disturbance` says, the suspect tone kept). (Inlined, as the rest
    /// of the record's path. The rescue reads the line's three numbers,
    /// not the solution: its address kept from calls, the channels' own
    /// path copies nothing.)
    #[inline(always)]
    fn rescued<const N: usize, const K: usize>(
        &mut self,
        rules: &Rules<'_, N>,
        tones: &[Tone; K],
        sol: &Solution,
        disturbance: &impl Fn(usize, Option<usize>) -> [f32; 2],
    ) -> Option<Solution> {
        if sol.chi2 <= rules.chi2_flag {
            return None;
        }
        let start = (sol.line.r_ohm, sol.line.c_farad, sol.loss_tangent);
        let shift = |k| {
            let [by_tone, shared] = disturbance(k, None);
            by_tone + shared
        };
        rescue(
            rules.sensor,
            rules.dielectric,
            tones,
            start,
            rules.rescue,
            &shift,
            &mut self.suspect,
        )
    }

    /// Steps 6 and 7 on the line `sol` reports: beyond the electrodes'
    /// range, or without resistance (x below what the inversion
    /// resolves), RANGE and the line is lost; otherwise it is tracked
    /// where χ² passed (`consistent`) and the policy moves on it.
    #[inline(always)]
    fn follow<const N: usize>(
        &mut self,
        rules: &Rules<'_, N>,
        policy: &mut PolicyState,
        sol: &Solution,
        consistent: bool,
        dt_s: f32,
        flags: &mut Flags,
    ) {
        let line = sol.line;
        if !(line.r_ohm > 0.0 && line.r_ohm <= rules.thresholds.r_max_ohm) {
            flags.set(Flags::RANGE);
            self.lose(rules.policy, policy, true);
            return;
        }
        if consistent {
            self.joint.keep(sol);
        }
        if !self.pinned {
            rules
                .policy
                .update_on(rules.set_hz, policy, line.r_ohm, line.c_farad, dt_s);
        }
    }

    /// The share of the record's residual an error at one tone may have
    /// ([`crate::joint::hidden`]): a rescued `pair`'s own (the history is
    /// of the three tones), else, where the rules keep one, by the model
    /// check's history ([`Quiet`]), which then takes the block `sol`
    /// (of `tones`) fitted.
    fn share<const N: usize, const K: usize>(
        &mut self,
        rules: &Rules<'_, N>,
        tones: &[Tone; K],
        sol: &Solution,
        pair: Option<&Solution>,
    ) -> f32 {
        if !rules.quiet {
            return own_share(pair.unwrap_or(sol));
        }
        let set_hz = tones.iter().fold(0.0, |a, t| a + t.f_hz);
        let share = self.quiet.share(sol, rules.chi2_flag, set_hz);
        self.quiet.take(sol.chi2, rules.chi2_flag, set_hz);
        pair.map_or(share, own_share)
    }

    /// The line is lost: nothing tracked, no history of the model check;
    /// `out_of_range`, a free channel falls back to its lowest frequency.
    fn lose(&mut self, rules: &Policy, policy: &mut PolicyState, out_of_range: bool) {
        self.joint.lose();
        self.quiet.forget();
        if out_of_range && !self.pinned {
            rules.fallback(policy);
        }
    }
}

/// Steps 3–5 of the module's docs on the line `sol` reports (rescued,
/// where it was): its stretch (the calibration's status into `flags`),
/// MODEL where its χ² exceeds `chi2_flag`, UNCERTAIN where its error
/// bound, with `share` the share of its residual an error at one tone
/// may have ([`hidden`]), and what a disturbance moved it by
/// ([`disturbed`]; None: the inputs show none), and what one interferer
/// spread over the tones hides where it hides more than an error at one
/// tone (`spread`, of a record not rescued: [`Course::decide`]'s),
/// exceeds the tolerance. Returns the stretch and whether χ² passed.
/// (Inlined: the record's path is one function in the boards' fast
/// RAM.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn check<const N: usize>(
    sensor: &Sensor<N>,
    th: &Thresholds,
    sol: &Solution,
    chi2_flag: f32,
    share: f32,
    disturbance: Option<impl Fn(usize) -> [f32; 2]>,
    spread: Option<&impl Fn(&Solution, f32, f32) -> f32>,
    flags: &mut Flags,
) -> (f32, bool) {
    let (stretch_mm, status) = sensor.read(sol.line.c_farad, th.c_tolerance);
    flags.set(status);
    let consistent = sol.chi2 <= chi2_flag;
    if !consistent {
        flags.set(Flags::MODEL);
    }
    let moved = disturbance.map_or(0.0, |d| disturbed(sol, d));
    let noise = 5.0 * sol.sigma_ln_c + moved;
    let one_tone = hidden(sol, chi2_flag, share);
    let mut bound = noise + one_tone;
    // (A record already beyond the tolerance asks no more.)
    if let Some(spread) = spread.filter(|_| consistent && bound <= th.c_tolerance) {
        bound = noise + spread_beyond(spread, sol, share, one_tone, th.c_tolerance - noise);
    }
    if bound.is_nan() || bound > th.c_tolerance {
        flags.set(Flags::UNCERTAIN);
    }
    (stretch_mm, consistent)
}

/// The larger of `one_tone` and what one interferer spread over the
/// tones hides (`spread(sol, share, room)`); NaN where that is (no
/// bound). (Out of line, in flash on a board, as the spread's bound.)
#[inline(never)]
fn spread_beyond(
    spread: &impl Fn(&Solution, f32, f32) -> f32,
    sol: &Solution,
    share: f32,
    one_tone: f32,
    room: f32,
) -> f32 {
    let along = spread(sol, share, room);
    if one_tone >= along {
        one_tone
    } else {
        along
    }
}

/// What a disturbance could have moved ln C of `sol` by, from each
/// tone's shift (`disturbance(k)`, in units of its noise) through that
/// tone's own reach ([`Solution::tone_ln_c2`]): its part bounded tone by
/// tone (a leak ratio from a tone left out or avoided, a sideband's leak
/// left) summed, and its part shared (the residual's disturbance, at
/// most whole in any one tone) in root sum of squares: the tones are
/// orthogonal over the block, so what one disturbance puts into all of
/// them holds no more energy than its whole (Bessel). σ_lnC times the
/// largest shift missed what a pair's shared shift moves (a record
/// vouched for 1.10 % off). (Unshifted, a record pays no root.)
#[inline(always)]
fn disturbed(sol: &Solution, disturbance: impl Fn(usize) -> [f32; 2]) -> f32 {
    let (mut by_tone, mut shared2) = (0.0, 0.0);
    for (k, &g2) in sol.tone_ln_c2.iter().enumerate() {
        let [b, s] = disturbance(k);
        if b != 0.0 {
            by_tone += dsp_core::fmath::sqrt(g2) * b;
        }
        if s != 0.0 {
            shared2 += g2 * (s * s);
        }
    }
    if shared2 != 0.0 {
        by_tone + dsp_core::fmath::sqrt(shared2)
    } else {
        by_tone
    }
}
