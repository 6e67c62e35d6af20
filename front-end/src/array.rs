//! The array board's front end (`skin-array-board`): one comb
//! excitation for sixteen sensors, a transimpedance stage on each, and
//! the voltage the sensors see, each on the G474 input the firmware maps
//! it to.
//!
//! ```text
//! PA4 ─ reconstruction (Sallen–Key, 43 kHz) ─ 49.9 Ω ─ EXC ─┬─ J1…J16 top tabs
//!                                                          ├─ 3.3 kΩ / 270 pF ─ follower ─ 100 Ω / 1 nF ─ PA0
//!                                                          └─ 680 kΩ + 220 pF (the self-test's reference)
//! bottom tab ─ TIA (330 kΩ ∥ 2.7 pF, + at BIAS) ─ 100 Ω / 1 nF ─ the sensor's pin
//! ```
//!
//! **Why the voltage path has a pole.** A stage's feedback capacitor
//! (for its stability with 20 pF of cable and the op-amp's 9 pF) makes
//! its gain R_f/(1 + jωR_fC_f): 22 mrad of phase at 4 kHz, which the
//! firmware's one real transimpedance (`FrontEnd::transimpedance`) does
//! not carry. The voltage path's 3.3 kΩ and 270 pF have the same time
//! constant, 891 ns, so the ratio V/I the firmware reads carries none
//! (within the parts' tolerances: `tests/array.rs`). The ADC inputs'
//! 100 Ω and 1 nF (the sampling capacitor's charge reservoir, 1.6 MHz)
//! are on every path alike.

use crate::blocks;
use crate::circuit::{Circuit, Kind, Sensor};
use crate::parts;
use skin_spec::array::SENSORS;

/// Each sensor's ADC input pin, as the firmware's pin map
/// (`firmware::board::scan::INPUT_PINS`) sets it: sensor s on input
/// s + 1. The firmware's test `the_netlist_wires_every_input_as_the_pin_map`
/// holds the two together.
pub const SENSOR_PINS: [&str; SENSORS] = [
    "PC0", "PC1", "PC2", "PA6", "PA7", "PC4", "PC5", "PB0", "PB1", "PB13", "PA1", "PA8", "PA9", "PC3",
    "PB11", "PB12",
];
pub use crate::blocks::{DAC_PIN, VOLTAGE_PIN};
/// The self-test's reference network's input (spare input 17).
pub const REFERENCE_PIN: &str = "PB14";
/// The other spare input (18), held at the bias.
pub const SPARE_PIN: &str = "PB15";

/// The op-amp section of transimpedance stage `s` (0–15: sensors; 16:
/// the reference network): U1A … U4D, then U5A.
fn stage(s: usize) -> String {
    format!("U{}{}", s / 4 + 1, ['A', 'B', 'C', 'D'][s % 4])
}

/// The array board as built, the paper's sensor on every connector.
pub fn board() -> Circuit {
    let mut c = Circuit::new("skin-array-board front end: sixteen DE sensors, one comb excitation");
    // 43 kHz, Q 0.73: the DAC's 1 MSa/s steps' images 50 dB down, 6 kHz
    // flat within 10⁻⁴.
    blocks::excitation(&mut c, "U5B", "the comb, 1 MSa/s", [parts::C_1N, parts::C_470P]);
    blocks::voltage_path(&mut c, "U5D", parts::R_3K3, parts::C_270P, blocks::RESERVOIR);
    blocks::bias(&mut c, "U5C");
    for (s, pin) in SENSOR_PINS.iter().enumerate() {
        let j = format!("J{}", s + 1);
        let tab = format!("TAB{s}");
        c.add(
            &j,
            Kind::Connector,
            Some(parts::JST_PH2),
            &["EXC", &tab],
            &format!("sensor {s}: pin 1 top tab, pin 2 bottom tab"),
            "sensors",
        );
        transimpedance(&mut c, s, &tab, pin, &format!("sensor {s}"));
        c.sensors.push((j, Sensor::PAPER));
    }
    let block = "self-test";
    c.add(
        "RREF",
        Kind::Resistor,
        Some(parts::R_680K),
        &["EXC", "REFM"],
        "reference network: resistor",
        block,
    );
    c.add(
        "CREF",
        Kind::Capacitor,
        Some(parts::C_220P),
        &["REFM", "TABREF"],
        "reference network: capacitor",
        block,
    );
    transimpedance(&mut c, SENSORS, "TABREF", REFERENCE_PIN, "the reference network");
    blocks::adc_input(
        &mut c,
        blocks::RESERVOIR,
        "SP",
        "BIAS",
        SPARE_PIN,
        "spare input at the bias",
        "self-test",
    );
    blocks::supplies(&mut c, &["U1", "U2", "U3", "U4", "U5"], 6);
    c
}

/// Transimpedance stage `s` from `tab` to the ADC input `pin`.
fn transimpedance(c: &mut Circuit, s: usize, tab: &str, pin: &str, what: &str) {
    let (id, b) = if s < SENSORS {
        (s.to_string(), format!("stage {s}"))
    } else {
        ("REF".to_string(), "self-test".to_string())
    };
    let (u, out) = (stage(s), format!("TIA{id}"));
    c.add(
        &u,
        Kind::OpAmp,
        Some(parts::MCP6024),
        &["BIAS", tab, &out],
        &format!("{what}: transimpedance"),
        &b,
    );
    c.add(
        &format!("RF{id}"),
        Kind::Resistor,
        Some(parts::R_330K),
        &[tab, &out],
        &format!("{what}: feedback"),
        &b,
    );
    c.add(
        &format!("CF{id}"),
        Kind::Capacitor,
        Some(parts::C_2P7),
        &[tab, &out],
        &format!("{what}: feedback (stability)"),
        &b,
    );
    blocks::adc_input(c, blocks::RESERVOIR, &id, &out, pin, what, &b);
}
