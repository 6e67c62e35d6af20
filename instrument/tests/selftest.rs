//! The power-up self-test on the simulated array front end: a board as
//! designed passes, its reported errors those of an f64 reference; parts
//! at the edges of their tolerances pass; a wrong part, a stage open loop,
//! a weak excitation or a missing network fail, and refuse the records
//! they should; noise is reported and refuses nothing.

use instrument::array::{
    input_of, Frame, Layout, BLOCK_INSTANTS, REFERENCE_FARAD, REFERENCE_INPUT, REFERENCE_OHM,
};
use instrument::faults::Flags;
use instrument::reader::ArrayReader;
use instrument::selftest::{Limits, Outcome, SelfTest, PATHS};
use instrument::sensor::{self as skin_sensor, Sensors};
use instrument::tones::ToneSettings;
use link::Verdict;
use num_complex::Complex64;
use skin_sim::array::ArrayFrontEnd;
use skin_sim::frontend::Disturbance;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};

/// The k the firmware divides by: the design's, whatever the board's.
fn firmware_k() -> dsp_core::demod::FrontEnd {
    ArrayFrontEnd::REFERENCE.dsp_front_end()
}

/// The self-test on `fe` with the paper's sensor, held, on every input.
fn run(fe: &ArrayFrontEnd, seed: u64) -> Outcome {
    let layout = fe.layout;
    let each = Sensors::all(skin_sensor::Sensor::uncalibrated(200e-12));
    let reader = ArrayReader::new(layout, &each).unwrap();
    let hz = layout.tones_hz().map(|f| f as f64);
    let z = [Sensor::settled(SensorParams::PAPER).impedances(&hz); 16];
    let mut rng = Rng::new(seed);
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let mut test = SelfTest::new(layout);
    while !test.done() {
        let rails = fe.frame(&z, &[Disturbance::NONE; 16], &mut rng, &mut frame);
        let rows = |a: usize| layout.rows(&frame[a]);
        let block = reader.demodulate(rows);
        test.add(&block, &reader.reference(rows), |i| rails[i]);
    }
    test.outcome(&firmware_k(), reader.reference_rotation(), &Limits::DEFAULT)
}

/// The reference's impedance as assembled over the nominal, in f64: the
/// error a perfect measurement would report.
fn expected_error(layout: &Layout, r: f64, c: f64) -> Vec<(f64, f64)> {
    layout
        .tones_hz()
        .iter()
        .map(|&f| {
            let w = std::f64::consts::TAU * f as f64;
            let z = |r: f64, c: f64| Complex64::new(r, -1.0 / (w * c));
            let q = z(r, c) / z(REFERENCE_OHM, REFERENCE_FARAD);
            (q.norm() - 1.0, q.arg())
        })
        .collect()
}

/// Each tone's reported gain and phase against the f64 reference: RMS
/// and largest difference of each.
fn against(out: &Outcome, want: &[(f64, f64)]) -> [(f64, f64); 2] {
    let stats = |d: Vec<f64>| {
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        (rms, d.iter().fold(0f64, |m, x| m.max(x.abs())))
    };
    let dg = (0..want.len()).map(|k| out.gain[k] as f64 - want[k].0).collect();
    let dp = (0..want.len())
        .map(|k| out.phase_rad[k] as f64 - want[k].1)
        .collect();
    [stats(dg), stats(dp)]
}

/// As designed, in both layouts: every path passes, nothing is noisy or
/// refused, and the reference reads its nominal impedance within 2·10⁻⁴
/// (RMS 10⁻⁴) in |Z| and 2·10⁻⁴ rad in phase: the noise of 100 ms.
#[test]
fn a_board_as_designed_passes_and_reads_its_reference() {
    for layout in Layout::ALL {
        let out = run(&ArrayFrontEnd::reference(layout), 1);
        assert!(out.passed(), "{layout:?}: {out:?}");
        assert_eq!((out.noisy, out.refused()), (0, 0), "{out:?}");
        let [(g_rms, g_max), (p_rms, p_max)] =
            against(&out, &expected_error(&layout, REFERENCE_OHM, REFERENCE_FARAD));
        println!(
            "{} records/s: |Z| rms {g_rms:.1e} max {g_max:.1e}, phase rms {p_rms:.1e} max {p_max:.1e} rad",
            layout.records_per_s()
        );
        assert!(g_rms <= 1e-4 && g_max <= 2e-4, "{g_rms} {g_max}");
        assert!(p_rms <= 1e-4 && p_max <= 2e-4, "{p_rms} {p_max}");
        for p in 0..PATHS {
            assert!(
                out.offset_counts[p].abs() < 1.0,
                "path {p}: {}",
                out.offset_counts[p]
            );
            assert!((0.8..1.2).contains(&out.noise[p]), "path {p}: {}", out.noise[p]);
        }
        assert!(
            out.excitation.iter().all(|e| e.abs() < 1e-3),
            "{:?}",
            out.excitation
        );
        let frame = out.frame();
        assert_eq!((frame.verdict, frame.failed), (Verdict::Passed, 0));
    }
}

/// The reference's parts at every corner of their tolerances pass, and
/// the test reports the error they make (the f64 reference's, within
/// 2·10⁻⁴).
#[test]
fn the_parts_at_their_tolerances_pass_and_are_measured() {
    let (dr, dc) = (
        instrument::array::REFERENCE_OHM_TOLERANCE,
        instrument::array::REFERENCE_FARAD_TOLERANCE,
    );
    for (sr, sc) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let (r, c) = (REFERENCE_OHM * (1.0 + sr * dr), REFERENCE_FARAD * (1.0 + sc * dc));
        let fe = ArrayFrontEnd {
            reference: Some((r, c)),
            ..ArrayFrontEnd::REFERENCE
        };
        let out = run(&fe, 2);
        assert!(out.passed(), "R {r} C {c}: {out:?}");
        let [(_, g_max), (_, p_max)] = against(&out, &expected_error(&fe.layout, r, c));
        assert!(g_max <= 2e-4 && p_max <= 2e-4, "R {r} C {c}: {g_max} {p_max}");
    }
}

/// A reference of the wrong part (the next E12 capacitor, 270 pF; a
/// 560 kΩ resistor) or none at all fails the chain: every sensor's
/// records are refused.
#[test]
fn a_wrong_or_missing_reference_fails_and_refuses_every_sensor() {
    for reference in [
        Some((REFERENCE_OHM, 270e-12)),
        Some((560e3, REFERENCE_FARAD)),
        None,
    ] {
        let fe = ArrayFrontEnd {
            reference,
            ..ArrayFrontEnd::REFERENCE
        };
        let out = run(&fe, 3);
        assert_eq!(out.failed, 1 << REFERENCE_INPUT, "{reference:?}: {out:?}");
        assert_eq!(out.refused(), u16::MAX);
        assert_eq!(out.frame().verdict, Verdict::Failed);
    }
}

/// A stage open loop (its output past a rail) or pulled 100 mV off the
/// bias fails its own path: that sensor's records alone are refused.
#[test]
fn a_stage_off_its_bias_fails_its_own_sensor_only() {
    for (sensor, offset) in [(5usize, 40_000.0f32), (12, -2_000.0)] {
        let mut fe = ArrayFrontEnd::REFERENCE;
        fe.offset_counts[input_of(sensor)] = offset;
        let out = run(&fe, 4);
        assert_eq!(out.failed, 1 << input_of(sensor), "{out:?}");
        assert_eq!(out.refused(), 1 << sensor);
    }
}

/// An excitation 10 % weak fails the excitation's path (and the
/// reference's, whose V/I the firmware's k now misreads): all refused.
#[test]
fn a_weak_excitation_fails_every_sensor() {
    let fe = ArrayFrontEnd {
        v_gain: 0.9,
        ..ArrayFrontEnd::REFERENCE
    };
    let out = run(&fe, 5);
    assert!(out.failed & 1 != 0, "{out:?}");
    assert_eq!(out.refused(), u16::MAX);
    let frame = out.frame();
    assert!((frame.excitation_ppm + 100_000).abs() < 1_000, "{frame:?}");
}

/// Three times the converter's noise on every input: every path
/// reported noisy (at 3.0×), none refused.
#[test]
fn noise_is_reported_and_refuses_nothing() {
    let fe = ArrayFrontEnd {
        noise_counts: 3.0 * ArrayFrontEnd::REFERENCE.noise_counts,
        ..ArrayFrontEnd::REFERENCE
    };
    let out = run(&fe, 6);
    assert!(out.passed(), "{out:?}");
    assert_eq!(out.noisy, (1 << PATHS) - 1);
    assert_eq!(out.refused(), 0);
    let permille = out.frame().noise_permille;
    assert!((2800..3300).contains(&permille), "{permille}");
}

/// A refused sensor's records carry `SELF_TEST` and are not valid; the
/// others' are untouched (sensors without tab leads, as declared).
#[test]
fn the_reader_flags_the_refused_sensors_records() {
    let fe = ArrayFrontEnd::REFERENCE;
    let each = Sensors::all(skin_sensor::Sensor::uncalibrated(200e-12));
    let settings = ToneSettings::new(fe.layout, fe.dsp_front_end(), &each);
    let mut reader = ArrayReader::new(fe.layout, &each).unwrap();
    reader.refuse(1 << 3 | 1 << 9);
    let hz = fe.layout.tones_hz().map(|f| f as f64);
    let z = [Sensor::settled(SensorParams::REFERENCE).impedances(&hz); 16];
    let mut frame: Box<Frame> = Box::new([[[0; 4]; BLOCK_INSTANTS]; 5]);
    let mut rng = Rng::new(7);
    let mut got = vec![];
    for k in 0..20u64 {
        fe.frame(&z, &[Disturbance::NONE; 16], &mut rng, &mut frame);
        reader.read(&settings, k * 4000, |a| &frame[a][..], |_| false, |r| got.push(r));
    }
    for r in &got {
        let refused = r.sensor == 3 || r.sensor == 9;
        assert_eq!(r.flags.has(Flags::SELF_TEST), refused, "{r:?}");
        if refused {
            assert!(!r.flags.valid());
        }
    }
    assert!(got.iter().filter(|r| r.sensor == 0).any(|r| r.flags.valid()));
}
