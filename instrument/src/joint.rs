//! The line of a block's two tones, tracked from record to record, and
//! what its model check vouches for: what the multiplexed channel
//! ([`crate::channel`]) and the array's ([`crate::tones`]) share.
//!
//! [`dsp_core::twotone`] fits one uniform line to both tones. While a
//! channel tracks its sensor the fit starts from the last line it
//! vouched for (half the work); lost or never locked, from the
//! single-tone inversions, the better of the two. Its χ² is the model
//! check ([`crate::faults::Flags::MODEL`] above the flag), and
//! [`hidden`] what an error at one tone that no residual or guard sees
//! could still hide behind a χ² that passed.

use crate::sensor::Sensor;
use dsp_core::dielectric::Dielectric;
use dsp_core::fmath;
use dsp_core::invert::{InvertError, Inverter};
use dsp_core::twotone::{self, Solution, Tone};

/// Why a block's two tones give no line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unsolved {
    /// The wiring cannot be taken out of a tone (its impedance is what
    /// the wiring alone would give): no sensor there.
    Open,
    /// Neither tone inverts to a line.
    Range,
}

impl Unsolved {
    /// The record's flag for it: OPEN or RANGE.
    pub const fn flag(self) -> u16 {
        match self {
            Self::Open => crate::faults::Flags::OPEN,
            Self::Range => crate::faults::Flags::RANGE,
        }
    }
}

/// A channel's tracked line: the last one solved consistently.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Joint {
    /// (R Ω, C F, the film's tan δ).
    line: Option<(f32, f32, f32)>,
}

impl Joint {
    /// Nothing tracked yet.
    pub const fn new() -> Self {
        Self { line: None }
    }

    /// The line `tones` fit ([`dsp_core::twotone`]): from the tracked line
    /// when its χ² passes `chi2_flag`, else also from the single-tone
    /// inversions (the branch nearest the tracked C, or `prior_farad`),
    /// whichever fits better; an error when neither inverts.
    pub fn solve<const K: usize>(
        &self,
        inv: &Inverter,
        d: &Dielectric,
        tones: &[Tone; K],
        prior_farad: f32,
        chi2_flag: f32,
    ) -> Result<Solution, InvertError> {
        let Some((r, c, t)) = self.line else {
            // Never locked: from the single-tone inversions.
            return twotone::solve(inv, d, tones, prior_farad);
        };
        // (Matched in place, not gathered into an Option of a Result: the
        // solution is 15 words, and each such move was a copy.)
        let tracked = twotone::solve_from(inv, d, tones, r, c, t);
        if let Ok(s) = &tracked {
            if s.chi2 <= chi2_flag {
                return tracked;
            }
        }
        // Lost: from the single-tone inversions, the better of the two.
        match (tracked, twotone::solve(inv, d, tones, c)) {
            (Ok(t), Ok(f)) => Ok(if f.chi2 < t.chi2 { f } else { t }),
            (Ok(t), Err(_)) => Ok(t),
            (Err(_), fresh) => fresh,
        }
    }

    /// The line `tones` (as measured, Ω) leave behind `sensor`'s wiring,
    /// by [`Joint::solve`] with its line model; out of range, the tracked
    /// line is forgotten.
    pub fn solve_behind<const N: usize, const K: usize>(
        &mut self,
        sensor: &Sensor<N>,
        d: &Dielectric,
        mut tones: [Tone; K],
        prior_farad: f32,
        chi2_flag: f32,
    ) -> Result<Solution, Unsolved> {
        sensor.fixture.take_out(&mut tones).map_err(|_| Unsolved::Open)?;
        let solved = self.solve(sensor.tracker.inverter(), d, &tones, prior_farad, chi2_flag);
        if solved.is_err() {
            self.lose();
        }
        solved.map_err(|_| Unsolved::Range)
    }

    /// Track `sol` from now on.
    pub fn keep(&mut self, sol: &Solution) {
        self.line = Some((sol.line.r_ohm, sol.line.c_farad, sol.loss_tangent));
    }

    /// Forget the tracked line (the sensor is out of range, or gone).
    pub fn lose(&mut self) {
        self.line = None;
    }
}

/// What a record of three tones may be rescued by ([`rescue`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rescue {
    /// χ² above which a pair of the three is flagged (2 degrees of
    /// freedom); NaN: no rescue.
    pub pair_flag: f32,
    /// The most a disturbance half a bin or more from every frequency the
    /// block fits leaks into a tone, per unit of the residual's √2·rms
    /// (`Layout::leak_ratio`).
    pub leak_ratio: f32,
}

impl Rescue {
    /// No rescue (a block of two tones).
    pub const NONE: Self = Self {
        pair_flag: f32::NAN,
        leak_ratio: f32::NAN,
    };
}

/// How far past its flag each pair that keeps the tone left out must
/// fail, for a rescue ([`rescue`]): one tone's error shows in both pairs
/// that hold it alike, where a misfit spread over the tones (a wiring or
/// a film the line lacks) leaves pairs near their flag.
const CLEAR: f32 = 10.0;

/// The σ, Ω, that takes a tone out of a fit: its residual and its
/// derivatives scale by 1/σ, and their squares (below 10⁻²⁶ of a
/// measured tone's) vanish in every sum, while the fit's checks, which
/// want a finite σ, pass.
const UNWEIGHTED_SIGMA_OHM: f32 = 1e20;

/// A record of three tones whose line fails the model check, rescued from
/// two of them: where leaving out exactly one tone leaves a pair that one
/// uniform line explains within the pair's own flag (χ² of 2
/// degrees of freedom, [`Rescue::pair_flag`]), the two pairs that keep that tone both fail, and
/// the tone lies further from the pair's line than a disturbance the
/// residual sees could put it from outside its bin, the misfit is that
/// tone's alone (an interferer in its bin, a mains harmonic or an alias
/// on it): the pair's line. None where no pair passes, or more than one
/// (the misfit is spread over the tones: a wiring or a film the line
/// lacks, and nothing says which tone is wrong), or with fewer than three
/// tones. `tones` as measured (the sensor's wiring is taken out here),
/// `start` the three tones' line (R Ω, C F, tan δ), where each pair's fit
/// starts.
///
/// The last test: `disturbance(k)` is the shift, in units of tone
/// k's noise, of a disturbance whose leak into the tone is the residual's
/// √2·rms; one half a bin or more from every fitted frequency leaks at
/// most [`Rescue::leak_ratio`] times that. A left-out tone no further off than
/// that may be clean, and the pair's line wrong: an alias at 404 Hz, in
/// 4 ms blocks, leaked into the 250 and 500 Hz tones, whose pair passed
/// 1.14 % off, while the clean 1 kHz tone, 24σ from it, was 3.8 times
/// the residual's shift. In its bin, an interferer 5 Hz off a tone
/// leaves it 29 times or more.
///
/// `suspect` is set to the index (into `tones`) of the tone a rescued
/// record leaves out: the evidence a channel moves its tones on
/// ([`crate::avoid`]); left as it was otherwise. (Pairs that fail by
/// less than ten times their flag are no evidence either: taken
/// as such, a film's dispersion moved channels off one tone, and the
/// three others passed the check 1.07 % off the film's C at rest.) Run only on a record
/// that failed the check: out of line, with the code that runs once a
/// record at most.
#[cold]
#[inline(never)]
pub fn rescue<const N: usize, const K: usize>(
    sensor: &Sensor<N>,
    d: &Dielectric,
    tones: &[Tone; K],
    start: (f32, f32, f32),
    by: Rescue,
    disturbance: &impl Fn(usize) -> f32,
    suspect: &mut u8,
) -> Option<Solution> {
    let Rescue {
        pair_flag,
        leak_ratio,
    } = by;
    if K != 3 || pair_flag.is_nan() || pair_flag <= 0.0 {
        return None;
    }
    let mut behind = *tones;
    for t in behind.iter_mut() {
        match sensor.fixture.remove(t.z, t.f_hz) {
            Ok(z) => t.z = z,
            Err(_) => return None,
        }
    }
    let (r, c, t) = start;
    let inv = sensor.tracker.inverter();
    let mut passed: Option<(usize, Solution)> = None;
    // The least χ² of the pairs that fail (a pair with no line fails
    // without bound).
    let mut least_failed = f32::INFINITY;
    for out in 0..K {
        // The pair: the third tone kept in the fit with no weight (so
        // that the three tones' code fits it, not a second copy of it
        // for two), its degrees of freedom the pair's.
        let mut pair = behind;
        pair[out].sigma_ohm = UNWEIGHTED_SIGMA_OHM;
        let Some(mut sol) = pair_line(inv, d, &pair, (r, c, t), pair_flag) else {
            continue;
        };
        sol.dof = (2 * (K - 1) - 2) as f32;
        if sol.chi2 <= pair_flag {
            if passed.is_some() {
                return None;
            }
            passed = Some((out, sol));
        } else {
            least_failed = least_failed.min(sol.chi2);
        }
    }
    let (out, sol) = passed?;
    if least_failed <= CLEAR * pair_flag {
        return None;
    }
    let misfit = dsp_core::twotone::misfits(inv, d, &behind, &sol).ok()?[out];
    // (NaN never passes.)
    (misfit >= leak_ratio * disturbance(out)).then_some(())?;
    *suspect = out as u8;
    Some(sol)
}

/// The line a pair of [`rescue`] fits (`pair`: three tones, one of them
/// unweighted): from the three's line `start`, or, where the pair's χ²
/// does not pass `pair_flag` from there, also from the pair's own
/// single-tone inversions, the better of the two. The tone left out can
/// throw the three's line outside the pair's basin (a mains harmonic on
/// one sensor's 500 Hz tone left its clean pair failing by 10⁴ from
/// there).
fn pair_line<const K: usize>(
    inv: &Inverter,
    d: &Dielectric,
    pair: &[Tone; K],
    (r, c, t): (f32, f32, f32),
    pair_flag: f32,
) -> Option<Solution> {
    let near = twotone::solve_from(inv, d, pair, r, c, t).ok();
    if near.as_ref().is_some_and(|s| s.chi2 <= pair_flag) {
        return near;
    }
    match (near, twotone::solve(inv, d, pair, c).ok()) {
        (Some(a), Some(b)) => Some(if b.chi2 < a.chi2 { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// What an error at one tone that nothing else sees (an interferer at
/// its frequency, an alias of it) could hide behind the χ² of `sol`,
/// relative to C: `hidden_ln_c` per unit of that error's share of the
/// residual, `share` ([`Quiet::share`]); 0 where the check failed
/// (χ² > `chi2_flag`: the record is flagged MODEL and this bound says
/// nothing more).
pub fn hidden(sol: &Solution, chi2_flag: f32, share: f32) -> f32 {
    if sol.chi2 > chi2_flag {
        0.0
    } else {
        sol.hidden_ln_c * share
    }
}

/// The share of the residual an error at one tone that nothing sees may
/// have in the block `sol` was fitted to, by that block alone: √χ², but
/// never below the noise's own rms share, √dof ([`Quiet`] says why).
pub fn own_share(sol: &Solution) -> f32 {
    fmath::sqrt(fmath::max(sol.chi2, sol.dof))
}

/// Blocks the model check's history spans ([`Quiet`]): about a second
/// of 4 ms blocks, a quarter second of 1 ms ones.
pub const QUIET_BLOCKS: u16 = 256;

/// Blocks the model check's history must hold before it bounds a block
/// ([`Quiet`]): an eighth of a second of 4 ms blocks.
pub const QUIET_MIN_BLOCKS: u16 = 32;

/// How many standard errors of the history's mean χ² its bound adds
/// ([`Quiet::share`]).
pub const QUIET_Z: f32 = 3.0;

/// The model check's χ² over the last blocks a channel read at one set of
/// tones: how large an error at one tone that nothing sees can be, where
/// it persists.
///
/// One block alone cannot tell such an error from its noise: the residual
/// holds the error's share plus the noise's, which can cancel part of
/// it (a χ² of 0.34 hid a one-tone error whose own share was 1.1, an
/// interferer next to the multiplexed channel's second tone, 1 % off with
/// √χ² alone). So a block's own share is taken as √χ², but never below
/// the noise's own rms share, √dof (√2 for two tones, 2 for three:
/// [`Solution::dof`]).
///
/// Over many blocks the noise averages out and the error does not: an
/// error of share s in every block raises the mean χ² to dof + s². After
/// n ≥ [`QUIET_MIN_BLOCKS`] blocks at one set of tones, the share is
/// bounded by the mean (of the n blocks, up to [`QUIET_BLOCKS`];
/// exponential over that many after, each block's χ² taken at most at
/// the flag) less dof, plus [`QUIET_Z`] standard errors of the mean,
/// doubled in square: an error a few hertz off its tone turns its phase
/// from block to block, and its share in one block can be up to twice
/// its mean. The standard error is √(v·Σw²), v the blocks' own variance
/// of χ² where it exceeds white noise's 2·dof (an error's share adds
/// 4·s² to it, and one that turns adds its own spread), Σw² the sum of
/// the squares of the mean's weights (1/n for the running mean, down to
/// 1/511 for the exponential one). A block whose own χ² passes half the
/// flag (for three tones' 26.6, 13.3: the 1 % point of χ² with four
/// degrees of freedom; for two tones' 18.4, 9.2, that of two) is
/// evidence of something new: its own share stands. So does it
/// until the history holds [`QUIET_MIN_BLOCKS`], and again after the
/// channel's tones change (a history of other tones says nothing of the
/// new one's bin; one kept from the last time the channel read these
/// tones, seconds ago, says nothing of now): a channel whose policy
/// moves its tones as the electrodes' resistance peaks would read its
/// peak by its own share for a second if it waited for a full history,
/// and keeps its records after an eighth of one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quiet {
    /// Mean χ² of the blocks taken (exponential over [`QUIET_BLOCKS`]).
    mean: f32,
    /// Their mean χ⁴, as the mean.
    mean_square: f32,
    /// The sum of the squares of the mean's weights, the mean's variance
    /// per unit of the blocks': 1/n for n blocks, falling to
    /// 1/(2·[`QUIET_BLOCKS`] − 1) as the exponential mean forgets the
    /// first.
    weight2: f32,
    /// Blocks taken at these tones (up to [`QUIET_BLOCKS`]).
    blocks: u16,
    /// The tones' key: their frequencies summed, Hz.
    set_hz: f32,
}

impl Quiet {
    /// No history.
    pub const fn new() -> Self {
        Self {
            mean: 0.0,
            mean_square: 0.0,
            weight2: 0.0,
            blocks: 0,
            set_hz: 0.0,
        }
    }

    /// The share of the residual an error at one tone that nothing sees
    /// may have in the block `sol` was fitted to (flagged above
    /// `chi2_flag`), at tones whose frequencies sum to `set_hz`: by this
    /// history where it is full and the block calm, else the block's own
    /// ([`own_share`]). Before [`Quiet::take`] takes the block: a block
    /// never vouches for itself. (Out of line, as [`Quiet::take`]: one
    /// copy for every kind of channel, in the boards' fast RAM.)
    #[inline(never)]
    pub fn share(&self, sol: &Solution, chi2_flag: f32, set_hz: f32) -> f32 {
        let (chi2, dof) = (sol.chi2, sol.dof);
        let own = own_share(sol);
        let held = self.set_hz == set_hz && self.blocks >= QUIET_MIN_BLOCKS;
        if !(held && chi2 <= 0.5 * chi2_flag) {
            return own;
        }
        let spread = self.mean_square - self.mean * self.mean;
        let se = fmath::sqrt(fmath::max(spread, 2.0 * dof) * self.weight2);
        let excess = fmath::max(self.mean - dof, 0.0) + QUIET_Z * se;
        fmath::min(own, fmath::sqrt(2.0 * excess))
    }

    /// Take a block's `chi2` (at most `chi2_flag`), at tones whose
    /// frequencies sum to `set_hz`; other tones than the last start the
    /// history anew.
    #[inline(never)]
    pub fn take(&mut self, chi2: f32, chi2_flag: f32, set_hz: f32) {
        if self.set_hz != set_hz {
            *self = Self {
                set_hz,
                ..Self::new()
            };
        }
        // NaN counts as the flag.
        let x = if chi2 <= chi2_flag { chi2 } else { chi2_flag };
        self.blocks = if self.blocks < QUIET_BLOCKS {
            self.blocks + 1
        } else {
            QUIET_BLOCKS
        };
        // The running means until the history is full, exponential after.
        let w = 1.0 / f32::from(self.blocks);
        self.mean += (x - self.mean) * w;
        self.mean_square += (x * x - self.mean_square) * w;
        self.weight2 = (1.0 - w) * (1.0 - w) * self.weight2 + w * w;
    }

    /// Forget the history (the line is lost).
    #[inline(never)]
    pub fn forget(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use skin_sim::rng::Rng;
    use std::println;

    /// Three tones: 4 degrees of freedom, the array's 4 ms flag.
    const DOF: f32 = 4.0;
    const FLAG: f32 = 26.6;
    const SET: f32 = 250.0 + 500.0 + 1000.0;

    fn sol(chi2: f32, dof: f32) -> Solution {
        Solution {
            line: dsp_core::invert::Line {
                r_ohm: 7e5,
                c_farad: 2e-10,
                x: 1.0,
                kappa: f32::NAN,
            },
            chi2,
            sigma_ln_c: 1e-3,
            loss_tangent: 0.0,
            hidden_ln_c: 1e-3,
            tone_ln_c2: [1e-6; 3],
            dof,
        }
    }

    fn filled(chi2: f32, set_hz: f32) -> Quiet {
        let mut q = Quiet::new();
        for _ in 0..QUIET_BLOCKS {
            q.take(chi2, FLAG, set_hz);
        }
        q
    }

    /// Below [`QUIET_MIN_BLOCKS`] a block's own share stands; from there
    /// on calm blocks bound it by 3 standard errors of their n, doubled:
    /// √(2·3·√(8/32)) = √3 at 32 blocks, falling as they fill.
    #[test]
    fn a_block_counts_only_its_own_share_until_the_history_holds_enough() {
        let mut q = Quiet::new();
        for _ in 0..QUIET_MIN_BLOCKS - 1 {
            q.take(DOF, FLAG, SET);
            assert_eq!(q.share(&sol(1.0, DOF), FLAG, SET), 2.0);
            assert_eq!(q.share(&sol(9.0, DOF), FLAG, SET), 3.0);
        }
        q.take(DOF, FLAG, SET);
        let first = q.share(&sol(9.0, DOF), FLAG, SET);
        assert!((first - fmath::sqrt(3.0)).abs() < 1e-3, "{first}");
        let mut last = first;
        for _ in QUIET_MIN_BLOCKS..QUIET_BLOCKS {
            q.take(DOF, FLAG, SET);
            let share = q.share(&sol(9.0, DOF), FLAG, SET);
            assert!(share <= last, "{share} > {last}");
            last = share;
        }
        assert!(last < 1.04, "{last}");
    }

    /// Blocks whose χ² spreads more than white noise's (an error that
    /// turns: half the blocks hold twice its mean share, half none) bound
    /// by their own spread: the share of the blocks that hold it.
    #[test]
    fn a_history_that_spreads_bounds_by_its_own_spread() {
        // (A block of χ² 13.2, just calm: its own share is 3.63.)
        for s2 in [1.0f32, 2.0, 3.0, 4.0] {
            let mut q = Quiet::new();
            for b in 0..QUIET_MIN_BLOCKS {
                q.take(DOF + if b % 2 == 0 { 2.0 * s2 } else { 0.0 }, FLAG, SET);
            }
            let share = q.share(&sol(13.2, DOF), FLAG, SET);
            assert!(share >= fmath::sqrt(2.0 * s2), "{s2}: {share}");
            // Where the blocks spread more than white noise (s⁴ > 2·dof),
            // more than white noise's spread would give, √(2·(s² + 1.5)).
            if s2 * s2 > 2.0 * DOF {
                assert!(share > fmath::sqrt(2.0 * (s2 + 1.5)), "{s2}: {share}");
            }
        }
    }

    /// Calm blocks (χ² at its mean) bound the share by 3 standard errors
    /// of their mean, doubled: √(2·3·√(8/256)) = 1.03, half the block's
    /// own least (√dof = 2).
    #[test]
    fn calm_blocks_bound_the_share_by_their_mean() {
        let q = filled(DOF, SET);
        let share = q.share(&sol(9.0, DOF), FLAG, SET);
        assert!((share - 1.0299).abs() < 1e-3, "{share}");
        // The block's own alone.
        assert_eq!(own_share(&sol(9.0, DOF)), 3.0);
        // Never above the block's own.
        assert_eq!(filled(0.0, SET).share(&sol(0.1, 0.25), FLAG, SET), 0.5);
    }

    /// An error of share s in every block raises the mean to dof + s²:
    /// the bound holds it, and twice its square for a phase that turns.
    #[test]
    fn a_persistent_error_raises_the_bound_past_its_share() {
        for s in [0.5f32, 1.0, 2.0, 3.0] {
            let q = filled(DOF + s * s, SET);
            let share = q.share(&sol(DOF, DOF), FLAG, SET);
            assert!(
                share >= s * core::f32::consts::SQRT_2 || share == 2.0,
                "{s}: {share}"
            );
        }
    }

    /// A block whose χ² passes half the flag is something new: its own
    /// share stands, however calm the blocks before.
    #[test]
    fn a_block_past_half_the_flag_keeps_its_own_share() {
        let q = filled(DOF, SET);
        assert_eq!(q.share(&sol(14.0, DOF), FLAG, SET), fmath::sqrt(14.0));
        assert!(q.share(&sol(13.0, DOF), FLAG, SET) < 1.1);
    }

    /// Other tones start the history anew, and going back to the last
    /// ones too; a block beyond the flag counts at it, NaN too.
    #[test]
    fn other_tones_start_the_history_anew() {
        let other = 500.0 + 1000.0 + 2000.0;
        let mut q = filled(DOF, SET);
        for _ in 0..10 {
            q.take(DOF, FLAG, other);
        }
        assert_eq!(q.share(&sol(4.0, DOF), FLAG, other), 2.0);
        q.take(DOF, FLAG, SET);
        assert_eq!(q.share(&sol(4.0, DOF), FLAG, SET), 2.0);
        let mut loud = filled(DOF, SET);
        loud.take(1e9, FLAG, SET);
        loud.take(f32::NAN, FLAG, SET);
        let excess = loud.mean - DOF;
        let want = 2.0 * (FLAG - DOF) / QUIET_BLOCKS as f32;
        assert!((excess - want).abs() < 1e-3 * want.max(1.0), "{excess} {want}");
        q.forget();
        assert_eq!(q, Quiet::new());
    }

    // What the history adds, drawn: an error at one tone of share s,
    // fixed or turning its phase from block to block, under white noise
    // of the check's degrees of freedom. A calm block's share is the
    // lesser of its own (√χ², at least √dof) and the history's; its own
    // falls short of its error where the noise cancels part of it (about
    // 6 % of the calm blocks drawn here), which no history mends. What
    // the history adds, a share short of the error where the block's
    // own was not, is at most 0.08 % of the calm blocks over histories
    // of every length it bounds from (QUIET_MIN_BLOCKS to 16 times
    // QUIET_BLOCKS). Its standard error from white noise's spread
    // alone, not the blocks' own, adds up to 0.12 % (and fails the
    // test).

    /// One block's χ² and its error's share: white noise in `dof`
    /// dimensions plus the error, of share `s` (fixed) or √2·s·cos φ (turning
    /// at phase `phi`: its mean square s²).
    fn block(rng: &mut Rng, dof: usize, s: f64, turning: bool, phi: f64) -> (f32, f64) {
        let e = if turning {
            std::f64::consts::SQRT_2 * s * phi.cos()
        } else {
            s
        };
        let chi2: f64 = (0..dof)
            .map(|k| {
                let z = rng.gaussian() + if k == 0 { e } else { 0.0 };
                z * z
            })
            .sum();
        (chi2 as f32, e.abs())
    }

    /// The share of calm blocks whose bound falls short of their error where
    /// their own share did not, after histories of `n` blocks, over errors
    /// of several sizes, fixed and turning.
    fn short_of(n: u16, dof: usize, flag: f32, seed: u64) -> f64 {
        let mut rng = Rng::new(seed);
        let (mut short, mut asked) = (0u64, 0u64);
        for trial in 0..6000 {
            let s = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0][trial % 6];
            let turning = trial % 12 >= 6;
            let step = rng.uniform() * std::f64::consts::PI;
            let mut phi = rng.uniform() * std::f64::consts::TAU;
            let mut q = Quiet::new();
            for _ in 0..n {
                let (chi2, _) = block(&mut rng, dof, s, turning, phi);
                q.take(chi2, flag, 1.0);
                phi += step;
            }
            for _ in 0..8 {
                let (chi2, e) = block(&mut rng, dof, s, turning, phi);
                phi += step;
                if chi2 > 0.5 * flag {
                    continue; // its own share stands
                }
                asked += 1;
                let own = own_share(&sol(chi2, dof as f32)) as f64;
                if own >= e && (q.share(&sol(chi2, dof as f32), flag, 1.0) as f64) < e {
                    short += 1;
                }
                q.take(chi2, flag, 1.0);
            }
        }
        short as f64 / asked as f64
    }

    #[test]
    fn a_short_history_bounds_as_surely_as_a_full_one() {
        // Three tones (4 degrees of freedom, the array's flag) and two (2,
        // the multiplexed channel's).
        for (dof, flag) in [(4usize, 26.6f32), (2, 18.4)] {
            // (The exponential mean's weights settle after several times its
            // span: 4,096 blocks.)
            let lengths = [
                QUIET_MIN_BLOCKS,
                2 * QUIET_MIN_BLOCKS,
                QUIET_BLOCKS / 2,
                QUIET_BLOCKS,
                2 * QUIET_BLOCKS,
                16 * QUIET_BLOCKS,
            ];
            for n in lengths {
                let short = short_of(n, dof, flag, 92 + u64::from(n));
                println!("{dof} dof, {n} blocks: {:.3} %", 100.0 * short);
                assert!(short <= 0.0008, "{dof} dof, {n} blocks: {short}");
            }
            // No history: the block's own share alone, nothing added.
            assert_eq!(short_of(0, dof, flag, 91), 0.0);
        }
    }
}
