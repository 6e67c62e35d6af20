//! How many of a clean skin's records the array keeps valid across the
//! sensors it is documented for, on the host with the firmware's own code
//! (`instrument::reader`): sixteen sensors, their electrodes a multiple
//! of the paper's, held or on the paper's trapezoid (30 mm, 10 s period)
//! at a stretch rate, each later in its cycle than the last by 0.4 s, in
//! 4 ms and 1 ms blocks. The other half of the instrument's promise
//! beside its error: the share valid, why the others are not, and that
//! none of the valid ones is 1 % off.

use crate::disturbances::Outcome;
use crate::interpolate::{Anchor, Interpolator};
use instrument::array::{Frame, Layout, BLOCK_INSTANTS, SENSORS, TONES};
use instrument::availability::Availability;
use instrument::reader::ArrayReader;
use instrument::tones::ToneSettings;
use skin_sim::array::ArrayFrontEnd;
use skin_sim::frontend::Disturbance;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};

/// One case: the blocks' layout, the electrodes' resistance as a
/// multiple of the paper's, and the stretch rate, mm/s (0: held at
/// 15 mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    /// The blocks (4 ms: 250 records/s; 1 ms: 1000).
    pub layout: Layout,
    /// Electrode resistance, times the paper's.
    pub r_scale: f64,
    /// Stretch rate, mm/s; 0 holds the sensors at half the stroke.
    pub rate_mm_s: f64,
    /// Seconds into the cycle the first sensor starts (the others 0.4 s
    /// later each).
    pub phase_s: f64,
    /// The front end's noise.
    pub seed: u64,
}

/// What the array made of a case: over every sensor, and its least
/// available sensor's share.
#[derive(Clone, Debug, PartialEq)]
pub struct Kept {
    /// The case.
    pub case: Case,
    /// Every sensor's records together.
    pub all: Outcome,
    /// The least share of records valid among the sensors.
    pub least: f64,
    /// The records not valid given a value from their valid neighbours
    /// ([`crate::interpolate`]), and those values' relative error of C
    /// against the truth: rms and worst (NaN and 0 with none).
    pub interpolated: (usize, f64, f64),
}

/// Seconds each case runs (after [`SETTLE_S`]): with the sensors 0.4 s
/// apart, 8.4 s of the 10 s cycle are seen, both ramps included.
const SECONDS: f64 = 2.0;
/// Seconds run first and not counted: the tone policy finds its pair,
/// and the model check's history fills (`instrument::joint::Quiet`:
/// 256 blocks, 1 s of 4 ms blocks), as on a skin that has run a while.
pub(crate) const SETTLE_S: f64 = 1.2;

/// Blocks a case of `layout` runs, [`SETTLE_S`] included.
pub(crate) fn blocks_of(layout: &Layout) -> u64 {
    ((SETTLE_S + SECONDS) / (layout.block_us() as f64 * 1e-6)) as u64
}

/// A case's sixteen sensors, each 0.4 s later in the cycle than the last.
pub(crate) struct Skin {
    /// The sensors' parameters (the paper's, electrodes scaled).
    pub(crate) params: SensorParams,
    sensors: Vec<Sensor>,
    profile: Profile<'static>,
    phase_s: f64,
}

impl Skin {
    /// The sensors of `case`, settled at their start.
    pub(crate) fn new(case: &Case) -> Self {
        let params = SensorParams::PAPER.with_electrodes_scaled(case.r_scale);
        let profile = if case.rate_mm_s > 0.0 {
            Profile::paper(case.rate_mm_s)
        } else {
            Profile::Constant(15.0)
        };
        let mut skin = Self {
            params,
            sensors: vec![Sensor::settled(params); SENSORS],
            profile,
            phase_s: case.phase_s,
        };
        skin.at(0.0);
        skin
    }

    /// Every sensor `t_s` after the case's start.
    pub(crate) fn at(&mut self, t_s: f64) -> &[Sensor] {
        for (s, sensor) in self.sensors.iter_mut().enumerate() {
            sensor.advance(&self.profile, self.phase_s + 0.4 * s as f64 + t_s);
        }
        &self.sensors
    }
}

/// The array on `case`.
pub fn run(case: Case) -> Kept {
    let layout = case.layout;
    let fe = ArrayFrontEnd::reference(layout);
    let each = crate::disturbances::paper_sensors();
    let settings = ToneSettings::new(layout, fe.dsp_front_end(), &each);
    let mut reader = ArrayReader::new(layout, &each).expect("the array's comb lays out");
    let mut skin = Skin::new(&case);
    let mut rng = Rng::new(case.seed);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let block_s = layout.block_us() as f64 * 1e-6;
    let blocks = blocks_of(&layout);
    let hz = layout.tones_hz().map(|f| f as f64);
    let mut all = Outcome::new();
    let mut each_sensor = [Availability::new(); SENSORS];
    // The interpolated values: each keyed by its record's true C.
    let mut gaps = Interpolator::default();
    let mut filled: Vec<f64> = vec![];
    for b in 0..blocks {
        let t = b as f64 * block_s;
        let t_us = (t * 1e6) as u64 + (block_s * 5e5) as u64;
        let mut z = [[num_complex::Complex64::new(0.0, 0.0); TONES]; SENSORS];
        let mut truth = [0.0; SENSORS];
        for (s, sensor) in skin.at(t + 0.5 * block_s).iter().enumerate() {
            z[s] = sensor.impedances(&hz);
            truth[s] = sensor.truth().c_farad;
        }
        let d = Disturbance {
            t0_s: t,
            ..Disturbance::NONE
        };
        let clipped = fe.frame(&z, &[d; SENSORS], &mut rng, &mut frame);
        reader.read(
            &settings,
            t_us,
            |a| layout.rows(&frame[a]),
            |input| clipped[input],
            |rec| {
                if t >= SETTLE_S {
                    let s = usize::from(rec.sensor);
                    all.add(rec.flags, rec.c_farad, truth[s]);
                    each_sensor[s].count(rec.flags);
                    let line = Anchor::of(rec.t_us, rec.flags, rec.c_farad, rec.r_ohm, rec.stretch_mm);
                    gaps.take(rec.sensor, rec.t_us, line, truth[s], |f| {
                        filled.push(f.c_farad / f.key - 1.0);
                    });
                }
            },
        );
    }
    let least = each_sensor
        .iter()
        .filter_map(Availability::share)
        .fold(1.0, f64::min);
    let (rms, worst, _) = crate::numerics::rms_max(filled.iter().copied());
    Kept {
        case,
        all,
        least,
        interpolated: (filled.len(), rms, worst),
    }
}

/// The documented range: electrodes 0.5, 1 and 2 times the paper's,
/// held, at the paper's 20 mm/s and at 50 mm/s, in both layouts.
pub fn cases() -> Vec<Case> {
    let mut out = vec![];
    for layout in [Layout::BLOCK_4MS, Layout::BLOCK_1MS] {
        for r_scale in [0.5, 1.0, 2.0] {
            for rate_mm_s in [0.0, 20.0, 50.0] {
                out.push(Case {
                    layout,
                    r_scale,
                    rate_mm_s,
                    phase_s: 0.0,
                    seed: 0xa5a1 ^ r_scale.to_bits() ^ rate_mm_s.to_bits().rotate_left(17),
                });
            }
        }
    }
    out
}

/// The cases run, as a Markdown table.
pub fn markdown(rows: &[Kept]) -> String {
    let mut md = String::from(
        "| records/s | electrodes | stretching | valid | least sensor | not valid: faults | valid > 1 % off | worst valid | not valid, interpolated | their error: rms, worst |\n\
         |---:|---:|---|---:|---:|---|---:|---:|---:|---:|\n",
    );
    for k in rows {
        let c = k.case;
        let a = &k.all.availability;
        md += &format!(
            "| {} | {}× the paper's | {} | {:.1} % of {} | {:.1} % | {} | {} | {:.2} % | {} | {} |\n",
            1_000_000 / c.layout.block_us(),
            c.r_scale,
            stretching(c.rate_mm_s),
            100.0 * a.share().unwrap_or(0.0),
            a.records,
            100.0 * k.least,
            a.why(),
            k.all.valid_off,
            100.0 * k.all.worst_valid,
            interpolated_cell(a.invalid(), k.interpolated.0),
            error_cell(k.interpolated),
        );
    }
    md
}

/// A case's stretching, as the tables say it.
pub(crate) fn stretching(rate_mm_s: f64) -> String {
    if rate_mm_s > 0.0 {
        format!("trapezoid, {rate_mm_s} mm/s")
    } else {
        "held at 15 mm".to_string()
    }
}

/// How many of the `invalid` records were given a value.
fn interpolated_cell(invalid: u64, given: usize) -> String {
    if invalid == 0 {
        "–".to_string()
    } else {
        format!("{given} of {invalid}")
    }
}

/// The interpolated values' rms and worst error.
fn error_cell((given, rms, worst): (usize, f64, f64)) -> String {
    if given == 0 {
        "–".to_string()
    } else {
        format!("{:.2} %, {:.2} %", 100.0 * rms, 100.0 * worst)
    }
}
