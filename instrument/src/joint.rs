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
        for t in tones.iter_mut() {
            t.z = sensor.fixture.remove(t.z, t.f_hz).map_err(|_| Unsolved::Open)?;
        }
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
/// The last test: `disturbance(Some(k))` is the shift, in units of tone
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
    disturbance: &impl Fn(Option<usize>) -> f32,
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
    (misfit >= leak_ratio * disturbance(Some(out))).then_some(())?;
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
/// residual; 0 where the check failed (χ² > `chi2_flag`: the record is
/// flagged MODEL and this bound says nothing more).
///
/// The residual is the error's share plus the noise's, which can cancel
/// part of it: a χ² of 0.34 hid a one-tone error whose own share was 1.1
/// (an interferer next to the multiplexed channel's second tone, 1 % off
/// with √χ² alone). So the share is taken as √χ², but never below the
/// noise's own rms share, √dof (2 for two tones, 4 for three:
/// [`Solution::dof`]).
pub fn hidden(sol: &Solution, chi2_flag: f32) -> f32 {
    if sol.chi2 > chi2_flag {
        0.0
    } else {
        sol.hidden_ln_c * dsp_core::fmath::sqrt(dsp_core::fmath::max(sol.chi2, sol.dof))
    }
}
