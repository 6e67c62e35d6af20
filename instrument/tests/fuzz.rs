//! Fuzzing the firmware's channel logic and the wire format with proptest.
//!
//! * `channel_on_arbitrary_readings`: any lock-in output (tones, guards,
//!   noise gains, pair counts, NaN and infinities among them), clipping,
//!   time stamps and frequency indices, in
//!   sequences on one channel: no panic, and a record flagged valid has a
//!   finite, positive C and R and a finite stretch.
//! * `disturbed_blocks`: the simulated sensor (any stretch, electrodes at
//!   0.3–20 times their resistance, any frequency of the set) under random
//!   mains hum (50/60 Hz, 0 to the rails, either channel), a step inside
//!   the block, a stuck current ADC, or an electrode step between blocks:
//!   no record flagged valid is more than 1 % off the truth.
//! * `two_tones_under_interferers_and_motion`: the simulated sensor
//!   stretching on the paper's trapezoid from any phase (20 or 40 mm/s,
//!   electrodes at 0.5–1.5 times their resistance, any frequency of the
//!   set, the policy free or pinned) under an interferer of any frequency
//!   (0.5 Hz to 400 kHz, aliases included; in half the cases within
//!   100 Hz of one of the block's two tones or of an alias of one, where
//!   no guard sees it) and amplitude (0.1 counts to the rails) on either
//!   or both channels: no record flagged valid is more than 1 % off the
//!   truth of its block.
//! * `wire_parse`: any text, and mutated record lines: no panic; a parsed
//!   record has finite values.
//!
//! Cases per target: `FUZZ_CASES` (default 100 000); `cargo xtask fuzz`
//! runs 1 000 000.

use dsp_core::fixture::Fixture;
use dsp_core::lockin::{Phasors, Reading};
use dsp_core::Complex32;
use instrument::calib::{POINTS, REFERENCE};
use instrument::channel::{Channel, Settings};
use instrument::config::{freq_hz, tones_hz, Readings, BLOCK_PAIRS, PERIODS, SLOT_S};
use instrument::sensor::{Sensor as Measured, Sensors};
use instrument::wire;
use proptest::prelude::*;
use skin_sim::frontend::{Disturbance, FrontEndParams};
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};

fn cases(default: u32) -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn config(default: u32) -> ProptestConfig {
    ProptestConfig {
        cases: cases(default),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn settings() -> Settings<'static, POINTS, 1> {
    let ranging = FrontEndParams::REFERENCE.ranging();
    Settings::new(ranging.front_ends(1.0), ranging, reference())
}

/// A component of a reading: anything an f32 holds, and the realistic
/// sizes often.
fn value() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<f32>(),
        -3000f32..3000.0,
        -1f32..1.0,
        Just(0.0),
        Just(f32::NAN),
        Just(f32::INFINITY)
    ]
}

fn complex() -> impl Strategy<Value = Complex32> {
    (value(), value()).prop_map(|(re, im)| Complex32::new(re, im))
}

fn reading() -> impl Strategy<Value = Reading> {
    (
        (complex(), complex()),
        (complex(), complex(), complex(), complex()),
        (value(), value()),
        prop_oneof![any::<u32>(), Just(BLOCK_PAIRS as u32), Just(0)],
    )
        .prop_map(
            |((v, i), (a, b, c, d), (noise_gain, guard_noise_gain), n)| Reading {
                v,
                i,
                guards: [[a, b], [c, d]],
                noise_gain,
                guard_noise_gain,
                n,
            },
        )
}

/// Both tones of a block: arbitrary readings, the second tone's noise
/// gain and length its own.
fn readings() -> impl Strategy<Value = Readings> {
    (reading(), complex(), complex(), value(), any::<u32>()).prop_map(|(tone, v, i, noise_gain, n)| {
        Readings {
            tone,
            companion: Phasors { v, i, noise_gain, n },
        }
    })
}

proptest! {
    #![proptest_config(config(100_000))]

    #[test]
    fn channel_on_arbitrary_readings(
        steps in prop::collection::vec((readings(), any::<bool>(), any::<u64>(), any::<u8>()), 1..16),
        prior in prop_oneof![any::<f32>(), 1e-12f32..1e-9],
        index in any::<usize>(),
        pinned in any::<bool>(),
    ) {
        let s = settings();
        let mut ch = if pinned { Channel::pinned(prior, index) } else { Channel::new(prior) };
        for (ph, clipped, t_us, range) in steps {
            let r = ch.process(&s, 3, t_us, &ph, clipped, range);
            prop_assert!(ch.fidx() < PERIODS.len());
            prop_assert!((ch.range() as usize) < instrument::design::RANGES);
            if r.flags.valid() && r.c_farad != 0.0 {
                prop_assert!(r.c_farad.is_finite() && r.c_farad > 0.0, "{r:?}");
                prop_assert!(r.r_ohm.is_finite() && r.r_ohm > 0.0, "{r:?}");
                prop_assert!(r.stretch_mm.is_finite(), "{r:?}");
            }
        }
    }

    #[test]
    fn wire_parse(text in prop_oneof![
        ".{0,120}",
        "(rec|truth)( [-+0-9.eEinfNaN]{0,12}){0,12}",
    ]) {
        if let Ok(wire::Line::Rec(r)) = wire::parse(&text) {
            prop_assert!(r.freq_hz.is_finite() && r.cs_farad.is_finite() && r.c_farad.is_finite());
        }
    }
}

/// The reference sensor with its electrodes at `r_scale` times their
/// resistance.
fn scaled(r_scale: f64) -> SensorParams {
    SensorParams::REFERENCE.with_electrodes_scaled(r_scale)
}

/// One block of `sensor` read by channel `ch` at its frequency through the
/// reference front end under `d` (from `t0` s): the record and the true C
/// of the block, F.
fn measure(
    s: &Settings<'_, POINTS, 1>,
    ch: &mut Channel,
    sensor: &Sensor,
    t0: f64,
    d: &Disturbance,
    rng: &mut Rng,
) -> (instrument::channel::Record, f64) {
    let i = ch.fidx();
    let mut buf = [[0i16; 2]; BLOCK_PAIRS];
    let clipped = FrontEndParams::REFERENCE
        .at_range(&s.ranging, ch.range())
        .mux_block(i, |f| sensor.impedance(f), rng, &mut buf, d);
    let ph = instrument::config::read(i, &buf);
    let range = ch.range();
    (
        ch.process(s, 0, (t0 * 1e6) as u64, &ph, clipped, range),
        sensor.truth().c_farad,
    )
}

/// What disturbs a block in a case.
#[derive(Clone, Copy, Debug)]
enum Attack {
    Hum {
        hz: f32,
        v: f32,
        i: f32,
        phase: f32,
    },
    Step {
        counts: f32,
        at: usize,
    },
    Stuck(i16),
    /// Electrodes times this from the second block on.
    Resistance(f64),
}

fn attack() -> impl Strategy<Value = Attack> {
    prop_oneof![
        (
            prop_oneof![Just(50.0f32), Just(60.0)],
            0.0f32..2048.0,
            0.0f32..2048.0,
            0.0f32..1.0,
            0u8..3
        )
            .prop_map(|(hz, a, b, phase, which)| Attack::Hum {
                hz,
                v: if which != 1 { a } else { 0.0 },
                i: if which != 0 { b } else { 0.0 },
                phase
            }),
        (-2000.0f32..2000.0, 0..BLOCK_PAIRS).prop_map(|(counts, at)| Attack::Step { counts, at }),
        any::<i16>().prop_map(|c| Attack::Stuck(c.clamp(-2048, 2047))),
        (0.3f64..20.0).prop_map(Attack::Resistance),
    ]
}

proptest! {
    #![proptest_config(config(100_000))]

    #[test]
    fn disturbed_blocks(
        stretch in 0.0f64..30.0,
        r_scale in 0.3f64..3.0,
        index in 0..PERIODS.len(),
        attack in attack(),
        seed in any::<u64>(),
    ) {
        let s = settings();
        let p = scaled(r_scale);
        let mut sensor = Sensor::settled(p);
        sensor.advance(&Profile::Constant(stretch), 0.0);
        let stepped = match attack {
            Attack::Resistance(k) => p.with_electrodes_scaled(k),
            _ => p,
        };
        let mut stepped = Sensor::settled(stepped);
        stepped.advance(&Profile::Constant(stretch), 0.0);
        let mut ch = Channel::pinned(REFERENCE.rest_capacitance(), index);
        let mut rng = Rng::new(seed);
        for b in 0..4 {
            let t0 = b as f64 * SLOT_S as f64;
            let mut d = Disturbance { t0_s: t0, ..Disturbance::NONE };
            let mut sensor_now = &sensor;
            if b >= 2 {
                match attack {
                    Attack::Hum { hz, v, i, phase } => {
                        (d.hum_hz, d.hum_v, d.hum_i, d.hum_phase_turns) = (hz, v, i, phase)
                    }
                    Attack::Step { counts, at } => (d.step_i, d.step_at) = (counts, at),
                    Attack::Stuck(c) => d.stuck_i = Some(c),
                    Attack::Resistance(_) => sensor_now = &stepped,
                }
            }
            let (r, truth) = measure(&s, &mut ch, sensor_now, t0, &d, &mut rng);
            if r.flags.valid() {
                let e = (r.c_farad as f64 / truth - 1.0).abs();
                prop_assert!(e < 0.01, "block {b} at {} Hz under {attack:?}: C {} pF vs {} pF ({r:?})",
                    freq_hz(index), r.c_farad * 1e12, truth * 1e12);
            }
        }
    }
}

/// Every channel on the reference sensor's table, without leads.
fn reference() -> &'static Sensors<POINTS, 1> {
    static SENSORS: std::sync::OnceLock<Sensors<POINTS, 1>> = std::sync::OnceLock::new();
    SENSORS.get_or_init(|| Sensors::all(Measured::calibrated(REFERENCE, 0.0, Fixture::NONE).unwrap()))
}

proptest! {
    #![proptest_config(config(100_000))]

    #[test]
    fn two_tones_under_interferers_and_motion(
        start in 0.0f64..10.0,
        rate in prop_oneof![Just(20.0f64), Just(40.0)],
        r_scale in 0.5f64..1.5,
        index in 0..PERIODS.len(),
        pinned in any::<bool>(),
        log_hz in (0.5f64).ln()..(400e3f64).ln(),
        near in prop::option::of((0usize..2, -100f64..100.0, any::<bool>())),
        log_counts in (0.1f64).ln()..(2048f64).ln(),
        which in 0u8..3,
        phase in 0.0f32..1.0,
        seed in any::<u64>(),
    ) {
        // Anywhere, or within 100 Hz of one of the first block's tones
        // (or of its alias about the pair rate).
        let hz = match near {
            None => log_hz.exp(),
            Some((k, off, alias)) => {
                let tone = tones_hz(index)[k] as f64 + off;
                if alias { instrument::config::SAMPLE_RATE_HZ as f64 - tone } else { tone }
            }
        };
        let case = Interfered { start, rate, r_scale, index, pinned, hz, counts: log_counts.exp() as f32, which, phase, seed };
        if let Err(e) = case.run() {
            prop_assert!(false, "{e} ({case:?})");
        }
    }
}

/// One case of `two_tones_under_interferers_and_motion`: the sensor
/// stretching on the paper's trapezoid at `rate` mm/s from `start` s, its
/// electrodes at `r_scale` times theirs, read from frequency `index`
/// (`pinned` or the policy free) for six blocks under a sinusoid of
/// `counts` at `hz` (`which`: 0 the voltage, 1 the current, 2 both).
#[derive(Clone, Copy, Debug)]
struct Interfered {
    start: f64,
    rate: f64,
    r_scale: f64,
    index: usize,
    pinned: bool,
    hz: f64,
    counts: f32,
    which: u8,
    phase: f32,
    seed: u64,
}

impl Interfered {
    /// Every valid record within 1 % of its block's truth, or the first
    /// that is not.
    fn run(&self) -> Result<(), String> {
        let s = settings();
        let mut sensor = Sensor::settled(scaled(self.r_scale));
        let profile = Profile::paper(self.rate);
        sensor.advance(&profile, self.start);
        let mut ch = if self.pinned {
            Channel::pinned(REFERENCE.rest_capacitance(), self.index)
        } else {
            let mut c = Channel::new(REFERENCE.rest_capacitance());
            c.policy.fidx = self.index;
            c
        };
        let counts = self.counts;
        let mut rng = Rng::new(self.seed);
        for b in 0..6 {
            let t0 = self.start + b as f64 * SLOT_S as f64;
            let i = ch.fidx();
            sensor.advance(&profile, t0 + 0.5 * SLOT_S as f64);
            let d = Disturbance {
                hum_hz: self.hz as f32,
                hum_v: if self.which != 1 { counts } else { 0.0 },
                hum_i: if self.which != 0 { counts } else { 0.0 },
                hum_phase_turns: self.phase,
                t0_s: t0,
                ..Disturbance::NONE
            };
            let (r, truth) = measure(&s, &mut ch, &sensor, t0, &d, &mut rng);
            let e = (r.c_farad as f64 / truth - 1.0).abs();
            if r.flags.valid() && e >= 0.01 {
                return Err(format!(
                    "block {b} at {} Hz, {counts} counts at {} Hz: C {} pF vs {} pF ({r:?})",
                    freq_hz(i),
                    self.hz,
                    r.c_farad * 1e12,
                    truth * 1e12
                ));
            }
        }
        Ok(())
    }
}

/// A case the target found: a count of interferer 71 Hz from the second
/// tone (977 Hz, no guards of its own) of a channel pinned at 3906 Hz
/// (ωRC ≈ 6.7) left a record valid and 1.03 % off behind a χ² of 0.34:
/// the noise had cancelled part of the interferer's share of the
/// residual, which the bound on what one tone can hide now allows for.
#[test]
fn an_interferer_next_to_the_second_tone_is_not_vouched_for() {
    let case = Interfered {
        start: 5.0787095673391915,
        rate: 40.0,
        r_scale: 0.7270835929983261,
        index: 3,
        pinned: true,
        hz: 6.808190916121611f64.exp(),
        counts: 0.02469632075391684f64.exp() as f32,
        which: 1,
        phase: 0.37833706,
        seed: 13017437019389783390,
    };
    case.run().unwrap();
}
