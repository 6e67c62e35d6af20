//! One sensor of the array ([`crate::array`]): from the comb's phasors of
//! a block to a line-corrected record with its model check.
//!
//! Every block carries the sensor's current at all [`TONES`] tones of the
//! comb. The channel reads a pair of them: the policy's tone (the highest
//! whose x̂ = 2π·f·R̂·C stays within the bound, as [`crate::policy`]
//! chooses one frequency for the multiplexed board) and the one two steps
//! below it (a factor 3–4 lower; the lowest pair when the policy sits at
//! the bottom). The pair's impedances and the tone between them (the one
//! above, for the lowest pair: [`ToneChannel::fitted_of`]), each with its
//! noise from the block, give the line by [`dsp_core::twotone`]: from the
//! previous record's line while the channel tracks its sensor, from the
//! single-tone inversions otherwise. χ² (4 degrees of freedom) says
//! whether one uniform line explains the three tones; a record where it
//! does not is flagged [`Flags::MODEL`].
//!
//! Why three: an error at one tone that no residual sees (an interferer
//! at the tone's frequency, or at an alias of it, 4 Hz from a tone of a
//! 4 ms block) moves a two-tone line along what the two tones cannot
//! tell apart, and χ² sees little of it: an alias 4 Hz from the 500 Hz
//! tone left a record 1.03 % off behind χ² = 6.2. A third tone sees it:
//! what such an error can move C by per unit of √χ² falls about five-fold
//! ([`dsp_core::twotone::Solution::hidden_ln_c`]), and the record's bound
//! ([`crate::joint::hidden`]) with it. Switching tones needs no settling:
//! the excitation never changes. A tone an interferer occupies (records
//! rescued from the other two, again and again) is left out of the next
//! records' three ([`crate::avoid`]).

use crate::array::SENSORS;
use crate::array::{Layout, TONES};
use crate::avoid::Avoidance;
use crate::decide::{Course, Rules};
use crate::faults::{Flags, Thresholds};
use crate::joint::Rescue;
use crate::policy::{Policy, PolicyState};
use crate::sensor::{Sensor, Sensors};
use dsp_core::comb::{Levels, Tones};
use dsp_core::demod::FrontEnd;
use dsp_core::dielectric::Dielectric;
use dsp_core::fmath;
use dsp_core::twotone::{self, Solution, Tone};
use dsp_core::Complex32;

/// What every sensor of the array shares, and each sensor.
#[derive(Clone, Copy, Debug)]
pub struct ToneSettings<'a, const N: usize> {
    /// The blocks' layout: their tones and residual (the reader's; the
    /// model check's flag `chi2_flag` is set for its degrees of freedom).
    pub layout: Layout,
    /// Tone policy (its `settle_blocks` is not used: nothing settles).
    pub policy: Policy,
    /// Fault thresholds, in the array ADC's counts.
    pub thresholds: Thresholds,
    /// The transimpedance k in Z = k·V/I.
    pub front_end: FrontEnd,
    /// Each sensor: its line model and inversion (its tab leads), its
    /// wiring, its stretch table.
    pub sensors: &'a Sensors<N, SENSORS>,
    /// The film between the electrodes: its loss tangent, taken into the
    /// line, and the model's error floor added to each tone's noise
    /// ([`dsp_core::dielectric::Dielectric`]); the material's, for each
    /// sensor whose own was not measured ([`Sensor::film`]).
    pub dielectric: Dielectric,
    /// χ² above which a record is flagged [`Flags::MODEL`].
    pub chi2_flag: f32,
    /// χ² above which a pair of a record's three tones is flagged, for a
    /// record rescued from two of them ([`crate::joint::rescue`]); NaN:
    /// no rescue (the 1 ms layout's default).
    pub chi2_pair_flag: f32,
    /// One block's records reported in every this many
    /// ([`crate::reader::ArrayReader::solve`]).
    pub record_every: u8,
    /// The pair (its upper tone index) every sensor is measured at in
    /// this block, whatever the policy says: a calibration step's sweep
    /// ([`crate::sweep::Sweep`]); None: the policy's.
    pub sweep: Option<u8>,
}

impl<'a, const N: usize> ToneSettings<'a, N> {
    /// The settings every array application starts from: the default
    /// policy, the array's thresholds for the layout
    /// ([`Thresholds::array`]), a silicone film
    /// ([`Dielectric::SILICONE`]), the model check's flag at a 10⁻⁴ false
    /// rate for the layout's residual degrees of freedom; the layout, the
    /// front end and the sensors are the application's.
    pub fn new(layout: Layout, front_end: FrontEnd, sensors: &'a Sensors<N, SENSORS>) -> Self {
        Self {
            layout,
            policy: Policy::DEFAULT,
            thresholds: Thresholds::array(&layout),
            front_end,
            sensors,
            dielectric: Dielectric::SILICONE,
            chi2_flag: twotone::chi2_flag_of(1e-4, 3, layout.residual_dof()),
            // A record that fails the check takes three more solves to be
            // rescued: 4 ms blocks have room for them, 1 ms blocks not
            // (docs/benchmarks.md: 80 % of the core already).
            chi2_pair_flag: if layout.block_us() >= 4000 {
                twotone::chi2_flag_of(1e-4, 2, layout.residual_dof())
            } else {
                f32::NAN
            },
            record_every: 1,
            sweep: None,
        }
    }
}

impl<const N: usize> ToneSettings<'_, N> {
    /// All but the sensors.
    pub fn common(&self) -> ToneCommon {
        ToneCommon {
            layout: self.layout,
            policy: self.policy,
            thresholds: self.thresholds,
            front_end: self.front_end,
            dielectric: self.dielectric,
            chi2_flag: self.chi2_flag,
            chi2_pair_flag: self.chi2_pair_flag,
            record_every: self.record_every,
            sweep: self.sweep,
        }
    }
}

/// The array's settings but the sensors: what a device keeps beside
/// sensors it rebuilds in place when a new set comes into force while it
/// runs (fields as [`ToneSettings`]').
#[derive(Clone, Copy, Debug)]
pub struct ToneCommon {
    /// The blocks' layout.
    pub layout: Layout,
    /// Tone policy.
    pub policy: Policy,
    /// Fault thresholds, in the array ADC's counts.
    pub thresholds: Thresholds,
    /// The transimpedance k in Z = k·V/I.
    pub front_end: FrontEnd,
    /// The film between the electrodes.
    pub dielectric: Dielectric,
    /// χ² above which a record is flagged [`Flags::MODEL`].
    pub chi2_flag: f32,
    /// χ² above which a pair of a record's three tones is flagged.
    pub chi2_pair_flag: f32,
    /// One block's records reported in every this many.
    pub record_every: u8,
    /// A calibration step's pair, or None: the policy's.
    pub sweep: Option<u8>,
}

impl ToneCommon {
    /// The settings of these and `sensors`.
    pub fn with<const N: usize>(self, sensors: &Sensors<N, SENSORS>) -> ToneSettings<'_, N> {
        ToneSettings {
            layout: self.layout,
            policy: self.policy,
            thresholds: self.thresholds,
            front_end: self.front_end,
            sensors,
            dielectric: self.dielectric,
            chi2_flag: self.chi2_flag,
            chi2_pair_flag: self.chi2_pair_flag,
            record_every: self.record_every,
            sweep: self.sweep,
        }
    }
}

/// One record of an array sensor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToneRecord {
    /// Middle of the block since start, µs.
    pub t_us: u64,
    /// Sensor.
    pub sensor: u8,
    /// The two tones' frequencies, Hz, lower first.
    pub f_hz: [f32; 2],
    /// The measured impedance at each, Ω (0 when not measured; the tone
    /// between them, fitted too, is not reported).
    pub z: [Complex32; 2],
    /// Line capacitance, F (0 when not available).
    pub c_farad: f32,
    /// Line resistance (both electrodes), Ω.
    pub r_ohm: f32,
    /// χ² of the fitted tones (the pair and the one between them) against
    /// one uniform line (4 degrees of freedom; 0 when not solved).
    pub chi2: f32,
    /// 1σ relative error of C from the block's noise.
    pub sigma_ln_c: f32,
    /// Stretch from the calibration, mm.
    pub stretch_mm: f32,
    /// Flags.
    pub flags: Flags,
}

/// One input of a block: the comb's sums (borrowed: they are 104 bytes)
/// and, computed once from them, every tone's amplitude and the residual.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input<'a> {
    /// The comb's sums.
    pub tones: &'a Tones<TONES>,
    /// Amplitudes and residual.
    pub levels: Levels<TONES>,
    /// Each tone's noise, times what the residual gives: above 1 where
    /// a hum was taken out of the levels ([`dsp_core::hum`]).
    pub gains: [f32; TONES],
    /// What an interferer whose sideband was taken out may still have
    /// moved each tone's phasor by, counts (None: none taken out;
    /// [`crate::sideband`]).
    pub leak: Option<[f32; TONES]>,
}

impl<'a> Input<'a> {
    /// An input's sums with their levels (the reader may then take a
    /// hum out of them: [`crate::mains`]).
    pub fn of(tones: &'a Tones<TONES>) -> Self {
        Self {
            levels: tones.levels(),
            tones,
            gains: [1.0; TONES],
            leak: None,
        }
    }
}

/// State of one array sensor.
#[derive(Clone, Copy, Debug)]
pub struct ToneChannel {
    /// Tone policy state (`fidx`: the higher tone).
    pub policy: PolicyState,
    /// The line from block to block.
    course: Course,
    /// The tone an interferer occupies, kept out of the fit.
    pub avoidance: Avoidance,
}

impl ToneChannel {
    /// A sensor that rests at `prior_farad` (its calibration).
    pub const fn new(prior_farad: f32) -> Self {
        Self {
            policy: PolicyState::new(),
            course: Course::new(prior_farad, false),
            avoidance: Avoidance::new(),
        }
    }

    /// The comb tone this channel avoids, if any ([`crate::avoid`]).
    pub fn avoided(&self) -> Option<usize> {
        self.avoidance.tone()
    }

    /// The pair whose upper tone index is `hi` (clamped to 1 … TONES −
    /// 1): it and the tone two below (or the lowest).
    pub fn pair_of(hi: u8) -> [usize; 2] {
        let hi = usize::from(hi).clamp(1, TONES - 1);
        [hi.saturating_sub(2), hi]
    }

    /// The comb tones a record's line is fitted to: its pair and the
    /// tone between them (the one above them for the lowest pair), lowest
    /// first.
    pub fn fitted_of(pair: [usize; 2]) -> [usize; 3] {
        if pair[1] >= pair[0] + 2 {
            [pair[0], pair[0] + 1, pair[1]]
        } else {
            [pair[0], pair[1], (pair[1] + 1).min(TONES - 1)]
        }
    }

    /// Turn the comb's phasors of the excitation `v` and of this sensor's
    /// current `i` over one block into a record; `rotation` takes the
    /// sensor's scan skew out ([`crate::array::Layout::skew_rotation`]), `clipped`
    /// says an ADC result of the sensor's input or the voltage's hit a
    /// rail. Updates the tone policy and the tracked line.
    #[allow(clippy::too_many_arguments)]
    pub fn process<const N: usize>(
        &mut self,
        s: &ToneSettings<'_, N>,
        channel: u8,
        t_us: u64,
        v: &Input<'_>,
        i: &Input<'_>,
        clipped: bool,
        rotation: &[Complex32; TONES],
    ) -> ToneRecord {
        let dt = self.course.elapsed(t_us);
        let (pair, fitted, moved) = self.tones_now(s);
        let sensor = s.sensors.of(channel);
        let mut rec = ToneRecord {
            t_us,
            sensor: channel,
            f_hz: pair.map(|k| s.layout.tone_hz(k)),
            ..ToneRecord::default()
        };
        if !sensor.calibrated {
            rec.flags.set(Flags::UNCALIBRATED);
        }
        if moved {
            rec.flags.set(Flags::TONE_MOVED);
        }
        if clipped {
            rec.flags.set(Flags::CLIPPED);
        }
        let th = &s.thresholds;
        let n = v.tones.n.min(i.tones.n);
        let Some(tones) = read_tones(s, v, i, rotation, pair, fitted, &mut rec) else {
            return rec;
        };
        if !residuals_within(th, v, i) {
            rec.flags.set(Flags::DISTURBED);
        }
        let set_hz = s.layout.tones_hz();
        // What the MODEL check does not see of a disturbance: the shift
        // it could give each tone of `tones`, in units of the tone's
        // noise (`decide` bounds ln C by each tone's reach times that:
        // the fit's sensitivity).
        // An interferer within half a bin of a tone the record left out
        // (rescued without it) or the channel avoids (moved, and its
        // sideband not taken out) leaks into an adjacent tone more than
        // the residual shows ([`Layout::near_leak`]).
        let avoided = (moved && i.leak.is_none())
            .then(|| self.avoidance.tone())
            .flatten();
        let seen = Seen::of(th, v, i, n);
        let rules = Rules {
            seen: !seen.quiet,
            ..rules_of(s, sensor, &set_hz)
        };
        // Asked only where the inputs are not quiet (`rules.seen`), or
        // of a record left without a tone: one near it may hide in the
        // noise. (A moved channel's interferer near its tone is its
        // sideband's to show.)
        let disturbance = |k: usize, out: Option<usize>| seen.shift_of(&s.layout, &fitted, k, out, avoided);
        let spread = spread_of(s, &seen, sensor, &tones, fitted, moved);
        let decided = self.course.decide(
            &rules,
            &mut self.policy,
            tones,
            disturbance,
            spread,
            dt,
            &mut rec.flags,
        );
        let suspect = self.course.suspect();
        if s.sweep.is_none() && (suspect.is_some() || !self.avoidance.idle()) {
            self.avoidance.update(suspect, &fitted, dt);
        }
        if let Some(line) = decided {
            (rec.c_farad, rec.r_ohm, rec.chi2, rec.sigma_ln_c, rec.stretch_mm) = line.fields();
        }
        rec
    }

    /// The pair a record reports, the three tones it fits and whether
    /// they were moved off an avoided tone: the sweep's or the policy's,
    /// unless the channel avoids a tone. (Inlined: the record's path is
    /// one function in the boards' fast RAM.)
    #[inline(always)]
    fn tones_now<const N: usize>(&self, s: &ToneSettings<'_, N>) -> ([usize; 2], [usize; 3], bool) {
        let hi = s.sweep.unwrap_or(self.policy.fidx as u8);
        if s.sweep.is_none() && self.avoidance.tone().is_some() {
            self.avoidance.read_at(hi)
        } else {
            let pair = Self::pair_of(hi);
            (pair, Self::fitted_of(pair), false)
        }
    }
}

/// The bound of one interferer spread over the three `tones` (comb
/// tones `fitted`) of `sensor`, where the leak's kernels are the
/// layout's (the 4 ms comb's); not where the channel `moved` off a tone:
/// the interferer it avoids is a known one, bounded by its sideband's
/// leak and by the residual's share on the neighbours tone by tone, and
/// its residual would let the spread bound take it for an unknown one
/// besides. (The bound itself out of line, in flash on a board:
/// [`crate::spread::of_record`].)
#[inline(always)]
fn spread_of<'b, const N: usize>(
    s: &'b ToneSettings<'_, N>,
    seen: &'b Seen<'_>,
    sensor: &'b Sensor<N>,
    tones: &'b [Tone; 3],
    fitted: [usize; 3],
    moved: bool,
) -> Option<impl Fn(&Solution, f32, f32) -> f32 + 'b> {
    (skin_spec::leak::of_layout(&s.layout) && !moved).then_some(
        move |sol: &Solution, share: f32, room: f32| {
            let (inputs, excess) = seen.hidden();
            let film = sensor.film(&s.dielectric);
            crate::spread::of_record(&inputs, excess, tones, sensor, film, fitted, sol, share, room)
        },
    )
}

/// What no tone of the comb explains stays within the thresholds on both
/// inputs, against each input's largest tone. (Inlined, as
/// [`ToneChannel::process`]'s other steps.)
#[inline(always)]
fn residuals_within(th: &Thresholds, v: &Input<'_>, i: &Input<'_>) -> bool {
    let limit = |a: f32| fmath::max(th.residual_counts, th.residual_rel * a);
    v.levels.residual <= limit(v.levels.largest) && i.levels.residual <= limit(i.levels.largest)
}

/// What `decide` reads for `sensor` of settings `s`, the policy moving on
/// `set_hz`. 1 ms blocks keep no history of the model check: they are
/// vouched for within 1.6 % (twice the noise), and their records stay
/// within 1 % by each block's own share of it; bounded by the calm
/// blocks before, a record 1.03 % off passed 1.6 %.
fn rules_of<'a, const N: usize>(
    s: &'a ToneSettings<'_, N>,
    sensor: &'a Sensor<N>,
    set_hz: &'a [f32],
) -> Rules<'a, N> {
    Rules {
        sensor,
        dielectric: sensor.film(&s.dielectric),
        thresholds: &s.thresholds,
        chi2_flag: s.chi2_flag,
        rescue: Rescue {
            pair_flag: s.chi2_pair_flag,
            leak_ratio: s.layout.leak_ratio(),
        },
        policy: &s.policy,
        set_hz,
        quiet: s.layout.block_us() >= 4000,
        seen: true,
    }
}

/// Each fitted tone's impedance with its noise (1σ per component, Ω),
/// the pair's into `rec`; None where the block has none (flagged OPEN or
/// SHORTED). Both tones' impedances are kept whenever the excitation is
/// there, also on a record flagged open or shorted: an open fixture's
/// cable is measured so (`live calibrate --open`).
fn read_tones<const N: usize>(
    s: &ToneSettings<'_, N>,
    v: &Input<'_>,
    i: &Input<'_>,
    rotation: &[Complex32; TONES],
    pair: [usize; 2],
    fitted: [usize; 3],
    rec: &mut ToneRecord,
) -> Option<[Tone; 3]> {
    let th = &s.thresholds;
    let mut tones = [Tone {
        z: Complex32::new(0.0, 0.0),
        f_hz: 0.0,
        sigma_ohm: 0.0,
    }; 3];
    let n = v.tones.n.min(i.tones.n);
    // The noise's σ from the residual's own degrees of freedom: the
    // residual rms is over the block's N instants, but its mean and
    // 2·K tone components were fitted out of them.
    let dof = s.layout.residual_dof() as f32;
    let unbiased = dsp_core::fmath::sqrt(n as f32 / dof);
    let (rv, ri) = (unbiased * v.levels.residual, unbiased * i.levels.residual);
    for (j, &k) in fitted.iter().enumerate() {
        let (av, ai) = (v.levels.amplitude[k], i.levels.amplitude[k]);
        let z = match Levels::ratio(&v.levels, &i.levels, k) {
            Some(r) if av >= th.no_excitation_counts => r * s.front_end.gain * rotation[k],
            _ => {
                rec.flags.set(Flags::OPEN);
                return None;
            }
        };
        for (slot, &p) in rec.z.iter_mut().zip(&pair) {
            if p == k {
                *slot = z;
            }
        }
        if ai < th.open_counts {
            rec.flags.set(Flags::OPEN);
        } else if !(z.re >= 0.0 && z.im < 0.0 && z.norm_sqr() >= th.short_ohm * th.short_ohm) {
            // Not a lossy capacitor (Re Z ≥ 0, Im Z < 0), or a short.
            rec.flags.set(Flags::SHORTED);
        }
        tones[j] = Tone {
            z,
            f_hz: s.layout.tone_hz(k),
            sigma_ohm: twotone::z_sigma(z, n, av, ai, rv * v.gains[k], ri * i.gains[k]),
        };
    }
    let biased = rec.flags.has(Flags::OPEN) || rec.flags.has(Flags::SHORTED);
    (!biased).then_some(tones)
}

/// The disturbance a record's two inputs show, once a record: what
/// [`Seen::shift`] reads for each tone.
struct Seen<'a> {
    v: &'a dsp_core::comb::Levels<TONES>,
    i: &'a dsp_core::comb::Levels<TONES>,
    /// What a sideband taken out of the current input still leaks into
    /// each tone, counts ([`Input::leak`]).
    leak: Option<&'a [f32; TONES]>,
    /// The ADC's white noise σ, counts rms, and the block's instants.
    noise: (f32, u32),
    /// δ_v, δ_i: each residual's rms beyond the ADC's white noise σ,
    /// √(r² − σ²), counts; and √(2/N); 0 where `quiet`.
    excess: [f32; 2],
    root_2_over_n: f32,
    /// No disturbance at all: every tone's shift is 0.
    quiet: bool,
}

impl<'a> Seen<'a> {
    /// (Quiet, a record pays two comparisons.)
    fn of(th: &Thresholds, v: &'a Input<'_>, i: &'a Input<'_>, n: u32) -> Self {
        let sigma = th.noise_counts;
        let mut seen = Self {
            v: &v.levels,
            i: &i.levels,
            leak: i.leak.as_ref(),
            noise: (sigma, n),
            excess: [0.0; 2],
            root_2_over_n: 0.0,
            quiet: v.levels.residual <= sigma && i.levels.residual <= sigma && i.leak.is_none(),
        };
        if !seen.quiet {
            let excess = |r: f32| dsp_core::fmath::sqrt(fmath::max(r * r - sigma * sigma, 0.0));
            seen.excess = [excess(v.levels.residual), excess(i.levels.residual)];
            seen.root_2_over_n = dsp_core::fmath::sqrt(2.0 / n.max(1) as f32);
        }
        seen
    }

    /// What a disturbance could have moved tone `k`'s phasor by, in
    /// units of its noise σ: the block's residual r beyond the ADC's
    /// white noise σ ([`Thresholds::noise_counts`]) is a disturbance of
    /// rms δ = √(r² − σ²). White noise averages over the block's N
    /// instants (each tone's σ of phase r·√(2/N)/A, which `sigma_ln_c`
    /// carries); a disturbance need not: an interferer near a tone (or at
    /// an alias of one) leaks into its bin up to its whole amplitude
    /// √2·δ. So the tone's phasor may be off by √2·(δ_v/A_v + δ_i/A_i),
    /// relative, against its noise's √(2/N)·√((r_v/A_v)² + (r_i/A_i)²);
    /// `near` times that where an interferer may sit near an adjacent
    /// tone ([`Layout::near_leak`]), and then (`hidden`) with δ as large
    /// as the noise may hide ([`Seen::hidden_excess`]); plus what a sideband
    /// taken out of the current input still leaks into the tone over
    /// A_i ([`crate::sideband`]). As [by tone, shared]: the sideband's
    /// leak, and the residual's share where an interferer may sit near a
    /// tone (`by_tone`), are bounded tone by tone; the residual's share
    /// otherwise is one disturbance's, shared among the tones
    /// (`decide`'s `disturbed`). 0 without a disturbance, unbounded
    /// without a tone.
    fn shift(&self, k: usize, near: f32, hidden: bool, by_tone: bool) -> [f32; 2] {
        let (Some(&av), Some(&ai)) = (self.v.amplitude.get(k), self.i.amplitude.get(k)) else {
            return [f32::INFINITY, 0.0];
        };
        if !(av > 0.0 && ai > 0.0) {
            return [f32::INFINITY, 0.0];
        }
        let [dv, di] = if hidden { self.hidden_excess() } else { self.excess };
        let leak = self.leak.and_then(|l| l.get(k).copied()).unwrap_or(0.0);
        let root_2_over_n = if self.quiet {
            dsp_core::fmath::sqrt(2.0 / self.noise.1.max(1) as f32)
        } else {
            self.root_2_over_n
        };
        // Every term over A_v·A_i: one division.
        let (ev, ei) = (self.v.residual * ai, self.i.residual * av);
        let per_noise = 1.0 / (root_2_over_n * dsp_core::fmath::sqrt(ev * ev + ei * ei));
        let s = near * core::f32::consts::SQRT_2 * (dv * ai + di * av) * per_noise;
        let leak = leak * av * per_noise;
        // NaN (no tone) is no bound.
        if s.is_nan() || leak.is_nan() {
            [f32::INFINITY, 0.0]
        } else if by_tone {
            [s + leak, 0.0]
        } else {
            [leak, s]
        }
    }

    /// [`Seen::shift`] of tone `k` of `fitted` (comb tones), where the
    /// record left tone `out` of them out, or the channel avoids comb
    /// tone `avoided` without its sideband: an interferer near either
    /// leaks into their neighbours ([`Layout::near_leak`]), and near a
    /// tone left out, δ is as large as the noise may hide. (Cold, in
    /// flash: a record asks only where its inputs show a disturbance or
    /// it was rescued.)
    #[cold]
    #[inline(never)]
    fn shift_of(
        &self,
        layout: &Layout,
        fitted: &[usize; 3],
        k: usize,
        out: Option<usize>,
        avoided: Option<usize>,
    ) -> [f32; 2] {
        let left_out = out.and_then(|o| fitted.get(o).copied());
        let Some(&k) = fitted.get(k) else {
            return [f32::INFINITY, 0.0];
        };
        let near_to = left_out.or(avoided);
        let near = match near_to {
            Some(t) => layout.near_leak(t, k),
            None => 1.0,
        };
        self.shift(k, near, left_out.is_some(), near_to.is_some())
    }

    /// Both inputs' levels, and δ_v, δ_i as large as the noise may hide
    /// ([`Seen::hidden_excess`]): what the bound of one interferer spread
    /// over the tones reads ([`crate::spread::of_record`]).
    #[inline(always)]
    fn hidden(&self) -> ([&'a Levels<TONES>; 2], [f32; 2]) {
        ([self.v, self.i], self.hidden_excess())
    }

    /// δ_v, δ_i as large as the residuals allow: the white noise's
    /// share of r², σ²·(N − 11)/N for the mean and five tones fitted,
    /// taken 3 of its standard deviations, σ²·√(2·(N − 11))/N, low (where
    /// `excess` takes all of σ²). An interferer half a bin from a
    /// tone leaves as little as a tenth of itself in the residual
    /// ([`Layout::near_leak`]): near a tone a record left out, one the
    /// noise hides may still shift its neighbour by 5 times the
    /// residual's. (Cold, in flash: a rescued record asks, and a record
    /// of the 4 ms comb for the spread bound once its line passed.)
    #[cold]
    #[inline(never)]
    fn hidden_excess(&self) -> [f32; 2] {
        let (sigma, n) = self.noise;
        let dof = n.saturating_sub(1 + 2 * TONES as u32) as f32;
        let share = fmath::max(
            (dof - 3.0 * dsp_core::fmath::sqrt(2.0 * dof)) / n.max(1) as f32,
            0.0,
        );
        let floor = sigma * sigma * share;
        let excess = |r: f32| dsp_core::fmath::sqrt(fmath::max(r * r - floor, 0.0));
        [excess(self.v.residual), excess(self.i.residual)]
    }
}
