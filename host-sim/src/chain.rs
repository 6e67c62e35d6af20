//! The measurement chain: a simulated sensor read at one excitation
//! frequency, either through the front end, the ADC and the firmware's own
//! channel (`instrument::channel::Channel::process`: demodulation, fault
//! checks, line tracking; pinned to the nearest frequency of the firmware's
//! set, in its blocks and slots) or by an ideal series LCR meter (the
//! paper's instrument). Both report the lumped Cs–Rs and the line-corrected
//! C and R.

use crate::numerics::series_cs;
use dsp_core::fixture::Fixture;
use dsp_core::lumped::SeriesRc;
use dsp_core::tline::LineModel;
use dsp_core::track::{TrackState, Tracker};
use instrument::calib;
use instrument::channel::{Channel, Settings};
use instrument::config::{self, PERIODS};
use instrument::effects::{Effect, EffectSet};
use instrument::sensor::{Sensor as Measured, Sensors};
use num_complex::Complex64;
use skin_sim::frontend::Disturbance;
use skin_sim::frontend::FrontEndParams;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::Sensor;

/// How the impedance is measured.
#[derive(Clone, Copy, Debug)]
pub enum Meter {
    /// Front end, ADC, and the firmware's channel, slot by slot.
    Adc(FrontEndParams),
    /// An ideal series Cs–Rs meter, sampled every `interval_s`, with
    /// Gaussian reading noise of `rel` (relative) plus `abs_farad` on Cs and
    /// `rel` on Rs (the example data set: 0.02 % + 0.02 pF).
    ///
    /// Its reading at t is the mean admittance over the integration window
    /// [t + offset − window, t + offset]: `window_s` is the meter's lag,
    /// `offset_s` the misalignment of the capacitance channel against the
    /// stretch and resistance columns recorded in another run (> 0: the
    /// capacitance is late). Both 0 for an instantaneous, aligned meter.
    /// With `response_s` > 0, the (windowed) admittance then passes a
    /// first-order filter of that time constant (a lock-in's RC output
    /// filter), settled on the sensor at rest before the run.
    Lcr(LcrMeter),
}

impl Meter {
    /// The paper's LCR meter: 50 readings/s, 0.02 % + 0.02 pF.
    pub const LCR: Meter = Meter::lcr(&EffectSet::NONE);

    /// The paper's LCR meter with the recording's effects of `effects`
    /// (the catalogue's [`Effect::MeterLag`] window and
    /// [`Effect::TimeOffset`] of the capacitance channel).
    pub const fn lcr(effects: &EffectSet) -> Meter {
        Meter::Lcr(LcrMeter {
            interval_s: 0.02,
            rel: 2e-4,
            abs_farad: 0.02e-12,
            window_s: effects.get(Effect::MeterLag),
            offset_s: effects.get(Effect::TimeOffset),
            response_s: effects.get(Effect::MeterResponse),
            response_order: effects.get(Effect::MeterOrder),
            mean_readings: effects.get(Effect::MeterMean),
            ewma_memory: effects.get(Effect::MeterEwma),
        })
    }

    /// How far before a reading's time the meter looks, s (≥ 0): the
    /// sensor must be at or before `t − lookback` when a run starts at t.
    pub fn lookback_s(&self) -> f64 {
        match *self {
            Meter::Lcr(m) => (m.window_s + m.response_reach_s() - m.offset_s).max(0.0),
            Meter::Adc(_) => 0.0,
        }
    }
    /// The reference front end and ADC.
    pub const ADC: Meter = Meter::Adc(FrontEndParams::REFERENCE);
}

/// One reading with the truth beside it.
#[derive(Clone, Copy, Debug)]
pub struct Reading {
    /// Time, s.
    pub t: f64,
    /// Stretch, mm.
    pub stretch_mm: f64,
    /// True line capacitance, F.
    pub c_true: f64,
    /// True line resistance (both electrodes, no contacts), Ω.
    pub r_line: f64,
    /// End-to-end top electrode resistance, Ω.
    pub r_top: f64,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom: f64,
    /// Excitation frequency actually used, Hz.
    pub freq_hz: f64,
    /// Lumped series capacitance, F.
    pub cs: f64,
    /// Lumped series resistance, Ω.
    pub rs: f64,
    /// Line-corrected capacitance, F (NaN when the inversion failed).
    pub c_corr: f64,
    /// Line-corrected resistance, Ω (NaN when the inversion failed).
    pub r_corr: f64,
    /// The ADC clipped during this reading.
    pub clipped: bool,
}

/// How the chain is set up.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    /// Excitation frequency, Hz.
    pub freq_hz: f64,
    /// How the impedance is measured.
    pub meter: Meter,
    /// Line model of the correction.
    pub model: LineModel,
    /// Prior capacitance (F), e.g. the rest value of the static
    /// calibration: picks the branch until a reading is tracked.
    pub prior_farad: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Tab-lead ratio the correction assumes (the device calibration's
    /// `EffectSet::lead_ratio`; 0: none).
    pub lead_ratio: f32,
}

/// Read `sensor` following `profile` from `t_start` until `t_end` (s);
/// `tick` is called with the time of every reading (progress). The sensor
/// should be at or before `t_start − meter.lookback_s()`.
pub fn run(
    sensor: &mut Sensor,
    profile: &Profile,
    setup: Setup,
    t_start: f64,
    t_end: f64,
    tick: impl FnMut(f64),
) -> Vec<Reading> {
    let span = (t_start, t_end);
    match setup.meter {
        Meter::Adc(fe) => run_adc(sensor, profile, &fe, &setup, span, tick),
        Meter::Lcr(lcr) => run_lcr(sensor, profile, &lcr, &setup, span, tick),
    }
}

/// The firmware's channel, pinned to the frequency of its set nearest to
/// the one asked for: blocks of `config::BLOCK_PAIRS` pairs after
/// `SETTLE_PAIRS` of settling, one slot each, through front end `fe` and
/// its ADC.
fn run_adc(
    sensor: &mut Sensor,
    profile: &Profile,
    fe: &FrontEndParams,
    setup: &Setup,
    (t_start, t_end): (f64, f64),
    mut tick: impl FnMut(f64),
) -> Vec<Reading> {
    let mut rng = Rng::new(setup.seed);
    let fs = fe.sample_rate_hz;
    let index = (0..PERIODS.len())
        .min_by(|&a, &b| {
            let d = |i: usize| (config::freq_hz(i) as f64 / setup.freq_hz).ln().abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(0);
    let f = config::freq_hz(index) as f64;
    let ranging = fe.ranging();
    let sensor_model = Measured::calibrated(calib::REFERENCE, setup.lead_ratio, Fixture::NONE)
        .expect("a calibration's lead ratio is in range");
    let sensors = Sensors::<{ calib::POINTS }, 1>::all(sensor_model);
    let settings = Settings::new(ranging.front_ends(fe.v_gain as f32), ranging, &sensors);
    let mut ch = Channel::pinned(setup.prior_farad as f32, index);
    let slot = (config::BLOCK_PAIRS + config::SETTLE_PAIRS) as f64 / fs;
    let settle = config::SETTLE_PAIRS as f64 / fs;
    let block = config::BLOCK_PAIRS as f64 / fs;
    let mut buf = [[0i16; 2]; config::BLOCK_PAIRS];
    let mut out = Vec::new();
    sensor.advance(profile, t_start);
    let mut t = sensor.time();
    while t + slot <= t_end + 1e-12 {
        let mid = t + settle + 0.5 * block;
        sensor.advance(profile, mid);
        let truth = sensor.truth();
        let range = ch.range();
        let clipped = fe.at_range(&ranging, range).mux_block(
            index,
            |f| sensor.impedance(f),
            &mut rng,
            &mut buf,
            &Disturbance::NONE,
        );
        let ph = config::read(index, &buf);
        let rec = ch.process(&settings, 0, (mid * 1e6).round() as u64, &ph, clipped, range);
        let measured = |v: f32| if v > 0.0 { v as f64 } else { f64::NAN };
        let (c_corr, r_corr) = if rec.flags.valid() && rec.c_farad > 0.0 {
            (rec.c_farad as f64, rec.r_ohm as f64)
        } else {
            (f64::NAN, f64::NAN)
        };
        out.push(reading(
            &truth,
            f,
            measured(rec.cs_farad),
            measured(rec.rs_ohm),
            c_corr,
            r_corr,
            clipped,
        ));
        t += slot;
        sensor.advance(profile, t);
        tick(t);
    }
    out
}

/// An LCR meter's settings ([`Meter::Lcr`]).
#[derive(Clone, Copy, Debug)]
pub struct LcrMeter {
    /// Sampling interval, s.
    pub interval_s: f64,
    /// Relative noise (1 σ).
    pub rel: f64,
    /// Absolute capacitance noise (1 σ), F.
    pub abs_farad: f64,
    /// Integration window, s.
    pub window_s: f64,
    /// Time offset of the capacitance channel, s.
    pub offset_s: f64,
    /// First-order response time constant, s (0: none).
    pub response_s: f64,
    /// Sections of that response in cascade, 1…4 (a fraction mixes the
    /// next order in part; 0: one).
    pub response_order: f64,
    /// Readings of its running mean, one per `interval_s` (0: none; a
    /// fraction weighs the oldest in part).
    pub mean_readings: f64,
    /// Memory m of its weighted mean of readings, y = (1 − m)·x + m·y
    /// (0: none).
    pub ewma_memory: f64,
}

impl LcrMeter {
    /// The order of its response, 1…4.
    fn order(&self) -> f64 {
        self.response_order.clamp(1.0, 4.0)
    }

    /// How far back its response reaches, s: (8 + 4n)·τ for n sections
    /// (12 τ for one: the weights further back are under 10⁻⁵; 24 τ for
    /// four, under 10⁻⁶).
    pub fn response_reach_s(&self) -> f64 {
        (8.0 + 4.0 * self.order()) * self.response_s
    }
}

/// A meter's average of its own readings (Cs, Rs) in discrete time: a
/// running mean of N, or a weighted mean of memory m, settled on its
/// first reading (the sensor at rest before the run).
enum ReadingAverage {
    /// The readings as they are.
    None,
    /// The mean of the last `n` (a fraction weighs the oldest in part),
    /// newest first.
    Mean {
        n: f64,
        history: std::collections::VecDeque<(f64, f64)>,
    },
    /// y = (1 − m)·x + m·y.
    Weighted { m: f64, state: Option<(f64, f64)> },
}

impl ReadingAverage {
    fn new(lcr: &LcrMeter) -> Self {
        if lcr.mean_readings > 0.0 {
            Self::Mean {
                n: lcr.mean_readings.max(1.0),
                history: Default::default(),
            }
        } else if lcr.ewma_memory > 0.0 {
            Self::Weighted {
                m: lcr.ewma_memory,
                state: None,
            }
        } else {
            Self::None
        }
    }

    /// The average after the reading `x`.
    fn push(&mut self, x: (f64, f64)) -> (f64, f64) {
        match self {
            Self::None => x,
            Self::Mean { n, history } => {
                let keep = n.ceil() as usize;
                if history.is_empty() {
                    history.extend(std::iter::repeat_n(x, keep));
                }
                history.push_front(x);
                history.truncate(keep);
                let whole = n.floor() as usize;
                let part = *n - whole as f64;
                let mut sum = history
                    .iter()
                    .take(whole)
                    .fold((0.0, 0.0), |a, r| (a.0 + r.0, a.1 + r.1));
                if part > 0.0 {
                    let r = history[whole.min(keep - 1)];
                    sum = (sum.0 + part * r.0, sum.1 + part * r.1);
                }
                (sum.0 / *n, sum.1 / *n)
            }
            Self::Weighted { m, state } => {
                let y = state.unwrap_or(x);
                let y = ((1.0 - *m) * x.0 + *m * y.0, (1.0 - *m) * x.1 + *m * y.1);
                *state = Some(y);
                y
            }
        }
    }
}

/// The mean admittance of the sensor over `[start, start + window_s]`,
/// sampled at the midpoints of ≤ 2 ms sub-intervals; `m` waits at
/// `start` (windows overlap: a copy integrates this one).
fn mean_admittance(m: &mut Sensor, profile: &Profile, start: f64, window_s: f64, freq_hz: f64) -> Complex64 {
    let k = ((window_s / 2e-3).ceil() as usize).clamp(1, 500);
    m.advance(profile, start);
    let mut v = m.clone();
    let mut y = Complex64::default();
    for j in 0..k {
        v.advance(profile, start + window_s * (j as f64 + 0.5) / k as f64);
        y += v.impedance(freq_hz).inv();
    }
    y / k as f64
}

/// A response of n first-order sections of time constant τ in cascade
/// (1…4, and a fraction of the next) to the (windowed) admittance: each
/// section's state and the time they have reached.
struct FirstOrder {
    state: [Complex64; 5],
    at: f64,
}

impl FirstOrder {
    /// The filter settled on what the meter sees at `at`
    /// ([`LcrMeter::response_reach_s`] before the first reading).
    fn settled(m: &mut Sensor, profile: &Profile, lcr: &LcrMeter, at: f64, freq_hz: f64) -> Self {
        Self {
            state: [Self::input(m, profile, lcr, at, freq_hz); 5],
            at,
        }
    }

    /// What the filter integrates at `at`: the admittance, averaged over
    /// the meter's window when it has one.
    fn input(m: &mut Sensor, profile: &Profile, lcr: &LcrMeter, at: f64, freq_hz: f64) -> Complex64 {
        if lcr.window_s <= 0.0 {
            m.advance(profile, at);
            return m.impedance(freq_hz).inv();
        }
        mean_admittance(m, profile, at - lcr.window_s, lcr.window_s, freq_hz)
    }

    /// Advance to `target` in steps of ≤ 0.5 ms, each sampled at its
    /// midpoint and decaying the first section's state by e^(−d/τ), each
    /// further section fed the mean of the one before it over the step;
    /// the impedance then.
    fn advance(
        &mut self,
        m: &mut Sensor,
        profile: &Profile,
        lcr: &LcrMeter,
        target: f64,
        freq_hz: f64,
    ) -> Complex64 {
        let order = lcr.order();
        let (whole, part) = (order.floor() as usize, order - order.floor());
        let sections = whole + usize::from(part > 0.0);
        let steps = ((target - self.at) / 0.5e-3).ceil().max(0.0) as usize;
        if steps > 0 {
            let d = (target - self.at) / steps as f64;
            let e = (-d / lcr.response_s).exp();
            for _ in 0..steps {
                let mut input = Self::input(m, profile, lcr, self.at + 0.5 * d, freq_hz);
                for k in 0..sections {
                    let old = self.state[k];
                    self.state[k] = old * e + input * (1.0 - e);
                    input = 0.5 * (old + self.state[k]);
                }
                self.at += d;
            }
        }
        let y = if part > 0.0 {
            self.state[whole - 1] * (1.0 - part) + self.state[whole] * part
        } else {
            self.state[whole - 1]
        };
        y.inv()
    }
}

/// An LCR meter reading the sensor every `interval_s`: instant, averaged
/// over a window, or through a first-order response, stamped `offset_s`
/// late, with its noise; each reading corrected by the line tracker.
fn run_lcr(
    sensor: &mut Sensor,
    profile: &Profile,
    lcr: &LcrMeter,
    setup: &Setup,
    (t_start, t_end): (f64, f64),
    mut tick: impl FnMut(f64),
) -> Vec<Reading> {
    let freq_hz = setup.freq_hz;
    let mut rng = Rng::new(setup.seed);
    let tracker = Tracker::with_leads(setup.model, Tracker::X_MAX, setup.lead_ratio)
        .expect("valid model and lead ratio");
    let mut state = TrackState::new(setup.prior_farad as f32);
    // The meter's view of the sensor runs on its own clock.
    let mut seen =
        (lcr.window_s > 0.0 || lcr.offset_s != 0.0 || lcr.response_s > 0.0).then(|| sensor.clone());
    let mut filter: Option<FirstOrder> = None;
    let mut average = ReadingAverage::new(lcr);
    let mut out = Vec::new();
    let mut t = t_start;
    while t <= t_end + 1e-12 {
        sensor.advance(profile, t);
        let truth = sensor.truth();
        let target = t + lcr.offset_s;
        let z = match seen.as_mut() {
            None => sensor.impedance(freq_hz),
            Some(m) if lcr.response_s > 0.0 => filter
                .get_or_insert_with(|| {
                    FirstOrder::settled(m, profile, lcr, target - lcr.response_reach_s(), freq_hz)
                })
                .advance(m, profile, lcr, target, freq_hz),
            Some(m) => mean_admittance(m, profile, target - lcr.window_s, lcr.window_s, freq_hz).inv(),
        };
        // Its own readings averaged (running or weighted mean), then the
        // noise of what it reports.
        let (cs, rs) = average.push((series_cs(z, freq_hz), z.re));
        let cs = cs * (1.0 + lcr.rel * rng.gaussian()) + lcr.abs_farad * rng.gaussian();
        let rs = rs * (1.0 + lcr.rel * rng.gaussian());
        let zm = SeriesRc {
            cs_farad: cs as f32,
            rs_ohm: rs as f32,
        }
        .impedance(freq_hz as f32);
        let (c_corr, r_corr) = match tracker.update(&mut state, zm, freq_hz as f32) {
            Ok(t) => (t.line.c_farad as f64, t.line.r_ohm as f64),
            Err(_) => (f64::NAN, f64::NAN),
        };
        out.push(reading(&truth, freq_hz, cs, rs, c_corr, r_corr, false));
        tick(t);
        t += lcr.interval_s;
    }
    out
}

fn reading(
    tr: &skin_sim::sensor::Truth,
    f: f64,
    cs: f64,
    rs: f64,
    c_corr: f64,
    r_corr: f64,
    clipped: bool,
) -> Reading {
    Reading {
        t: tr.t,
        stretch_mm: tr.stretch_mm,
        c_true: tr.c_farad,
        r_line: tr.r_line_ohm,
        r_top: tr.r_top_ohm,
        r_bottom: tr.r_bottom_ohm,
        freq_hz: f,
        cs,
        rs,
        c_corr,
        r_corr,
        clipped,
    }
}

/// How far a capacitance reading dips below where it should only rise or
/// rest, over the readings of one trapezoid period starting at rest: the
/// larger of (reading at the start of the stretch − its minimum during the
/// stretch) and (final resting value − minimum after the release starts),
/// in F; 0 when the reading never dips.
pub fn undershoot(rs: &[Reading], value: impl Fn(&Reading) -> f64) -> f64 {
    let Some(first) = rs.first() else { return 0.0 };
    // Stretch phase: from the first moving reading until max stretch.
    let smax = rs.iter().map(|r| r.stretch_mm).fold(f64::MIN, f64::max);
    let end_stretch = rs.iter().position(|r| r.stretch_mm >= smax - 1e-9).unwrap_or(0);
    let start = value(first);
    let dip1 = rs[..=end_stretch].iter().map(&value).fold(start, f64::min);
    // Release: from the first reading below max stretch after the hold.
    let rel_start = rs[end_stretch..]
        .iter()
        .position(|r| r.stretch_mm < smax - 1e-9)
        .map(|k| k + end_stretch);
    let dip2 = rel_start.map_or(0.0, |k| {
        let last = value(&rs[rs.len() - 1]);
        last - rs[k..].iter().map(&value).fold(last, f64::min)
    });
    (start - dip1).max(dip2).max(0.0)
}
