//! The simulated skin of the array's QEMU runs ([`instrument::array`]):
//! sixteen sensors, their stretch, and the comb front end that fills a
//! block of the five ADCs' scans, as the board's DMA would.

use dsp_core::fixture::Fixture;
use dsp_core::tline::ModelError;
use instrument::array::{Frame, Layout, SENSORS, TONES};
use instrument::calib::POINTS;
use instrument::effects::Effect;
use instrument::policy::Policy;
use instrument::sensor::{Sensor as Measured, Sensors};
use instrument::stored::Stored;
use instrument::wire;
use skin_sim::array::{ArrayFrontEnd, INPUTS};
use skin_sim::frontend::Disturbance;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams, PAPER_CALIBRATION};

/// An array scenario, chosen by name on the semihosting command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArrayScenario {
    /// Sixteen of the paper's sensors on its 20 mm/s trapezoid, sensor s
    /// 0.6·s s ahead in its cycle: every phase of the motion at once.
    Paper,
    /// The model check: sensors 0–5 clean, 6–10 with 30 kΩ of undeclared
    /// contact per tab, 11–15 with 2 pF of undeclared cable capacitance;
    /// all on the 20 mm/s trapezoid.
    Check,
    /// Mains hum: as `paper`, with 50 Hz on sensors 4–7 (30, 100, 300 and
    /// 1000 counts) from 1 s to 2 s.
    Hum,
    /// A data-set recording for `host-sim identify`: every sensor the
    /// reference sensor (no tab leads, so the one undeclared effect is
    /// alone) with 12 pF of undeclared cable capacitance ([`HIDDEN_PF`]);
    /// sensors 0–3 on the 20 mm/s trapezoid (staggered), 4–15 held at
    /// 0–30 mm (the static calibration).
    Identify,
    /// A skin of sixteen different sensors ([`SensorParams::hand_made`]), none the
    /// reference, on the paper's 20 mm/s trapezoid (staggered).
    Skin,
    /// A calibration run on the same sixteen sensors as `skin`: all held
    /// together at 0, 3, …, 30 mm in turn ([`skin_sim::stairs`]).
    Stairs,
}

/// A board assembled wrong, for the self-test's failing cases (`fault=`
/// on the command line).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardFault {
    /// `fault=reference`: the reference network's capacitor from the
    /// wrong reel (270 pF for 220 pF): the chain fails, every sensor is
    /// refused.
    Reference,
    /// `fault=stage`: sensor [`FAULTY_STAGE`]'s stage open loop (its
    /// feedback resistor missing), its output on a rail: that sensor is
    /// refused.
    Stage,
}

/// The sensor whose stage `fault=stage` leaves open loop.
pub const FAULTY_STAGE: usize = 5;

impl BoardFault {
    /// Parse a fault's name.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "reference" => Some(Self::Reference),
            "stage" => Some(Self::Stage),
            _ => None,
        }
    }

    /// The front end assembled with this fault.
    fn apply(self, fe: &mut ArrayFrontEnd) {
        match self {
            Self::Reference => {
                fe.reference = fe.reference.map(|(r, _)| (r, 270e-12));
            }
            Self::Stage => fe.offset_counts[instrument::array::input_of(FAULTY_STAGE)] = 40_000.0,
        }
    }
}

/// The undeclared cable capacitance of the `identify` scenario, pF.
pub const HIDDEN_PF: f64 = 12.0;

impl ArrayScenario {
    /// Parse a scenario name.
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "paper" => Self::Paper,
            "check" => Self::Check,
            "hum" => Self::Hum,
            "identify" => Self::Identify,
            "skin" => Self::Skin,
            "stairs" => Self::Stairs,
            _ => return None,
        })
    }

    /// Simulated duration, s.
    pub fn duration_s(&self) -> f32 {
        match self {
            Self::Paper => 10.0,
            Self::Check | Self::Hum => 3.0,
            Self::Identify | Self::Skin => 10.0,
            Self::Stairs => skin_sim::stairs::DURATION_S as f32,
        }
    }

    /// Sensor `s`'s parameters.
    pub fn params(&self, s: usize) -> SensorParams {
        let mut p = SensorParams::PAPER;
        match self {
            Self::Check => {
                p.effects = match s {
                    0..=5 => p.effects,
                    6..=10 => p.effects.with(Effect::ContactResistance, 30e3),
                    _ => p.effects.with(Effect::ParasiticCapacitance, 2e-12),
                }
            }
            Self::Identify => {
                p = SensorParams::REFERENCE;
                p.effects = p.effects.with(Effect::ParasiticCapacitance, HIDDEN_PF * 1e-12);
            }
            Self::Skin | Self::Stairs => p = SensorParams::hand_made(s),
            _ => {}
        }
        p
    }

    /// Sensor `s`'s stretch.
    pub fn profile(&self, s: usize) -> Profile<'static> {
        match (self, s) {
            (Self::Identify, 4..) => Profile::Constant(30.0 * (s - 4) as f64 / 11.0),
            (Self::Stairs, _) => skin_sim::stairs::PROFILE,
            _ => Profile::paper(20.0),
        }
    }

    /// The firmware's description of the skin (the test rig knows its
    /// simulated sensors, as a calibration run would): every sensor on
    /// the paper's table with the paper's tab leads, no wiring declared.
    /// As a stored set, the default policy, every sensor in use.
    pub fn rig(&self) -> Result<Stored, ModelError> {
        let lead = SensorParams::PAPER.effects.lead_ratio();
        let paper = Measured::calibrated(PAPER_CALIBRATION, lead, Fixture::NONE)?;
        Ok(Stored::of_sensors(
            &Sensors::<POINTS, 1>::all(paper),
            &Policy::DEFAULT,
            instrument::design::SENSOR_R_REST_OHM as f32,
            SENSORS,
        ))
    }
}

/// How far ahead in its cycle sensor `s` runs, s.
fn lead_s(scenario: ArrayScenario, s: usize) -> f64 {
    match scenario {
        ArrayScenario::Paper | ArrayScenario::Hum | ArrayScenario::Identify | ArrayScenario::Skin => {
            0.6 * s as f64
        }
        ArrayScenario::Check | ArrayScenario::Stairs => 0.0,
    }
}

/// The simulated skin of the array.
pub struct ArraySkin {
    scenario: ArrayScenario,
    sensors: [Sensor; SENSORS],
    front_end: ArrayFrontEnd,
    rng: Rng,
}

impl ArraySkin {
    /// The skin of `scenario` at t = 0, read in blocks of `layout`.
    pub fn new(scenario: ArrayScenario, layout: Layout) -> Self {
        let sensors = core::array::from_fn(|s| {
            let mut sensor = Sensor::settled(scenario.params(s));
            sensor.advance(&scenario.profile(s), lead_s(scenario, s));
            sensor
        });
        Self {
            scenario,
            sensors,
            front_end: ArrayFrontEnd::reference(layout),
            rng: Rng::new(0xa11a),
        }
    }

    /// Assemble the board with `fault` (None: as designed).
    pub fn set_fault(&mut self, fault: Option<BoardFault>) {
        if let Some(f) = fault {
            f.apply(&mut self.front_end);
        }
    }

    /// The front end (for the transimpedance the firmware divides by).
    pub fn front_end(&self) -> &ArrayFrontEnd {
        &self.front_end
    }

    /// Fill `frame` with the block whose middle is at `t_us` (µs since
    /// start); returns which inputs clipped, and writes each sensor's
    /// truth to `truth`.
    pub fn block(
        &mut self,
        t_us: u64,
        frame: &mut Frame,
        truth: &mut [wire::TruthLine; SENSORS],
    ) -> [bool; INPUTS] {
        let t = t_us as f64 * 1e-6;
        let layout = &self.front_end.layout;
        let hz = layout.tones_hz().map(|f| f as f64);
        let mut z = [[num_complex::Complex64::new(0.0, 0.0); TONES]; SENSORS];
        let mut hum = [Disturbance::NONE; SENSORS];
        let block_s = layout.block_us() as f64 * 1e-6;
        for (s, sensor) in self.sensors.iter_mut().enumerate() {
            sensor.advance(&self.scenario.profile(s), t + lead_s(self.scenario, s));
            z[s] = sensor.impedances(&hz);
            truth[s] = sensor.truth().line(t_us, s as u8);
            if self.scenario == ArrayScenario::Hum && (4..8).contains(&s) && (1.0..2.0).contains(&t) {
                const HUM: [f32; 4] = [30.0, 100.0, 300.0, 1000.0];
                hum[s] = Disturbance {
                    hum_hz: 50.0,
                    hum_i: HUM[s - 4],
                    t0_s: t - 0.5 * block_s,
                    ..Disturbance::NONE
                };
            }
        }
        self.front_end.frame(&z, &hum, &mut self.rng, frame)
    }
}
