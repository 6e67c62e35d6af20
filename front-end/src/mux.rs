//! The multiplexed board's front end (`skin-board`): eight sensors behind
//! two eight-channel multiplexers (top tabs and bottom tabs), one
//! transimpedance stage with four ranges behind a four-channel switch,
//! and the voltage the sensors see, each on the pin the firmware maps.
//!
//! ```text
//! PA4 ─ reconstruction ─ U1A ─ 49.9 Ω ─ EXC ─┬─ U2 (ADG708) ─ J1…J8 pin 1
//!                                            └─ 4.7 kΩ / 1 nF ─ U1C ─ 160 Ω / 10 nF ─ PA0
//! J1…J8 pin 2 ─ U3 (ADG708) ─ TABM ─ U1D − (+ at BIAS) ─ TIA ─ 160 Ω / 10 nF ─ PA1
//!                             TABM ─ R_k ∥ C_k ─ U4 (TMUX1104) S_k ─ D at TIA, k = 0…3
//! PB0, PB1, PB2: U2's and U3's A0…A2; PB5, PB6: U4's A0, A1
//! ```
//!
//! Every range has the same time constant, 4.7 µs (100 kΩ ∥ 47 pF …
//! 1 MΩ ∥ 4.7 pF), which the voltage path's 4.7 kΩ and 1 nF match: the
//! ratio V/I the firmware reads through any range carries no phase of
//! its own. The range switch sits inside the loop, in series with its
//! resistor: its on-resistance is a gain error of 10⁻⁴ at 100 kΩ, which
//! the range's calibration takes.

use crate::blocks;
use crate::circuit::{Circuit, Kind, Sensor};
use crate::parts;
use skin_spec::config::CHANNELS;
use skin_spec::design::RANGES;

/// The current's ADC input (ADC2_IN2).
pub const CURRENT_PIN: &str = "PA1";
/// The sensors' multiplexer's address lines, A0…A2.
pub const MUX_PINS: [&str; 3] = ["PB0", "PB1", "PB2"];
/// The range switch's address lines, A0, A1.
pub const RANGE_PINS: [&str; 2] = ["PB5", "PB6"];

/// The multiplexed board as built, the paper's sensor on every
/// connector, channel 0 and range 0 selected.
pub fn board() -> Circuit {
    let mut c = Circuit::new("skin-board front end: eight DE sensors through a multiplexer, four ranges");
    // 13 kHz, Q 0.74: the DAC plays at the ADC's rate, so an image of its
    // steps at 200 kHz less a tone is sampled onto the tone itself, through
    // the sensor's path and the voltage's differently (docs/hardware.md).
    blocks::excitation(
        &mut c,
        "U1A",
        "two tones, 200 kSa/s",
        [parts::C_3N3, parts::C_1N5],
    );
    blocks::voltage_path(&mut c, "U1C", parts::R_4K7, parts::C_1N, blocks::ANTI_ALIAS);
    blocks::bias(&mut c, "U1B");
    for pin in MUX_PINS.iter().chain(&RANGE_PINS) {
        c.add(pin, Kind::GpioPin, None, &[pin], "address line", "addresses");
    }
    let b = "multiplexers";
    let tops: Vec<String> = (0..CHANNELS).map(|k| format!("TOP{k}")).collect();
    let bottoms: Vec<String> = (0..CHANNELS).map(|k| format!("BOT{k}")).collect();
    let mut top: Vec<&str> = vec!["EXC"];
    top.extend(tops.iter().map(String::as_str));
    top.extend(MUX_PINS);
    top.push("VDDA");
    c.add(
        "U2",
        Kind::Device("ADG708"),
        Some(parts::ADG708),
        &top,
        "top tabs' multiplexer",
        b,
    );
    let mut bottom: Vec<&str> = vec!["TABM"];
    bottom.extend(bottoms.iter().map(String::as_str));
    bottom.extend(MUX_PINS);
    bottom.push("VDDA");
    c.add(
        "U3",
        Kind::Device("ADG708"),
        Some(parts::ADG708),
        &bottom,
        "bottom tabs' multiplexer",
        b,
    );
    for k in 0..CHANNELS {
        let j = format!("J{}", k + 1);
        c.add(
            &j,
            Kind::Connector,
            Some(parts::JST_PH2),
            &[&tops[k], &bottoms[k]],
            &format!("sensor {k}: pin 1 top tab, pin 2 bottom tab"),
            "sensors",
        );
        c.sensors.push((j, Sensor::PAPER));
    }
    stage(&mut c);
    blocks::supplies(&mut c, &["U1", "U2", "U3", "U4"], 10);
    c
}

/// The transimpedance stage: U1D, its four ranges through U4, and the
/// current's ADC input.
fn stage(c: &mut Circuit) {
    let b = "stage";
    c.add(
        "U1D",
        Kind::OpAmp,
        Some(parts::MCP6024),
        &["BIAS", "TABM", "TIA"],
        "transimpedance",
        b,
    );
    let ranges: Vec<String> = (0..RANGES).map(|k| format!("RG{k}")).collect();
    for (k, (range, (r, cap))) in ranges
        .iter()
        .zip(parts::R_RANGES.iter().zip(parts::C_RANGES))
        .enumerate()
    {
        c.add(
            &format!("RF{k}"),
            Kind::Resistor,
            Some(*r),
            &["TABM", range],
            &format!("range {k}: feedback"),
            b,
        );
        c.add(
            &format!("CF{k}"),
            Kind::Capacitor,
            Some(cap),
            &["TABM", range],
            &format!("range {k}: feedback (stability, 4.7 µs)"),
            b,
        );
    }
    c.add(
        "CF1B",
        Kind::Capacitor,
        Some(parts::C_3P3),
        &["TABM", &ranges[1]],
        "range 1: feedback, with CF1 21.3 pF",
        b,
    );
    let mut switch: Vec<&str> = vec!["TIA"];
    switch.extend(ranges.iter().map(String::as_str));
    switch.extend(RANGE_PINS);
    switch.push("VDDA");
    c.add(
        "U4",
        Kind::Device("TMUX1104"),
        Some(parts::TMUX1104),
        &switch,
        "range switch",
        b,
    );
    blocks::adc_input(c, blocks::ANTI_ALIAS, "I", "TIA", CURRENT_PIN, "the current", b);
}

/// `board` with channel `channel` and range `range` selected (their
/// address lines high or low as the firmware sets them).
pub fn select(board: &Circuit, channel: usize, range: usize) -> Circuit {
    let mut c = board.clone();
    for (bit, pin) in MUX_PINS.iter().enumerate() {
        c = c.driven(pin, if channel >> bit & 1 == 1 { "DC 3.3" } else { "DC 0" });
    }
    for (bit, pin) in RANGE_PINS.iter().enumerate() {
        c = c.driven(pin, if range >> bit & 1 == 1 { "DC 3.3" } else { "DC 0" });
    }
    c
}
