//! What the boards' checks share: the documented range of sensors, the
//! firmware's inversion, a tone's amplitude, a result's noise.

#![allow(dead_code)]

use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use front_end::circuit::{Circuit, Sensor};
use front_end::spice;
use num_complex::Complex64;

/// The sensors of the documented range: the paper's; electrodes half
/// the paper's with the largest film (290 pF); twice the paper's; each
/// of the last two behind 20 pF of cable shield at the stage's input.
pub fn range() -> [(&'static str, Sensor); 3] {
    let shielded = |r_ohm: f64, c_farad: f64| Sensor {
        r_ohm,
        c_farad,
        cable_farad: 0.0,
        shield_farad: 20e-12,
    };
    [
        ("paper's", Sensor::PAPER),
        ("0.35 MΩ, 290 pF", shielded(350e3, 290e-12)),
        ("1.4 MΩ, 210 pF", shielded(1.4e6, 210e-12)),
    ]
}

/// C from one tone's impedance by the firmware's inversion, F.
pub fn c_of(z: Complex64, f: f64) -> Option<f64> {
    let inv = Inverter::new(LineModel::Continuous);
    let z = dsp_core::Complex32::new(z.re as f32, z.im as f32);
    inv.invert(z, f as f32).ok().map(|l| l.c_farad as f64)
}

/// Tone `f`'s amplitude in `x` sampled every `dt` over whole periods.
pub fn amplitude(x: &[f64], dt: f64, f: f64) -> f64 {
    let (mut c, mut s) = (0.0, 0.0);
    for (n, v) in x.iter().enumerate() {
        let p = std::f64::consts::TAU * f * n as f64 * dt;
        (c, s) = (c + v * p.cos(), s + v * p.sin());
    }
    2.0 * c.hypot(s) / x.len() as f64
}

/// The noise of one ADC result at `node`, in `lsb` volts: the spectrum
/// there (V/√Hz, ngspice) through the mean of `m` conversions `ts` s
/// apart (m = 1: one conversion, whose sample folds every frequency in),
/// times `m` (a result sums its conversions), on a 500 Hz grid to 20 MHz.
pub fn result_noise(board: &Circuit, node: &str, m: usize, ts: f64, lsb: f64) -> f64 {
    let spectrum = spice::noise(board, node, 10.0, 20e6, 100).expect("ngspice's noise analysis");
    // S(f) interpolated log-log.
    let density = |f: f64| {
        let i = spectrum
            .partition_point(|(g, _)| *g < f)
            .clamp(1, spectrum.len() - 1);
        let ((f0, s0), (f1, s1)) = (spectrum[i - 1], spectrum[i]);
        let u = (f.ln() - f0.ln()) / (f1.ln() - f0.ln());
        (s0.ln() + u * (s1.ln() - s0.ln())).exp()
    };
    let (df, mf) = (500.0, m as f64);
    let variance: f64 = (1..(20e6 / df) as usize)
        .map(|k| {
            let f = k as f64 * df;
            let x = std::f64::consts::PI * f * ts;
            let h = if m == 1 {
                1.0
            } else {
                (mf * x).sin() / (mf * x.sin())
            };
            density(f).powi(2) * h * h * df
        })
        .sum();
    mf * variance.sqrt() / lsb
}

/// `out`'s response to a 1 µA current step into `node` at 2 µs, every
/// 5 ns to `stop_s`, the DAC held at the bias: (s, V less its start) rows.
pub fn step(board: &Circuit, node: &str, out: &str, stop_s: f64) -> Vec<(f64, f64)> {
    let source = format!("IINJ 0 {node} PULSE(0 1e-6 2e-6 1e-9 1e-9 1 2)");
    let rows = spice::tran(board, "DC 1.65", &source, &[out], 5e-9, 0.0, stop_s).expect("ngspice's step");
    rows.iter().map(|r| (r[0], rows[0][1] - r[1])).collect()
}

/// A [`step`] response against its final value `want`: its overshoot
/// (0 when it never passes `want`) and how far off `want` it is at
/// `at_s` (at its end where it stops before), both relative.
pub fn settling(out: &[(f64, f64)], want: f64, at_s: f64) -> (f64, f64) {
    let peak = out.iter().map(|(_, v)| *v).fold(0.0, f64::max);
    let at = out
        .iter()
        .find(|(t, _)| *t >= at_s)
        .or(out.last())
        .map_or(0.0, |(_, v)| *v);
    ((peak / want - 1.0).max(0.0), (at / want - 1.0).abs())
}
