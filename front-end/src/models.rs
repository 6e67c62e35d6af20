//! The SPICE models the netlists include: the op-amp's macro-model from
//! its data sheet, the G474's ADC input, and a sensor's line.

use crate::circuit::Sensor;
use std::fmt::Write as _;

/// Microchip's MCP6024 (one section) as a macro-model built from the
/// figures of its data sheet (MCP6021/1R/2/3/4, DS20001685, "DC" and
/// "AC Electrical Specifications", 25 °C, 5 V): gain-bandwidth 10 MHz,
/// phase margin 65° at a gain of +1 (the second pole at 21 MHz), open
/// loop gain 110 dB, slew rate 7.0 V/µs (a limited transconductance),
/// input noise voltage 8.7 nV/√Hz at 10 kHz (white here: its 1/f
/// corner, about 1 kHz, is left out, stated in docs/hardware.md),
/// common-mode input capacitance 6 pF, differential 3 pF, output within
/// 20 mV of either rail (a clamp), 50 Ω open-loop output resistance (not
/// in the data sheet: an assumption the stability checks cover). Input
/// current noise (3 fA/√Hz) and offset are left out: below the 330 kΩ
/// feedback's own noise and DC. Microchip's own model is not
/// redistributable here.
pub const OPAMP: &str = "
.subckt MCP6024 inp inn out vdd vss
Ccm1 inp vss 6p
Ccm2 inn vss 6p
Cdiff inp inn 3p
* 8.7 nV/rtHz: 1 ohm's noise current (1.287e-10 A/rtHz at 27 C) through 67.6 ohm
Rn nz vss 1
Vnz nz vss 0
Hn inp inx Vnz 67.6
Emid mid vss vdd vss 0.5
* 10 MHz with 10 pF: gm 628 uS; 110 dB: 503 Mohm; 7 V/us: 70 uA
Bgm mid g I = 7e-5*tanh(6.2832e-4*(V(inx)-V(inn))/7e-5)
Rg g mid 5.03e8 noisy=0
Cg g mid 10p
Ep p1 mid g mid 1
Rp p1 p2 1k noisy=0
Cp p2 mid 7.58p
Bo o1 vss V = min(max(V(p2,vss), 0.02), V(vdd,vss)-0.02)
Ro o1 out 50 noisy=0
.ends
";

/// An ADC input of the STM32G474 while it samples: its switch's
/// resistance and its sampling capacitor (data sheet DS12288, "ADC
/// characteristics": R_ADC up to 680 Ω on a slow channel, C_ADC 5 pF).
pub const ADC_INPUT: &str = "
.subckt ADC_INPUT pin
Radc pin s 680 noisy=0
Cadc s 0 5p
.ends
";

/// Sensor `name` between nodes `top` and `bottom`: `sections` R-C
/// elements along both electrodes (midpoint sections), the far end open, with its cable;
/// the current into its top tab is that of the 0 V source `V{name}_i`.
pub fn sensor(name: &str, top: &str, bottom: &str, s: &Sensor, sections: usize) -> String {
    let n = sections as f64;
    let (r, c) = (s.r_ohm / 2.0 / n, s.c_farad / n);
    let mut out = format!(
        "* sensor on {name}: {:e} ohm, {:e} F; its current through V{name}_i\nV{name}_i {top} {name}_top 0\n",
        s.r_ohm, s.c_farad
    );
    let (mut t, mut b) = (format!("{name}_top"), bottom.to_string());
    for k in 1..=sections {
        let (tk, bk) = (format!("{name}_t{k}"), format!("{name}_b{k}"));
        // Midpoint sections: half a section's resistance before the first
        // capacitor (the open far end needs none after the last).
        let r = if k == 1 { r / 2.0 } else { r };
        let _ = writeln!(
            out,
            "R{name}_t{k} {t} {tk} {r:e}\nR{name}_b{k} {b} {bk} {r:e}\nC{name}_{k} {tk} {bk} {c:e}"
        );
        (t, b) = (tk, bk);
    }
    if s.cable_farad > 0.0 {
        let _ = writeln!(out, "C{name}_cable {top} {bottom} {:e}", s.cable_farad);
    }
    if s.shield_farad > 0.0 {
        let _ = writeln!(out, "C{name}_shield {bottom} 0 {:e}", s.shield_farad);
    }
    out
}

/// An analog multiplexer of `channels` (8 or 4): drain `d`, sources
/// `s1…`, address lines `a0…` (high above VDD/2), supply `vdd`. Its
/// figures are bounds no better than the data sheets' (ADG708: 3 Ω on
/// resistance typical at 5 V, more at 3.3 V; TMUX1104: a few Ω): on
/// resistance `ron` Ω, each source's and the drain's capacitance to
/// ground, and charge injection as a capacitance from each address line
/// to the drain (Q = C·VDD on every edge: the gate charge the decoder's
/// switching couples in). `tests/mux.rs` passes with them; a part with
/// smaller ones only does better. A switch is a conductance its decoder
/// sets (ngspice-39's own switch reads open in an AC analysis whatever
/// its control).
fn mux_model(name: &str, channels: usize, ron: f64, c_source: f64, c_drain: f64, q_coulomb: f64) -> String {
    let lines = channels.trailing_zeros() as usize;
    let sources: Vec<String> = (1..=channels).map(|k| format!("s{k}")).collect();
    let address: Vec<String> = (0..lines).map(|k| format!("a{k}")).collect();
    let mut m = format!(
        ".subckt {name} d {} {} vdd\n",
        sources.join(" "),
        address.join(" ")
    );
    let code: Vec<String> = (0..lines)
        .map(|k| format!("(V(a{k}) > V(vdd)/2 ? {} : 0)", 1 << k))
        .collect();
    let _ = writeln!(m, "Bcode code 0 V = {}", code.join(" + "));
    for k in 1..=channels {
        let _ = writeln!(
            m,
            "Bc{k} c{k} 0 V = abs(V(code) - {}) < 0.5 ? 1 : 0\nBs{k} d s{k} I = (V(d) - V(s{k})) * (V(c{k}) * {:e} + 1e-12)\nCs{k} s{k} 0 {c_source:e}",
            k - 1,
            1.0 / ron
        );
    }
    let _ = writeln!(m, "Cd d 0 {c_drain:e}");
    for k in 0..lines {
        let _ = writeln!(m, "Cq{k} a{k} d {:e}", q_coulomb / 3.3);
    }
    m += ".ends\n";
    m
}

/// The sensors' multiplexer, ADG708 (8:1), as [`mux_model`] bounds it:
/// 10 Ω on, 15 pF at each source, 100 pF at the drain, 5 pC injected on
/// an address edge.
pub fn adg708() -> String {
    mux_model("ADG708", 8, 10.0, 15e-12, 100e-12, 5e-12)
}

/// The range switch, TMUX1104 (4:1), as [`mux_model`] bounds it: 10 Ω
/// on, 10 pF at each source, 30 pF at the drain, 5 pC on an edge.
pub fn tmux1104() -> String {
    mux_model("TMUX1104", 4, 10.0, 10e-12, 30e-12, 5e-12)
}

/// The model of device `name` ([`adg708`], [`tmux1104`]); empty for one
/// this crate has no model of.
pub fn device(name: &str) -> String {
    match name {
        "ADG708" => adg708(),
        "TMUX1104" => tmux1104(),
        _ => String::new(),
    }
}

/// The pins of device `name`'s model, in the order its netlist line
/// gives its nodes.
pub fn pins(name: &str) -> &'static [&'static str] {
    match name {
        "ADG708" => &[
            "D", "S1", "S2", "S3", "S4", "S5", "S6", "S7", "S8", "A0", "A1", "A2", "VDD",
        ],
        "TMUX1104" => &["D", "S1", "S2", "S3", "S4", "A0", "A1", "VDD"],
        _ => &[],
    }
}
