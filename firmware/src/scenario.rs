//! The simulated skin of the QEMU runs: eight sensors, their stretch
//! profiles, the front end, and injected faults. It stands in for the
//! multiplexer, the DAC and the ADC/DMA of the board, producing the same
//! blocks of `[voltage, current]` pairs the board's DMA would.

use core::sync::atomic::{AtomicU8, Ordering};
use embedded_hal::digital::{ErrorType, OutputPin};
use instrument::calib::{CalTable, POINTS, REFERENCE};
use instrument::config::{BLOCK_PAIRS, CHANNELS, MUX_ADDRESS_LINES, RANGE_ADDRESS_LINES};
use instrument::effects::{Effect, EffectSet};
use instrument::ranging::Ranging;
use skin_sim::frontend::{Disturbance, FrontEndParams};
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams, Truth, PAPER_CALIBRATION};

/// A test scenario, chosen by name on the semihosting command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// Channel 0 stretched slowly (1 mm/s ramp); the rest at rest.
    Slow,
    /// Channel 0 on the paper's 20 mm/s trapezoid; the rest at rest.
    Paper20,
    /// The main job: channel 0 at 20 mm/s, channel 1 at 10 mm/s (the
    /// paper's trapezoids, two periods), the rest held at 0–14 mm.
    Paper,
    /// Eight different sensors, each on its own slow trapezoid.
    Eight,
    /// Faults from 1 s to 2 s: channel 1 open, channel 2 clipping,
    /// channel 3 electrodes at 10 MΩ, channel 4 electrodes stepping 8×
    /// from 356 kΩ to 2.85 MΩ (ωRC from 3 to 24 at 5859 Hz, where it sat:
    /// beyond the inversion's range, below the broken-electrode limit),
    /// channel 5 under 300 counts of
    /// 50 Hz hum, channel 6's current ADC stuck at one code, channel 7 a
    /// 400-count step in the middle of every block.
    Faults,
    /// A data-set recording of sensors with an undeclared effect
    /// ([`HIDDEN`]): channels 0–2 on the 20 mm/s trapezoid at a fixed
    /// 586 Hz, 1953 Hz and 5859 Hz; channels 3–7 held at 0, 7.5, 15, 22.5
    /// and 30 mm at 586 Hz (the static calibration).
    Identify,
    /// As `paper` (adaptive frequency), with the undeclared effect.
    Hidden,
    /// Panic after a few blocks (the harness must report it).
    Panic,
    /// Hang after a few blocks (the watchdog must catch it).
    Hang,
}

impl Scenario {
    /// Parse a scenario name.
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "slow" => Self::Slow,
            "paper20" => Self::Paper20,
            "paper" => Self::Paper,
            "eight" => Self::Eight,
            "faults" => Self::Faults,
            "identify" => Self::Identify,
            "hidden" => Self::Hidden,
            "panic" => Self::Panic,
            "hang" => Self::Hang,
            _ => return None,
        })
    }

    /// The frequency index channel `ch` is held at, if any.
    pub fn pinned(&self, ch: usize) -> Option<usize> {
        match (self, ch) {
            (Self::Identify, 0) => Some(0),
            (Self::Identify, 1) => Some(2),
            (Self::Identify, 2) => Some(4),
            (Self::Identify, _) => Some(0),
            _ => None,
        }
    }

    /// The sensor every channel of the scenario starts from: the paper's
    /// (`SensorParams::PAPER`, with tab leads) where the scenario plays
    /// the paper's stretching; the reference sensor (no leads) where the
    /// tests were sized on it: eight sensors scaled around it, the fault
    /// injections' resistance limits, and the calibration loop's hidden
    /// cable capacitance.
    pub fn sensor(&self) -> SensorParams {
        match self.on_paper_sensor() {
            true => SensorParams::PAPER,
            false => SensorParams::REFERENCE,
        }
    }

    fn on_paper_sensor(&self) -> bool {
        matches!(self, Self::Slow | Self::Paper20 | Self::Paper)
    }

    /// The calibration installed for the scenario's sensor, as the board
    /// holds it in flash: the stretch table of its line capacitance.
    pub fn calibration(&self) -> &'static CalTable<POINTS> {
        match self.on_paper_sensor() {
            true => &PAPER_CALIBRATION,
            false => &REFERENCE,
        }
    }

    /// The tab-lead ratio installed for the scenario's sensor (what
    /// `host-sim identify` finds on its static sweep: the paper's
    /// `lead_resistance` 0.642 ± 0.010 for its sensor, none for the
    /// reference sensor), unless the command line gives one.
    pub fn lead_ratio(&self) -> f32 {
        self.sensor().effects.lead_ratio()
    }

    /// Simulated duration, s.
    pub fn duration_s(&self) -> f32 {
        match self {
            Self::Slow => 6.0,
            Self::Paper20 => 10.0,
            Self::Paper | Self::Identify | Self::Hidden => 20.0,
            Self::Eight => 4.0,
            Self::Faults => 3.5,
            Self::Panic | Self::Hang => 1.0,
        }
    }
}

/// The simulated port of the multiplexer's address lines (bit i = line
/// Ai, i < 3) and the range switch's (bits 3 and 4).
pub static MUX_LINES: AtomicU8 = AtomicU8::new(0);

/// A simulated GPIO output driving one multiplexer address line.
pub struct SimPin(u8);

impl ErrorType for SimPin {
    type Error = core::convert::Infallible;
}

impl OutputPin for SimPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        MUX_LINES.fetch_and(!(1 << self.0), Ordering::Relaxed);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        MUX_LINES.fetch_or(1 << self.0, Ordering::Relaxed);
        Ok(())
    }
}

/// The three simulated address lines A0..A2.
pub fn mux_pins() -> [SimPin; MUX_ADDRESS_LINES] {
    [SimPin(0), SimPin(1), SimPin(2)]
}

/// The range switch's two simulated address lines.
pub fn range_pins() -> [SimPin; RANGE_ADDRESS_LINES] {
    [SimPin(3), SimPin(4)]
}

/// The undeclared effect of the `identify` and `hidden` scenarios: 12 pF
/// of cable capacitance in parallel with every sensor at the front end.
pub const HIDDEN: EffectSet = EffectSet::NONE.with(Effect::ParasiticCapacitance, 12e-12);

/// Fault window of the `faults` scenario, s.
pub const FAULT_WINDOW: (f32, f32) = (1.0, 2.0);

/// The simulated skin.
pub struct Skin {
    scenario: Scenario,
    sensors: [Sensor; CHANNELS],
    broken: Sensor,
    stepped: Sensor,
    front_end: FrontEndParams,
    ranging: Ranging,
    rng: Rng,
}

/// Sensor parameters of channel `ch` in `scenario`.
fn params(scenario: Scenario, ch: usize) -> SensorParams {
    let mut p = scenario.sensor();
    if scenario == Scenario::Eight {
        // Sensors of 150–290 pF and 0.65–1.35× the reference electrodes.
        p.c_rest_farad = (150.0 + 20.0 * ch as f64) * 1e-12;
        let k = 0.65 + 0.1 * ch as f64;
        p.top.r_rest_ohm *= k;
        p.bottom.r_rest_ohm *= k;
    }
    if matches!(scenario, Scenario::Identify | Scenario::Hidden) {
        p.effects = HIDDEN;
    }
    if scenario == Scenario::Faults && ch == 4 {
        // Low-resistance electrodes (356 kΩ): at rest the policy climbs to
        // the highest frequency.
        p.top.r_rest_ohm *= 0.5;
        p.bottom.r_rest_ohm *= 0.5;
    }
    p
}

impl Skin {
    /// The skin of `scenario` at t = 0.
    pub fn new(scenario: Scenario) -> Self {
        let sensors = core::array::from_fn(|ch| Sensor::settled(params(scenario, ch)));
        let mut broken = SensorParams::REFERENCE;
        broken.top.r_rest_ohm = 5e6;
        broken.bottom.r_rest_ohm = 5e6;
        let mut stepped = params(scenario, 4);
        stepped.top.r_rest_ohm *= 8.0;
        stepped.bottom.r_rest_ohm *= 8.0;
        Self {
            scenario,
            sensors,
            broken: Sensor::settled(broken),
            stepped: Sensor::settled(stepped),
            front_end: FrontEndParams::REFERENCE,
            ranging: FrontEndParams::REFERENCE.ranging(),
            rng: Rng::new(0x5eed),
        }
    }

    /// The front end at its lowest range.
    pub fn front_end(&self) -> &FrontEndParams {
        &self.front_end
    }

    /// The front end's ranges (for the transimpedances the firmware
    /// divides by).
    pub fn ranging(&self) -> Ranging {
        self.ranging
    }

    /// Stretch profile of channel `ch`.
    pub fn profile(&self, ch: usize) -> Profile<'static> {
        match (self.scenario, ch) {
            (Scenario::Slow, 0) => Profile::Ramp {
                rate: 1.0,
                amplitude: 10.0,
            },
            (Scenario::Paper20 | Scenario::Paper | Scenario::Hidden, 0) => Profile::paper(20.0),
            (Scenario::Paper | Scenario::Hidden, 1) => Profile::paper(10.0),
            (Scenario::Identify, 0..=2) => Profile::paper(20.0),
            (Scenario::Identify, c) => Profile::Constant(7.5 * (c - 3) as f64),
            (Scenario::Eight, c) => Profile::Trapezoid {
                rate: 2.0 + c as f64,
                amplitude: 5.0 + 2.0 * c as f64,
                period: 8.0,
            },
            (_, c) => Profile::Constant(2.0 * c as f64),
        }
    }

    /// Fill `out` with the block of the channel the multiplexer's address
    /// lines select, excited at frequency index `fidx`, for the block
    /// whose middle is at `t_us` (µs since start); returns (channel,
    /// clipped, truth).
    pub fn block(&mut self, fidx: usize, t_us: u64, out: &mut [[i16; 2]; BLOCK_PAIRS]) -> (u8, bool, Truth) {
        let lines = MUX_LINES.load(Ordering::Relaxed);
        let ch = (lines as usize) % CHANNELS;
        let range = (lines >> 3) & 0b11;
        let t_mid = t_us as f64 * 1e-6;
        let t_s = t_mid as f32;
        let profile = self.profile(ch);
        self.sensors[ch].advance(&profile, t_mid);
        let in_fault = self.scenario == Scenario::Faults && t_s >= FAULT_WINDOW.0 && t_s < FAULT_WINDOW.1;
        let mut fe = self.front_end.at_range(&self.ranging, range);
        // Which sensor the front end sees.
        let source = match (in_fault, ch) {
            // Disconnected: only a picofarad of stray capacitance remains.
            (true, 1) => None,
            // A gain fault: far too much transimpedance.
            (true, 2) => {
                fe.tia_ohm *= 20.0;
                Some(&self.sensors[ch])
            }
            // Electrodes broken to 10 MΩ.
            (true, 3) => {
                self.broken.advance(&Profile::Constant(0.0), t_mid);
                Some(&self.broken)
            }
            // Electrodes at 8× their resistance, from one block to the next.
            (true, 4) => {
                self.stepped.advance(&self.profile(4), t_mid);
                Some(&self.stepped)
            }
            _ => Some(&self.sensors[ch]),
        };
        let truth = source.map_or(Truth::default(), Sensor::truth);
        let z = |f: f64| match source {
            Some(s) => s.impedance(f),
            None => num_complex::Complex64::new(0.0, -1.0 / (core::f64::consts::TAU * f * 1e-15)),
        };
        let block_s = BLOCK_PAIRS as f64 / fe.sample_rate_hz;
        let d = match (in_fault, ch) {
            (true, 5) => Disturbance {
                hum_hz: 50.0,
                hum_i: 300.0,
                t0_s: t_mid - 0.5 * block_s,
                ..Disturbance::NONE
            },
            (true, 6) => Disturbance {
                stuck_i: Some(1234),
                ..Disturbance::NONE
            },
            (true, 7) => Disturbance {
                step_i: 400.0,
                step_at: BLOCK_PAIRS / 2,
                ..Disturbance::NONE
            },
            _ => Disturbance::NONE,
        };
        let clipped = fe.mux_block(fidx, z, &mut self.rng, out, &d);
        (ch as u8, clipped, truth)
    }
}
