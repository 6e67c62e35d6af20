//! The simulated sensor and front end against independent references.

use dsp_core::demod::Demodulator;
use dsp_core::Oscillator;
use num_complex::Complex64;
use skin_sim::frontend::FrontEndParams;
use skin_sim::profile::Profile;
use skin_sim::rng::Rng;
use skin_sim::sensor::{Sensor, SensorParams};
use skin_spec::effects::{Effect, EffectSet};

/// Continuous uniform line, f64: Z = √(R/(jωC))·coth √(jωRC).
fn line(r: f64, c: f64, f: f64) -> Complex64 {
    let w = std::f64::consts::TAU * f;
    let g = Complex64::new(0.0, w * r * c).sqrt();
    r / (g * g.tanh())
}

fn rel(a: Complex64, b: Complex64) -> f64 {
    (a - b).norm() / b.norm()
}

#[test]
fn uniform_grid_is_the_continuous_line() {
    // Its film lossless (the lossy line is `effects_have_their_signatures`').
    let mut p = SensorParams::REFERENCE;
    p.effects = EffectSet::NONE;
    let mut s = Sensor::settled(p);
    for (t, stretch) in [(0.0, 0.0), (4.0, 30.0)] {
        s.advance(&Profile::Constant(stretch), t);
        let tr = s.truth();
        for f in [100.0, 500.0, 2e3, 6e3, 20e3, 50e3] {
            let e = rel(s.impedance(f), line(tr.r_line_ohm, tr.c_farad, f));
            // Midpoint discretization error grows like x/n² (x = ωRC).
            let x = std::f64::consts::TAU * f * tr.r_line_ohm * tr.c_farad;
            assert!(e < 5e-6 * x.max(1.0), "f={f}, x={x}: {e}");
        }
    }
}

#[test]
fn truth_follows_stretch() {
    let p = SensorParams::REFERENCE;
    let mut s = Sensor::settled(p);
    s.advance(&Profile::Constant(30.0), 1.0);
    let tr = s.truth();
    assert!((tr.c_farad / p.capacitance(30.0) - 1.0).abs() < 1e-12);
    assert!((tr.r_line_ohm / (p.top.r_static(30.0) + p.bottom.r_static(30.0)) - 1.0).abs() < 1e-9);
    assert_eq!(tr.r_top_ohm + tr.r_bottom_ohm, tr.r_line_ohm);
}

/// Every effect of the catalogue against its physical signature, one
/// block per effect: long because the catalogue is, and in one place so
/// that an effect without a signature stands out.
#[test]
fn effects_have_their_signatures() {
    let base = SensorParams {
        effects: EffectSet::NONE,
        ..SensorParams::REFERENCE
    };
    let with = |e: EffectSet| {
        let mut p = base;
        p.effects = e;
        let mut s = Sensor::settled(p);
        s.advance(&Profile::Constant(10.0), 1.0);
        s
    };
    let plain = with(EffectSet::NONE);
    let (z0, t0) = (plain.impedance(2e3), plain.truth());
    // Contacts: 2·Rc in series; recorded electrodes include two each.
    let s = with(EffectSet::NONE.with(Effect::ContactResistance, 5e3));
    assert!(rel(s.impedance(2e3), z0 + 10e3) < 1e-12);
    assert_eq!(s.truth().r_top_ohm, t0.r_top_ohm + 10e3);
    assert_eq!(s.truth().r_line_ohm, t0.r_line_ohm);
    // Tab leads: a fraction β of each electrode's end-to-end resistance,
    // outside the line; the read end's two leads in series with it.
    let beta = 0.6;
    let s = with(EffectSet::NONE.with(Effect::LeadResistance, beta));
    assert_eq!(s.truth().r_top_ohm, t0.r_top_ohm);
    assert!((s.truth().r_line_ohm / t0.r_line_ohm - (1.0 - beta)).abs() < 1e-12);
    let scaled = with(EffectSet::NONE);
    let mut p = scaled.params;
    p.top.r_rest_ohm *= 1.0 - beta;
    p.bottom.r_rest_ohm *= 1.0 - beta;
    let body = {
        let mut x = Sensor::settled(p);
        x.advance(&Profile::Constant(10.0), 1.0);
        x
    };
    let lead = 0.5 * beta * (t0.r_top_ohm + t0.r_bottom_ohm);
    assert!(rel(s.impedance(6e3), body.impedance(6e3) + lead) < 1e-9);
    // Electrode dispersion: the film's impedance falls above its corner
    // (1.6 kHz here), so the series resistance a meter sees drops; far
    // below the corner nothing changes.
    let s = with(EffectSet::NONE.with(Effect::ElectrodeDispersion, 100e-6));
    assert_eq!(s.truth().r_top_ohm, t0.r_top_ohm);
    assert!(rel(s.impedance(10.0), plain.impedance(10.0)) < 1e-3);
    assert!(s.impedance(6e3).re < 0.5 * plain.impedance(6e3).re);
    // Parasitic capacitance in parallel at the meter.
    let s = with(EffectSet::NONE.with(Effect::ParasiticCapacitance, 15e-12));
    let w = std::f64::consts::TAU * 2e3;
    assert!(
        rel(
            s.impedance(2e3),
            (z0.inv() + Complex64::new(0.0, w * 15e-12)).inv()
        ) < 1e-12
    );
    // Gradient: same total R and C, different impedance.
    let s = with(EffectSet::NONE.with(Effect::ResistanceGradient, 0.5));
    assert!((s.truth().r_line_ohm / t0.r_line_ohm - 1.0).abs() < 1e-12);
    assert!(rel(s.impedance(6e3), plain.impedance(6e3)) > 1e-3);
    // The symmetric resistance mode: the same total (to the midpoint
    // rule's v/(2·n²)), a different impedance, the same from either end.
    let s = with(EffectSet::NONE.with(Effect::ResistanceBulge, 0.5));
    assert!((s.truth().r_line_ohm / t0.r_line_ohm - 1.0).abs() < 1e-5);
    assert!(rel(s.impedance(6e3), plain.impedance(6e3)) > 1e-3);
    let fx = EffectSet::NONE.with(Effect::ResistanceBulge, 0.5);
    assert!((fx.resistance_profile(0.2) - fx.resistance_profile(0.8)).abs() < 1e-12);
    assert!(
        (fx.resistance_profile(0.5) - 1.25).abs() < 1e-12 && (fx.resistance_profile(0.0) - 0.5).abs() < 1e-12
    );
    // Nonuniform stretch: the same mean capacitance (C linear in stretch).
    let s = with(EffectSet::NONE.with(Effect::NonuniformStretch, 0.5));
    assert!((s.truth().c_farad / t0.c_farad - 1.0).abs() < 1e-12);
    // The symmetric mode too; it changes the impedance, and unlike the
    // linear mode it is the same seen from either end.
    // (the 240 segments' midpoints average the quadratic mode to v/(2·240²),
    // not 0: 5·10⁻⁶ of C).
    let s = with(EffectSet::NONE.with(Effect::StretchBulge, 0.6));
    assert!((s.truth().c_farad / t0.c_farad - 1.0).abs() < 1e-5);
    assert!(rel(s.impedance(6e3), plain.impedance(6e3)) > 1e-3);
    let fx = EffectSet::NONE.with(Effect::StretchBulge, 0.6);
    for xi in [0.1, 0.3] {
        assert!((fx.stretch_profile(xi) - fx.stretch_profile(1.0 - xi)).abs() < 1e-12);
    }
    assert!((fx.stretch_profile(0.5) - 1.3).abs() < 1e-12 && (fx.stretch_profile(0.0) - 0.4).abs() < 1e-12);
    // Leakage: lowers the impedance at low frequency most.
    // 5 nS on 200 pF.
    let s = with(EffectSet::NONE.with(Effect::DielectricLeakage, 25.0));
    let lo = rel(s.impedance(100.0), plain.impedance(100.0));
    let hi = rel(s.impedance(20e3), plain.impedance(20e3));
    assert!(lo > 0.005 && lo > 10.0 * hi, "{lo} {hi}");
    // Dispersion: the series capacitance far below the line's corner
    // frequency scales by 1 − κ·log10(f / 1 kHz); the truth does not move.
    let s = with(EffectSet::NONE.with(Effect::DielectricDispersion, 0.02));
    assert_eq!(s.truth(), plain.truth());
    let cs = |s: &Sensor, f: f64| -1.0 / (std::f64::consts::TAU * f * s.impedance(f).im);
    for (f, k) in [(100.0, 1.02), (1e3, 1.0)] {
        let ratio = cs(&s, f) / cs(&plain, f);
        assert!((ratio / k - 1.0).abs() < 2e-4, "{f} Hz: {ratio} vs {k}");
    }
    // Loss: the continuous line of complex capacitance C·(1 − j·tan δ),
    // √(R/Y)·coth √(RY) with Y = jωC(1 − j·tan δ), to the grid's
    // discretization error; the truth does not move.
    for tan_d in [1e-3, 1e-2, 0.1] {
        let s = with(EffectSet::NONE.with(Effect::DielectricLoss, tan_d));
        assert_eq!(s.truth(), plain.truth());
        for f in [100.0, 2e3, 6e3, 20e3] {
            let w = std::f64::consts::TAU * f;
            let y = Complex64::new(0.0, w * t0.c_farad) * Complex64::new(1.0, -tan_d);
            let g = (t0.r_line_ohm * y).sqrt();
            let expected = (t0.r_line_ohm / y).sqrt() / g.tanh();
            let x = w * t0.r_line_ohm * t0.c_farad;
            let e = rel(s.impedance(f), expected);
            assert!(e < 5e-6 * x.max(1.0), "tan δ {tan_d} at {f} Hz: {e}");
        }
    }
}

#[test]
fn front_end_block_demodulates_to_the_impedance() {
    let fe = FrontEndParams::REFERENCE;
    let mut s = Sensor::settled(SensorParams::REFERENCE);
    s.advance(&Profile::Constant(15.0), 1.0);
    let mut rng = Rng::new(1);
    for f in [500.0f32, 2e3, 6e3] {
        let osc = Oscillator::coherent(f, fe.sample_rate_hz as f32, 11).unwrap();
        let z = s.impedance(osc.freq_hz(fe.sample_rate_hz as f32) as f64);
        let mut buf = [[0i16; 2]; 2048];
        assert!(!fe.block(&osc, z, &mut rng, &mut buf));
        let dm = Demodulator::<2048>::new(&osc);
        let zm = dm.block(&buf).impedance(&fe.dsp_front_end()).unwrap();
        let e = rel(Complex64::new(zm.re as f64, zm.im as f64), z);
        assert!(e < 2e-3, "f={f}: {e}");
    }
    // Too much gain: the current channel clips, and says so.
    let hot = FrontEndParams { tia_ohm: 1e6, ..fe };
    let osc = Oscillator::coherent(6e3, 200e3, 11).unwrap();
    let mut buf = [[0i16; 2]; 2048];
    assert!(hot.block(&osc, s.impedance(6e3), &mut rng, &mut buf));
}
