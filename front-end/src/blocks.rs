//! The pieces both boards share: the excitation's reconstruction filter
//! and buffer, the voltage path, the bias, and an ADC input.

use crate::circuit::{Circuit, Kind};
use crate::parts::{self, Part};

/// The DAC's output pin.
pub const DAC_PIN: &str = "PA4";
/// The excitation's voltage input.
pub const VOLTAGE_PIN: &str = "PA0";

/// PA4 through a unity-gain Sallen–Key low-pass (two 5.36 kΩ, `caps` the
/// feedback and the ground capacitor) to the buffered excitation, EXC,
/// through `buffer` (an op-amp section) and 49.9 Ω; `what` the DAC plays.
pub fn excitation(c: &mut Circuit, buffer: &str, what: &str, caps: [Part; 2]) {
    let b = "excitation";
    c.add(
        DAC_PIN,
        Kind::DacPin,
        None,
        &[DAC_PIN],
        &format!("DAC1_OUT1: {what}"),
        b,
    );
    c.add(
        "R1",
        Kind::Resistor,
        Some(parts::R_5K36),
        &[DAC_PIN, "SK1"],
        "reconstruction filter",
        b,
    );
    c.add(
        "R2",
        Kind::Resistor,
        Some(parts::R_5K36),
        &["SK1", "SK2"],
        "reconstruction filter",
        b,
    );
    c.add(
        "C1",
        Kind::Capacitor,
        Some(caps[0]),
        &["SK1", "EXCB"],
        "reconstruction filter (feedback)",
        b,
    );
    c.add(
        "C2",
        Kind::Capacitor,
        Some(caps[1]),
        &["SK2", "0"],
        "reconstruction filter",
        b,
    );
    c.add(
        buffer,
        Kind::OpAmp,
        Some(parts::MCP6024),
        &["SK2", "EXCB", "EXCB"],
        "excitation buffer",
        b,
    );
    c.add(
        "R3",
        Kind::Resistor,
        Some(parts::R_49R9),
        &["EXCB", "EXC"],
        "buffer's isolation from the cables",
        b,
    );
}

/// EXC through the pole matched to the stages' (`r` and `cap`) and the
/// `follower` op-amp section to PA0 through `filter`.
pub fn voltage_path(c: &mut Circuit, follower: &str, r: Part, cap: Part, filter: AdcFilter) {
    let b = "voltage";
    c.add(
        "R4",
        Kind::Resistor,
        Some(r),
        &["EXC", "VRC"],
        "voltage path: pole matched to R_f·C_f",
        b,
    );
    c.add(
        "C3",
        Kind::Capacitor,
        Some(cap),
        &["VRC", "0"],
        "voltage path: pole matched to R_f·C_f",
        b,
    );
    c.add(
        follower,
        Kind::OpAmp,
        Some(parts::MCP6024),
        &["VRC", "VBUF", "VBUF"],
        "voltage path follower",
        b,
    );
    adc_input(c, filter, "V", "VBUF", VOLTAGE_PIN, "the excitation's voltage", b);
}

/// The bias, VDDA/2 from two 10 kΩ, through the `buffer` op-amp section.
pub fn bias(c: &mut Circuit, buffer: &str) {
    let b = "bias";
    c.add(
        "R5",
        Kind::Resistor,
        Some(parts::R_10K),
        &["VDDA", "BIASD"],
        "bias divider",
        b,
    );
    c.add(
        "R6",
        Kind::Resistor,
        Some(parts::R_10K),
        &["BIASD", "0"],
        "bias divider",
        b,
    );
    c.add(
        "C4",
        Kind::Capacitor,
        Some(parts::C_100N),
        &["BIASD", "0"],
        "bias divider's filter",
        b,
    );
    c.add(
        buffer,
        Kind::OpAmp,
        Some(parts::MCP6024),
        &["BIASD", "BIAS", "BIAS"],
        "bias buffer, VDDA/2",
        b,
    );
    c.add(
        "C5",
        Kind::Capacitor,
        Some(parts::C_100N),
        &["BIAS", "0"],
        "bias decoupling",
        b,
    );
}

/// An ADC input's series resistor and the capacitor at its pin.
pub type AdcFilter = [Part; 2];

/// The array's: 100 Ω and 1 nF (1.6 MHz): the sampling capacitor's
/// charge reservoir; its 16 conversions a result average the rest.
pub const RESERVOIR: AdcFilter = [parts::R_100, parts::C_1N];

/// The multiplexed board's: 160 Ω and 10 nF, 0.1 % and 1 % (100 kHz): one
/// conversion a sample folds in all the op-amp passes, so the noise above
/// the tones is cut before the pin, on the voltage's path and the
/// current's alike.
pub const ANTI_ALIAS: AdcFilter = [parts::R_160, parts::C_10N];

/// `from` through `filter`'s resistor to ADC pin `pin`, its capacitor
/// there.
pub fn adc_input(
    c: &mut Circuit,
    filter: AdcFilter,
    id: &str,
    from: &str,
    pin: &str,
    what: &str,
    block: &str,
) {
    c.add(
        &format!("RA{id}"),
        Kind::Resistor,
        Some(filter[0]),
        &[from, pin],
        &format!("{what}: ADC input"),
        block,
    );
    c.add(
        &format!("CA{id}"),
        Kind::Capacitor,
        Some(filter[1]),
        &[pin, "0"],
        &format!("{what}: ADC charge reservoir"),
        block,
    );
    c.add(
        pin,
        Kind::AdcPin,
        None,
        &[pin],
        &format!("{what}: ADC input"),
        block,
    );
}

/// One 100 nF at each of `packages`' supply pins (C`first` on), and the
/// Nucleo's two morpho sockets, which bring VDDA and ground.
pub fn supplies(c: &mut Circuit, packages: &[&str], first: usize) {
    let b = "supplies";
    for (k, u) in packages.iter().enumerate() {
        let reference = format!("C{}", first + k);
        c.add(
            &reference,
            Kind::Capacitor,
            Some(parts::C_100N),
            &["VDDA", "0"],
            &format!("{u} decoupling"),
            b,
        );
    }
    let cn7 = "to the Nucleo's CN7, its pins as UM2505 names them";
    c.add(
        "CN7",
        Kind::Connector,
        Some(parts::MORPHO),
        &["VDDA", "0"],
        cn7,
        b,
    );
    c.add(
        "CN10",
        Kind::Connector,
        Some(parts::MORPHO),
        &["0"],
        "to the Nucleo's CN10",
        b,
    );
}
