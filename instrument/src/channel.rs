//! One sensor channel of the multiplexer: from the lock-ins' reading of
//! a block to a record, with fault checks, the model check, line tracking
//! and the frequency policy.
//!
//! Every block carries two tones ([`crate::config::tones`]): the policy's,
//! read with its guards, and a second one two steps away. Each gives the
//! impedance at its frequency; one uniform line must explain both
//! ([`crate::joint`], [`dsp_core::twotone`]). Where it does not (an
//! interferer at one tone's frequency or an alias of it, which no guard
//! can see; an undeclared contact resistance or cable capacitance) the
//! record is flagged [`Flags::MODEL`]; where it does, what such an error
//! could still hide joins the record's error bound.

use crate::config::{freq_hz, tones, tones_hz, Readings, FREQS_HZ};
use crate::decide::{Course, Rules};
use crate::design::RANGES;
use crate::faults::{Flags, Thresholds};
use crate::joint::Rescue;
use crate::policy::{Policy, PolicyState};
use crate::ranging::Ranging;
use crate::sensor::{Sensor, Sensors};
use crate::sequencer::Plan;
use dsp_core::demod::FrontEnd;
use dsp_core::dielectric::Dielectric;
use dsp_core::lumped::SeriesRc;
use dsp_core::twotone::{self, Tone};
use dsp_core::Complex32;

/// What every channel shares, and each channel's sensor.
#[derive(Clone, Copy, Debug)]
pub struct Settings<'a, const N: usize, const S: usize> {
    /// Frequency policy.
    pub policy: Policy,
    /// Fault thresholds.
    pub thresholds: Thresholds,
    /// The film between the electrodes: its loss tangent, fitted within
    /// its spread with the line, and the model's error floor
    /// ([`dsp_core::dielectric::Dielectric`]); the material's, for each
    /// sensor whose own was not measured ([`crate::sensor::Sensor::film`]).
    pub dielectric: Dielectric,
    /// Front end (transimpedance) for Z = k·V/I, one per range.
    pub front_ends: [FrontEnd; RANGES],
    /// Auto-ranging of the transimpedance stage.
    pub ranging: Ranging,
    /// Each channel's sensor: its line, its wiring, its stretch table.
    pub sensors: &'a Sensors<N, S>,
    /// One record reported in every this many blocks of a channel
    /// ([`Channel::due`]).
    pub record_every: u8,
}

impl<'a, const N: usize, const S: usize> Settings<'a, N, S> {
    /// The settings every multiplexed application starts from: the
    /// default policy and thresholds, a silicone film
    /// ([`Dielectric::SILICONE`]); the front end's ranges and the sensors
    /// are the application's.
    pub fn new(front_ends: [FrontEnd; RANGES], ranging: Ranging, sensors: &'a Sensors<N, S>) -> Self {
        Common::new(front_ends, ranging).with(sensors)
    }
}

impl<const N: usize, const S: usize> Settings<'_, N, S> {
    /// All but the sensors.
    pub fn common(&self) -> Common {
        Common {
            policy: self.policy,
            thresholds: self.thresholds,
            dielectric: self.dielectric,
            front_ends: self.front_ends,
            ranging: self.ranging,
            record_every: self.record_every,
        }
    }
}

/// The settings but the sensors: what a device keeps beside sensors it
/// rebuilds in place when a new set comes into force while it runs
/// (fields as [`Settings`]').
#[derive(Clone, Copy, Debug)]
pub struct Common {
    /// Frequency policy.
    pub policy: Policy,
    /// Fault thresholds.
    pub thresholds: Thresholds,
    /// The film between the electrodes.
    pub dielectric: Dielectric,
    /// Front end (transimpedance), one per range.
    pub front_ends: [FrontEnd; RANGES],
    /// Auto-ranging of the transimpedance stage.
    pub ranging: Ranging,
    /// One record reported in every this many blocks of a channel.
    pub record_every: u8,
}

impl Common {
    /// What every multiplexed application starts from
    /// ([`Settings::new`]).
    pub fn new(front_ends: [FrontEnd; RANGES], ranging: Ranging) -> Self {
        Self {
            policy: Policy::DEFAULT,
            thresholds: Thresholds::DEFAULT,
            dielectric: Dielectric::SILICONE,
            front_ends,
            ranging,
            record_every: 1,
        }
    }

    /// The settings of these and `sensors`.
    pub fn with<const N: usize, const S: usize>(self, sensors: &Sensors<N, S>) -> Settings<'_, N, S> {
        Settings {
            policy: self.policy,
            thresholds: self.thresholds,
            dielectric: self.dielectric,
            front_ends: self.front_ends,
            ranging: self.ranging,
            sensors,
            record_every: self.record_every,
        }
    }
}

/// One record reported in every `every` blocks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Decimation {
    since: u8,
}

impl Decimation {
    /// The next block is reported.
    pub const fn new() -> Self {
        Self { since: 0 }
    }

    /// Whether this block is reported: one in every `every` (0 counts as
    /// 1), the first one included.
    pub fn due(&mut self, every: u8) -> bool {
        let due = self.since == 0;
        self.since += 1;
        if self.since >= every {
            self.since = 0;
        }
        due
    }
}

/// One measurement record.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Record {
    /// Time of the block's middle since start, µs.
    pub t_us: u64,
    /// Sensor (the multiplexer's channel it is wired to).
    pub sensor: u8,
    /// Excitation frequency, Hz.
    pub freq_hz: f32,
    /// Lumped series capacitance, F (0 when not measured).
    pub cs_farad: f32,
    /// Lumped series resistance, Ω.
    pub rs_ohm: f32,
    /// Line-corrected capacitance, F (0 when not available).
    pub c_farad: f32,
    /// Line-corrected electrode resistance (both electrodes), Ω.
    pub r_ohm: f32,
    /// Stretch from the calibration, mm.
    pub stretch_mm: f32,
    /// Flags.
    pub flags: Flags,
    /// The block's second tone ([`crate::config::tones`]), Hz (0 when the
    /// record has none: settling).
    pub companion_hz: f32,
    /// The impedance measured at it, Ω (0 when not measured).
    pub companion_z: Complex32,
    /// χ² of the two tones against one uniform line (2 degrees of
    /// freedom; 0 when not solved).
    pub chi2: f32,
    /// 1σ relative error of C from the block's noise (0 when not solved).
    pub sigma_ln_c: f32,
}

/// State of one channel.
#[derive(Clone, Copy, Debug)]
pub struct Channel {
    /// Frequency policy state.
    pub policy: PolicyState,
    /// The line of the two tones from block to block (pinned: the
    /// frequency is fixed, recording a data set at one frequency).
    course: Course,
    /// Transimpedance range for the next block.
    range: u8,
    /// Which records are reported.
    reports: Decimation,
}

impl Channel {
    /// A channel whose sensor rests at `prior_farad` (its calibration).
    pub const fn new(prior_farad: f32) -> Self {
        Self {
            policy: PolicyState::new(),
            course: Course::new(prior_farad, false),
            range: 0,
            reports: Decimation::new(),
        }
    }

    /// Whether the record of the block just measured is reported
    /// ([`Decimation::due`]; `every`: the settings' `record_every`). The
    /// blocks between are measured all the same (the tracker and the
    /// policy follow every one).
    pub fn due(&mut self, every: u8) -> bool {
        self.reports.due(every)
    }

    /// A channel held at frequency index `fidx` whatever the policy
    /// says, as a data-set recording at one frequency needs.
    /// An index beyond the set means its highest frequency.
    pub const fn pinned(prior_farad: f32, fidx: usize) -> Self {
        let mut c = Self::new(prior_farad);
        c.policy.fidx = crate::config::index(fidx);
        c.course = Course::new(prior_farad, true);
        c
    }

    /// Frequency index to excite the next block with.
    pub fn fidx(&self) -> usize {
        crate::config::index(self.policy.fidx)
    }

    /// Transimpedance range to read the next block through.
    pub fn range(&self) -> u8 {
        self.range
    }

    /// What the channel wants for its next slot.
    pub fn plan(&self) -> Plan {
        Plan {
            fidx: self.fidx(),
            range: self.range,
        }
    }

    /// Turn the lock-ins' reading of the block just measured at the
    /// current frequency through transimpedance range `range` into a
    /// record, and update the policy and the range.
    pub fn process<const N: usize, const S: usize>(
        &mut self,
        s: &Settings<'_, N, S>,
        channel: u8,
        t_us: u64,
        ph: &Readings,
        clipped: bool,
        range: u8,
    ) -> Record {
        let played = tones(self.policy.fidx);
        let rec = self.measure(s, channel, t_us, ph, clipped, range);
        // The next block's current at its peak: each tone's, grown with
        // its frequency (a capacitor's current), the two in phase.
        let next = tones(self.policy.fidx);
        let growth = |k: usize| (freq_hz(next[k]) / freq_hz(played[k])).max(1.0);
        let peak = ph.tone.i_amplitude() * growth(0) + ph.companion.i_amplitude() * growth(1);
        self.range = s.ranging.next(range as usize, peak, clipped, 1.0) as u8;
        rec
    }

    fn measure<const N: usize, const S: usize>(
        &mut self,
        s: &Settings<'_, N, S>,
        channel: u8,
        t_us: u64,
        ph: &Readings,
        clipped: bool,
        range: u8,
    ) -> Record {
        let f = tones_hz(self.policy.fidx);
        let dt = self.course.elapsed(t_us);
        let mut rec = Record {
            t_us,
            sensor: channel,
            freq_hz: f[0],
            companion_hz: f[1],
            ..Record::default()
        };
        let sensor = s.sensors.of(channel);
        if !sensor.calibrated {
            rec.flags.set(Flags::UNCALIBRATED);
        }
        if self.policy.settling > 0 {
            self.policy.settling -= 1;
            rec.flags.set(Flags::SETTLING);
            return rec;
        }
        if clipped {
            rec.flags.set(Flags::CLIPPED);
        }
        let th = &s.thresholds;
        let front_end = &s.front_ends[(range as usize).min(RANGES - 1)];
        let Some((pair, noise)) = read_tones(th, front_end, ph, f, &mut rec) else {
            return rec;
        };
        if th.disturbed(&ph.tone) {
            rec.flags.set(Flags::DISTURBED);
        }
        let rules = rules_of(s, sensor);
        // What the energy near the policy's tone could have shifted its
        // V/I by, in units of its noise (`decide` bounds ln C by the
        // tone's reach times that: a weighted least-squares fit's
        // sensitivity); the second tone's share is the model check's.
        // (`decide` counts the tones lowest first.)
        let policy_tone = usize::from(f[0] > f[1]);
        let near = |k: usize, _: Option<usize>| {
            if k == policy_tone {
                [0.0, th.near_shift(&ph.tone) / noise]
            } else {
                [0.0; 2]
            }
        };
        let decided = self.course.decide(
            &rules,
            &mut self.policy,
            pair,
            near,
            // (Two tones: one interferer spreads over none.)
            crate::decide::NO_SPREAD,
            dt,
            &mut rec.flags,
        );
        if let Some(line) = decided {
            (rec.c_farad, rec.r_ohm, rec.chi2, rec.sigma_ln_c, rec.stretch_mm) = line.fields();
        }
        rec
    }
}

/// What `decide` reads for `sensor` of settings `s`: the multiplexed
/// channel's two tones of [`FREQS_HZ`], judged by the two-tone flag, no
/// pair to rescue a record from (two tones), the model check's history
/// kept, and the energy near the tones always asked.
#[inline(always)]
fn rules_of<'a, const N: usize, const S: usize>(
    s: &'a Settings<'_, N, S>,
    sensor: &'a Sensor<N>,
) -> Rules<'a, N> {
    Rules {
        sensor,
        dielectric: sensor.film(&s.dielectric),
        thresholds: &s.thresholds,
        chi2_flag: twotone::CHI2_FLAG,
        rescue: Rescue::NONE,
        policy: &s.policy,
        set_hz: &FREQS_HZ,
        quiet: true,
        seen: true,
    }
}

/// The block's two tones, each with its noise (1σ per component of Z,
/// Ω), and the policy's tone's relative noise; None where there are none
/// (the record flagged OPEN or SHORTED). The lumped reading, which stays
/// what the meter saw, and the second tone's impedance go into `rec`.
fn read_tones(
    th: &Thresholds,
    front_end: &FrontEnd,
    ph: &Readings,
    f: [f32; 2],
    rec: &mut Record,
) -> Option<([Tone; 2], f32)> {
    let (tone, companion) = (&ph.tone, &ph.companion);
    let excited = |v: f32, i: f32| i >= th.open_counts && v >= th.no_excitation_counts;
    let (z, z2) = match (tone.impedance(front_end), companion.impedance(front_end)) {
        (Some(z), Some(z2))
            if excited(tone.v_amplitude(), tone.i_amplitude())
                && excited(companion.v_amplitude(), companion.i_amplitude()) =>
        {
            (z, z2)
        }
        _ => {
            rec.flags.set(Flags::OPEN);
            return None;
        }
    };
    // A lossy capacitor at both tones (Re Z ≥ 0, Im Z < 0), not a short.
    let capacitor = |z: Complex32| z.re >= 0.0 && z.im < 0.0 && z.norm_sqr() >= th.short_ohm * th.short_ohm;
    match SeriesRc::from_impedance(z, f[0]) {
        Ok(m) if capacitor(z) && capacitor(z2) => {
            rec.cs_farad = m.cs_farad;
            rec.rs_ohm = m.rs_ohm;
            rec.companion_z = z2;
        }
        _ => {
            rec.flags.set(Flags::SHORTED);
            return None;
        }
    }
    // Each tone's noise: the ADC's, or what the guards show if more.
    let (sigma_v, sigma_i) = (th.sigma(tone, 0), th.sigma(tone, 1));
    let relative = |g: f32, av: f32, ai: f32| {
        let (ev, ei) = (sigma_v / av, sigma_i / ai);
        g * dsp_core::fmath::sqrt(ev * ev + ei * ei)
    };
    let noise = [
        relative(tone.noise_gain, tone.v_amplitude(), tone.i_amplitude()),
        relative(
            companion.noise_gain,
            companion.v_amplitude(),
            companion.i_amplitude(),
        ),
    ];
    // Each tone's 1σ per component of Z: |Z| times its relative noise.
    let measured = [z, z2];
    let pair = core::array::from_fn(|k| Tone {
        z: measured[k],
        f_hz: f[k],
        sigma_ohm: dsp_core::fmath::sqrt(measured[k].norm_sqr()) * noise[k],
    });
    Some((pair, noise[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_record_in_every_n_is_reported_the_first_included() {
        for every in [0u8, 1, 2, 3, 250] {
            let mut d = Decimation::new();
            let due: std::vec::Vec<bool> = (0..600).map(|_| d.due(every)).collect();
            let n = usize::from(every.max(1));
            assert!(due.iter().enumerate().all(|(k, &x)| x == (k % n == 0)), "{every}");
        }
    }
}
