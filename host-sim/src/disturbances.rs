//! The disturbance table (`host-sim disturbances`): each class of
//! disturbance a skin meets, tried on both of the firmware's paths, on
//! the host and with the firmware's own code (`instrument`'s channels,
//! `dsp-core`'s demodulators), the sensors stretching on the paper's
//! 20 mm/s trapezoid: the share of records valid and the faults that
//! stood on the others, how many records marked valid are more than 1 %
//! off the true C, and the worst error among the valid ones.
//!
//! * The multiplexed channel ([`instrument::channel`]): the reference
//!   sensor, pinned in turn at the three lower frequencies of the set
//!   (586–1953 Hz; pinned higher, the stretched sensor leaves the line's
//!   range, which the policy would not let happen), 40 blocks each,
//!   through the simulated 12-bit front end.
//! * The array ([`instrument::tones`]): sixteen of the paper's sensors at
//!   once through the comb's front end, 0.4 s (1600 records).
//!
//! The disturbances are the front ends' own (`skin_sim::frontend::Disturbance`:
//! a sinusoid, a step, a burst, a stuck ADC) and the sensor's (the catalogue's
//! effects, left undeclared to the firmware; an electrode resistance that
//! jumps; drift). The array's front end simulates sinusoids only, so its
//! rows for steps, bursts, offsets and stuck inputs are not tried ("–").

use dsp_core::fixture::Fixture;
use instrument::array::{Frame, Layout, BLOCK_INSTANTS, RATE_HZ, SENSORS, TONES};
use instrument::availability::Availability;
use instrument::calib;
use instrument::channel::{Channel, Settings};
use instrument::config::{tones_hz, BLOCK_PAIRS, SLOT_S};
use instrument::effects::Effect;
use instrument::faults::Flags;
use instrument::reader::ArrayReader;
use instrument::sensor::{Sensor as Measured, Sensors};
use instrument::tones::ToneSettings;
use skin_sim::array::ArrayFrontEnd;
use skin_sim::frontend::{Disturbance, FrontEndParams};
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};

/// One class of disturbance.
#[derive(Clone, Copy, Debug)]
pub struct Class {
    /// Its name in the table.
    pub name: &'static str,
    /// What is added, in words.
    pub what: &'static str,
    /// At the front end: a sinusoid (`hum_hz` relative to the tone when
    /// `near_tone`), a step, a stuck ADC.
    pub front: Front,
    /// At the sensor: effects left undeclared, and a change between
    /// blocks.
    pub sensor: SensorChange,
}

/// What a class adds at the front end.
#[derive(Clone, Copy, Debug)]
pub enum Front {
    /// Nothing.
    None,
    /// A sinusoid on the current input: `hz` (absolute, or an offset from
    /// the tone a record uses when `from_tone`), `counts` amplitude.
    Sine {
        /// Hz.
        hz: f32,
        /// Offset from the tone (its nearest mains harmonic when `mains`).
        from_tone: bool,
        /// The nearest 50 Hz harmonic of the tone, `hz` being ignored.
        mains: bool,
        /// An alias: `hz` from the tone, reflected about the sample rate.
        alias: bool,
        /// `hz` above the block's highest tone (a tone-relative offset
        /// that no tone of the block lies near).
        beyond: bool,
        /// Counts (peak).
        counts: f32,
    },
    /// A step on the current input, counts, at the block's middle
    /// (multiplexed only).
    Step(f32),
    /// A constant offset on the current input, counts (multiplexed only).
    Offset(f32),
    /// A burst on the current input: counts, for this many pairs from a
    /// third of the block (multiplexed only).
    Burst(f32, usize),
    /// The current input stuck at a code (multiplexed only).
    Stuck(i16),
}

/// What a class does to the sensor.
#[derive(Clone, Copy, Debug)]
pub enum SensorChange {
    /// Nothing.
    None,
    /// An effect of the catalogue at this value, undeclared.
    Effect(Effect, f64),
    /// The electrodes' resistance times this from the run's middle on.
    Jump(f64),
    /// The electrodes' resistance drifting up by this fraction over the
    /// run (a warming film), undeclared.
    Drift(f64),
    /// The film's capacitance drifting by this fraction over the run (its
    /// permittivity warming), undeclared: the truth follows it.
    DriftC(f64),
    /// No sensor: the cable open.
    Open,
    /// The tabs shorted through this many Ω.
    Short(f64),
}

/// The classes tried.
pub const CLASSES: [Class; 22] = [
    Class {
        name: "clean",
        what: "nothing added",
        front: Front::None,
        sensor: SensorChange::None,
    },
    Class {
        name: "mains hum",
        what: "50 Hz, 200 counts",
        front: sine(50.0, 200.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "weak mains hum",
        what: "50 Hz, 2 counts (0.05 % of full scale)",
        front: sine(50.0, 2.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "mains harmonic at the tone",
        what: "the 50 Hz harmonic nearest the tone, 10 counts (0.5 % of full scale)",
        front: Front::Sine {
            hz: 0.0,
            from_tone: true,
            mains: true,
            alias: false,
            beyond: false,
            counts: 10.0,
        },
        sensor: SensorChange::None,
    },
    Class {
        name: "interferer in the tone's bin",
        what: "5 Hz from the tone, 10 counts",
        front: near(5.0, 10.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "interferer near the tone",
        what: "60 Hz from the tone, 20 counts",
        front: near(60.0, 20.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "interferer far from the tone",
        what: "1.5 kHz above the block's highest tone, 100 counts",
        front: Front::Sine {
            hz: 1500.0,
            from_tone: true,
            mains: false,
            alias: false,
            beyond: true,
            counts: 100.0,
        },
        sensor: SensorChange::None,
    },
    Class {
        name: "alias of the tone",
        what: "at the sample rate minus the tone, 20 Hz off, 10 counts",
        front: Front::Sine {
            hz: 20.0,
            from_tone: true,
            mains: false,
            alias: true,
            beyond: false,
            counts: 10.0,
        },
        sensor: SensorChange::None,
    },
    Class {
        name: "step in a block",
        what: "300 counts at its middle",
        front: Front::Step(300.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "burst",
        what: "300 counts for 20 pairs (0.1 ms) in a block: a glitch, a relay, a discharge",
        front: Front::Burst(300.0, 20),
        sensor: SensorChange::None,
    },
    Class {
        name: "DC offset",
        what: "300 counts",
        front: Front::Offset(300.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "clipping",
        what: "a 50 Hz swing of 3000 counts (past the rails)",
        front: sine(50.0, 3000.0),
        sensor: SensorChange::None,
    },
    Class {
        name: "stuck ADC",
        what: "the current input stuck at mid-scale",
        front: Front::Stuck(0),
        sensor: SensorChange::None,
    },
    Class {
        name: "open sensor",
        what: "the cable unplugged",
        front: Front::None,
        sensor: SensorChange::Open,
    },
    Class {
        name: "shorted sensor",
        what: "the tabs shorted (100 Ω)",
        front: Front::None,
        sensor: SensorChange::Short(100.0),
    },
    Class {
        name: "contact resistance",
        what: "30 kΩ per tab, undeclared",
        front: Front::None,
        sensor: SensorChange::Effect(Effect::ContactResistance, 30e3),
    },
    Class {
        name: "parasitic capacitance",
        what: "10 pF at the meter, undeclared",
        front: Front::None,
        sensor: SensorChange::Effect(Effect::ParasiticCapacitance, 10e-12),
    },
    Class {
        name: "dielectric loss",
        what: "an acrylic film's tan δ = 2·10⁻², undeclared",
        front: Front::None,
        sensor: SensorChange::Effect(Effect::DielectricLoss, 2e-2),
    },
    Class {
        name: "electrode R jump",
        what: "the electrodes ×3 at once",
        front: Front::None,
        sensor: SensorChange::Jump(3.0),
    },
    Class {
        name: "drift of R",
        what: "the electrodes +30 % over the run",
        front: Front::None,
        sensor: SensorChange::Drift(0.3),
    },
    Class {
        name: "drift of C",
        what: "the film's permittivity −2 % over the run (warming)",
        front: Front::None,
        sensor: SensorChange::DriftC(-0.02),
    },
    Class {
        name: "dispersion of C",
        what: "the film's permittivity −3 % per decade above 1 kHz, undeclared",
        front: Front::None,
        sensor: SensorChange::Effect(Effect::DielectricDispersion, 0.03),
    },
];

const fn sine(hz: f32, counts: f32) -> Front {
    Front::Sine {
        hz,
        from_tone: false,
        mains: false,
        alias: false,
        beyond: false,
        counts,
    }
}

const fn near(hz: f32, counts: f32) -> Front {
    Front::Sine {
        hz,
        from_tone: true,
        mains: false,
        alias: false,
        beyond: false,
        counts,
    }
}

/// What one path made of one class.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Records: how many, the share valid, and the faults on the others.
    pub availability: Availability,
    /// Records valid and more than 1 % off the true C.
    pub valid_off: usize,
    /// The worst relative error of C among the valid records.
    pub worst_valid: f64,
    /// Records read at tones moved off one an interferer occupies
    /// ([`Flags::TONE_MOVED`]).
    pub moved: usize,
}

impl Outcome {
    /// Nothing counted.
    pub(crate) fn new() -> Self {
        Self {
            availability: Availability::new(),
            valid_off: 0,
            worst_valid: 0.0,
            moved: 0,
        }
    }

    /// Records.
    pub fn records(&self) -> usize {
        self.availability.records as usize
    }

    /// Records flagged (not valid).
    pub fn flagged(&self) -> usize {
        self.availability.invalid() as usize
    }

    /// Count a record with `flags` and its C against the truth.
    pub(crate) fn add(&mut self, flags: Flags, c_farad: f32, truth: f64) {
        self.availability.count(flags);
        self.moved += usize::from(flags.has(Flags::TONE_MOVED));
        if !flags.valid() {
            return;
        }
        let e = (c_farad as f64 / truth - 1.0).abs();
        self.worst_valid = self.worst_valid.max(e);
        if e > 0.01 {
            self.valid_off += 1;
        }
    }
}

/// The sinusoid's frequency for a record whose block plays `tones_hz`
/// (the tone a class aims at first), sampled at `rate_hz` (an alias is
/// reflected about it).
fn sine_hz(front: &Front, tones_hz: &[f32], rate_hz: f32) -> Option<(f32, f32)> {
    let Front::Sine {
        hz,
        from_tone,
        mains,
        alias,
        beyond,
        counts,
    } = *front
    else {
        return None;
    };
    let tone_hz = tones_hz.first().copied().unwrap_or(0.0);
    let f = if beyond {
        tones_hz.iter().fold(0f32, |m, &t| m.max(t)) + hz
    } else if mains {
        (tone_hz / 50.0).round() * 50.0
    } else if alias {
        rate_hz - tone_hz - hz
    } else if from_tone {
        tone_hz + hz
    } else {
        hz
    };
    Some((f, counts))
}

/// The sensor a class reads: `base` with its change at run time `t` of
/// `duration` s.
fn sensor_params(base: SensorParams, change: &SensorChange, t: f64, duration: f64) -> SensorParams {
    let mut p = base;
    match *change {
        SensorChange::Effect(e, v) => p.effects = p.effects.with(e, v),
        SensorChange::Jump(k) if t >= 0.5 * duration => p = p.with_electrodes_scaled(k),
        SensorChange::Drift(k) => p = p.with_electrodes_scaled(1.0 + k * t / duration),
        SensorChange::DriftC(k) => p.c_rest_farad *= 1.0 + k * t / duration,
        _ => {}
    }
    p
}

/// The impedance a front end sees for `sensor` under `change`, Ω.
fn seen(sensor: &Sensor, change: &SensorChange, f_hz: f64) -> num_complex::Complex64 {
    match *change {
        SensorChange::Open => num_complex::Complex64::new(1e12, -1e15),
        SensorChange::Short(r) => num_complex::Complex64::new(r, 0.0),
        _ => sensor.impedance(f_hz),
    }
}

/// The multiplexed channel under `class`.
pub fn multiplexed(class: &Class) -> Outcome {
    let fe = FrontEndParams::REFERENCE;
    let ranging = fe.ranging();
    let measured = Measured::calibrated(calib::REFERENCE, 0.0, Fixture::NONE)
        .expect("the reference calibration is valid");
    let sensors = Sensors::<{ calib::POINTS }, 1>::all(measured);
    let settings = Settings::new(ranging.front_ends(fe.v_gain as f32), ranging, &sensors);
    let mut out = Outcome::new();
    let mut rng = Rng::new(0xd157);
    let mut buf = vec![[0i16; 2]; BLOCK_PAIRS];
    const BLOCKS: usize = 40;
    let duration = BLOCKS as f64 * SLOT_S as f64;
    for index in 0..3 {
        let mut ch = Channel::pinned(calib::REFERENCE.rest_capacitance(), index);
        // Each frequency from another phase of the trapezoid (moving).
        let start = 0.5 + 1.7 * index as f64;
        for b in 0..BLOCKS {
            let t = b as f64 * SLOT_S as f64;
            let mut sensor =
                Sensor::settled(sensor_params(SensorParams::REFERENCE, &class.sensor, t, duration));
            sensor.advance(&Profile::paper(20.0), start + t);
            let truth = sensor.truth().c_farad;
            let mut d = Disturbance {
                t0_s: t,
                ..Disturbance::NONE
            };
            if let Some((hz, counts)) = sine_hz(&class.front, &tones_hz(index), fe.sample_rate_hz as f32) {
                (d.hum_hz, d.hum_i, d.hum_phase_turns) = (hz, counts, 0.21);
            }
            match class.front {
                Front::Step(c) => (d.step_i, d.step_at) = (c, BLOCK_PAIRS / 2),
                Front::Offset(c) => (d.step_i, d.step_at) = (c, 0),
                Front::Burst(c, pairs) => {
                    (d.step_i, d.step_at, d.step_until) = (c, BLOCK_PAIRS / 3, BLOCK_PAIRS / 3 + pairs)
                }
                Front::Stuck(c) => d.stuck_i = Some(c),
                _ => {}
            }
            let clipped = fe.at_range(&settings.ranging, ch.range()).mux_block(
                index,
                |f| seen(&sensor, &class.sensor, f),
                &mut rng,
                &mut buf,
                &d,
            );
            let ph = instrument::config::read(index, buf.as_slice().try_into().expect("a block's pairs"));
            let r = ch.process(&settings, 0, (t * 1e6) as u64, &ph, clipped, ch.range());
            if b > 0 {
                out.add(r.flags, r.c_farad, truth);
            }
        }
    }
    out
}

/// The array under `class` in 4 ms blocks, or `None` where its front
/// end does not simulate the class.
pub fn array(class: &Class) -> Option<Outcome> {
    array_in(Layout::BLOCK_4MS, class)
}

/// The array under `class` in blocks of `layout` (0.4 s of them), or
/// `None` where its front end does not simulate the class.
pub fn array_in(layout: Layout, class: &Class) -> Option<Outcome> {
    array_for(layout, class, &Profile::paper(20.0), 0.4, 1e-9)
}

/// The array under `class` in blocks of `layout`, its sensors stretched
/// by `profile` (sensor s a 0.4·s s later in it), for `duration_s`,
/// counting the records of the blocks that start `from_s` or later, or
/// `None` where its front end does not simulate the class. The class
/// starts with the run.
pub fn array_for(
    layout: Layout,
    class: &Class,
    profile: &Profile,
    duration_s: f64,
    from_s: f64,
) -> Option<Outcome> {
    array_for_mains(
        layout,
        class,
        profile,
        duration_s,
        from_s,
        instrument::mains::MAINS_HZ,
    )
}

/// [`array_for`] with the reader set for mains at `mains_hz`.
pub fn array_for_mains(
    layout: Layout,
    class: &Class,
    profile: &Profile,
    duration_s: f64,
    from_s: f64,
    mains_hz: u32,
) -> Option<Outcome> {
    if matches!(
        class.front,
        Front::Step(_) | Front::Offset(_) | Front::Burst(..) | Front::Stuck(_)
    ) {
        return None;
    }
    let fe = ArrayFrontEnd::reference(layout);
    let paper = SensorParams::PAPER;
    let each = paper_sensors();
    let settings = ToneSettings::new(layout, fe.dsp_front_end(), &each);
    let mut reader = ArrayReader::for_mains(layout, &each, mains_hz).expect("the array's comb lays out");
    let mut rng = Rng::new(0xa77a);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let block_s = layout.block_us() as f64 * 1e-6;
    let duration = duration_s;
    let blocks = (duration / block_s) as u64;
    let hz = layout.tones_hz().map(|f| f as f64);
    let mut out = Outcome::new();
    // The tone the paper's sensors read most (their three's lowest) is
    // what a tone-relative sinusoid aims at: 500 Hz (1 ms blocks: 1 kHz;
    // the 4 ms comb's 250 Hz is for electrodes of higher resistance).
    let aim = layout.tone_hz(usize::from(layout.tone_hz(0) < 500.0));
    let sample_rate = RATE_HZ as f32;
    for b in 0..blocks {
        let t = b as f64 * block_s;
        let t_us = (t * 1e6) as u64 + (block_s * 5e5) as u64;
        let mut z = [[num_complex::Complex64::new(0.0, 0.0); instrument::array::TONES]; SENSORS];
        let mut truth = [0.0; SENSORS];
        for s in 0..SENSORS {
            let mut sensor = Sensor::settled(sensor_params(paper, &class.sensor, t, duration));
            sensor.advance(profile, 0.4 * s as f64 + t);
            z[s] = hz.map(|f| seen(&sensor, &class.sensor, f));
            truth[s] = sensor.truth().c_farad;
        }
        let mut d = Disturbance {
            t0_s: t,
            ..Disturbance::NONE
        };
        if let Some((f, counts)) = sine_hz(&class.front, &[aim, layout.tone_hz(TONES - 1)], sample_rate) {
            // The array's counts are 16-bit: the same share of full scale.
            (d.hum_hz, d.hum_i, d.hum_phase_turns) = (f, counts * 16.0, 0.21);
        }
        let clipped = fe.frame(&z, &[d; SENSORS], &mut rng, &mut frame);
        reader.read(
            &settings,
            t_us,
            |a| layout.rows(&frame[a]),
            |input| clipped[input],
            |rec| {
                if t >= from_s {
                    out.add(rec.flags, rec.c_farad, truth[usize::from(rec.sensor)]);
                }
            },
        );
    }
    Some(out)
}

/// Every sensor of the array as the firmware reads a paper's sensor: its
/// calibration and its tab leads, no wiring.
pub fn paper_sensors() -> Sensors<{ calib::POINTS }, SENSORS> {
    let lead = SensorParams::PAPER.effects.lead_ratio();
    Sensors::from_fn(|_| {
        Measured::calibrated(skin_sim::sensor::PAPER_CALIBRATION, lead, Fixture::NONE)
            .expect("the paper's calibration is valid")
    })
}

/// One row of the table: a class, what the multiplexed channel made of
/// it, and the array's (`None`: not simulated there).
pub type Row = (Class, Outcome, Option<Outcome>);

/// Every class on both paths.
pub fn rows() -> Vec<Row> {
    CLASSES.iter().map(|c| (*c, multiplexed(c), array(c))).collect()
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut md = String::from(
        "| class | added | multiplexed: valid | not valid: faults | valid > 1 % off | worst valid | array: valid | not valid: faults | valid > 1 % off | worst valid |\n|---|---|---:|---|---:|---:|---:|---|---:|---:|\n",
    );
    let cell = |o: &Outcome| {
        let a = &o.availability;
        format!(
            "{:.1} % of {} | {} | {} | {:.2} %",
            100.0 * a.share().unwrap_or(0.0),
            a.records,
            a.why(),
            o.valid_off,
            100.0 * o.worst_valid
        )
    };
    for (class, m, a) in rows {
        let a = a.as_ref().map_or_else(|| "– | – | – | –".to_string(), cell);
        md += &format!("| {} | {} | {} | {} |\n", class.name, class.what, cell(m), a);
    }
    md
}

/// Every class on both paths, as a Markdown table.
pub fn table() -> String {
    markdown(&rows())
}
