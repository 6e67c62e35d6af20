//! The orderable parts the boards are built from: one entry per
//! manufacturer's part number, with what the netlist and the bill of
//! materials need of it.

use skin_spec::array::{REFERENCE_FARAD, REFERENCE_FARAD_TOLERANCE, REFERENCE_OHM, REFERENCE_OHM_TOLERANCE};

/// A part a lab can order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Part {
    /// Manufacturer.
    pub manufacturer: &'static str,
    /// Manufacturer's part number.
    pub number: &'static str,
    /// Package.
    pub package: &'static str,
    /// Value as the bill of materials prints it.
    pub value: &'static str,
    /// Tolerance as the bill of materials prints it.
    pub tolerance: &'static str,
    /// The value in SI units (Ω, F), 0 for parts without one.
    pub si: f64,
    /// The tolerance as a fraction of `si` (C0G parts under 10 pF are
    /// toleranced in pF: given here as the fraction it is of `si`).
    pub tol: f64,
}

/// A 0603 resistor: Panasonic's thin film at 0.1 %, Yageo's thick film
/// at 1 %.
const fn r(number: &'static str, value: &'static str, si: f64, tol: f64, tolerance: &'static str) -> Part {
    let manufacturer = if tol < 0.005 { "Panasonic" } else { "Yageo" };
    c(manufacturer, number, value, si, tol, tolerance)
}

/// A part without a value of its own (an integrated circuit, a
/// connector): its value column names it.
const fn unvalued(
    manufacturer: &'static str,
    number: &'static str,
    package: &'static str,
    value: &'static str,
) -> Part {
    Part {
        manufacturer,
        number,
        package,
        value,
        tolerance: "",
        si: 0.0,
        tol: 0.0,
    }
}

/// A C0G part of Murata's high-Q series (0402), ± 0.05 pF.
const fn gjm(number: &'static str, value: &'static str, si: f64) -> Part {
    Part {
        package: "0402",
        ..c("Murata", number, value, si, 0.05e-12 / si, "±0.05 pF")
    }
}

/// A 0603 part.
const fn c(
    manufacturer: &'static str,
    number: &'static str,
    value: &'static str,
    si: f64,
    tol: f64,
    tolerance: &'static str,
) -> Part {
    Part {
        manufacturer,
        number,
        package: "0603",
        value,
        tolerance,
        si,
        tol,
    }
}

/// 330 kΩ, 0.1 %, 25 ppm/K thin film: every transimpedance stage's
/// feedback ([`skin_spec::array::SENSOR_TIA_OHM`]).
pub const R_330K: Part = r("ERA-3AEB334V", "330 kΩ", 330e3, 0.001, "0.1 %");
/// 680 kΩ, 0.1 %: the self-test's reference network (its value and
/// tolerance the firmware's: `skin_spec::array::REFERENCE_OHM`).
pub const R_680K: Part = r(
    "ERA-3AEB684V",
    "680 kΩ",
    REFERENCE_OHM,
    REFERENCE_OHM_TOLERANCE,
    "0.1 %",
);
/// 3.3 kΩ, 0.1 %: the voltage path's pole, matched to the stages'.
pub const R_3K3: Part = r("ERA-3AEB332V", "3.3 kΩ", 3.3e3, 0.001, "0.1 %");
/// 5.36 kΩ, 0.1 %: the reconstruction filter (the DAC's buffered output
/// wants 5 kΩ or more).
pub const R_5K36: Part = r("ERA-3AEB5361V", "5.36 kΩ", 5.36e3, 0.001, "0.1 %");
/// 10 kΩ, 0.1 %: the bias divider.
pub const R_10K: Part = r("ERA-3AEB103V", "10 kΩ", 10e3, 0.001, "0.1 %");
/// 160 Ω, 0.1 %: the multiplexed board's anti-alias filter at each ADC
/// input (matched between the voltage's and the current's).
pub const R_160: Part = r("ERA-3AEB161V", "160 Ω", 160.0, 0.001, "0.1 %");
/// 10 nF, 1 %, C0G (0805): with [`R_160`].
pub const C_10N: Part = Part {
    package: "0805",
    ..c("KEMET", "C0805C103F5GACTU", "10 nF", 10e-9, 0.01, "1 %")
};
/// 100 Ω, 1 %: each ADC input's series resistor.
pub const R_100: Part = r("RC0603FR-07100RL", "100 Ω", 100.0, 0.01, "1 %");
/// 49.9 Ω, 1 %: the excitation buffer's isolation from the cables.
pub const R_49R9: Part = r("RC0603FR-0749R9L", "49.9 Ω", 49.9, 0.01, "1 %");

/// 2.7 pF ± 0.05 pF C0G (high-Q series, 0402): each transimpedance
/// stage's feedback capacitor. Its absolute tolerance across 330 kΩ is
/// most of a path's delay spread (`tests/array.rs`): ±0.1 pF parts
/// would double it.
pub const C_2P7: Part = gjm("GJM1555C1H2R7WB01D", "2.7 pF", 2.7e-12);
/// 270 pF, 1 %, C0G: the voltage path's pole.
pub const C_270P: Part = c("KEMET", "C0603C271F5GACTU", "270 pF", 270e-12, 0.01, "1 %");
/// 220 pF, 1 %, C0G: the self-test's reference (the firmware's
/// `skin_spec::array::REFERENCE_FARAD`).
pub const C_220P: Part = c(
    "KEMET",
    "C0603C221F5GACTU",
    "220 pF",
    REFERENCE_FARAD,
    REFERENCE_FARAD_TOLERANCE,
    "1 %",
);
/// 470 pF, 1 %, C0G: the reconstruction filter.
pub const C_470P: Part = c("KEMET", "C0603C471F5GACTU", "470 pF", 470e-12, 0.01, "1 %");
/// 1 nF, 1 %, C0G: the reconstruction filter; each ADC input's charge
/// reservoir.
pub const C_1N: Part = c("KEMET", "C0603C102F5GACTU", "1 nF", 1e-9, 0.01, "1 %");
/// 3.3 nF and 1.5 nF, 1 %, C0G: the multiplexed board's reconstruction
/// filter.
pub const C_3N3: Part = c("KEMET", "C0603C332F5GACTU", "3.3 nF", 3.3e-9, 0.01, "1 %");
/// See [`C_3N3`].
pub const C_1N5: Part = c("KEMET", "C0603C152F5GACTU", "1.5 nF", 1.5e-9, 0.01, "1 %");
/// 100 nF, 10 %, X7R: decoupling and the bias.
pub const C_100N: Part = c("Murata", "GRM188R71H104KA93D", "100 nF", 100e-9, 0.1, "10 %");

/// Quad CMOS op-amp, 10 MHz, rail to rail, 2.5–5.5 V ([`crate::models`]).
pub const MCP6024: Part = unvalued("Microchip", "MCP6024-E/SL", "SOIC-14", "MCP6024");

/// A sensor's connector: JST PH, 2 pins, 2 mm, through hole (pin 1 the
/// top tab, pin 2 the bottom tab).
pub const JST_PH2: Part = unvalued("JST", "B2B-PH-K-S(LF)(SN)", "THT 2 mm", "PH 2-pin");

/// The Nucleo's morpho connector, 2×19 female, 2.54 mm (two a board:
/// CN7 and CN10).
pub const MORPHO: Part = unvalued("Sullins", "PPTC192LFBN-RC", "THT 2.54 mm 2×19", "2×19 socket");

/// 100 kΩ, 220 kΩ, 470 kΩ and 1 MΩ, 0.1 %: the multiplexed board's four
/// ranges ([`skin_spec::design::TIA_RANGES_OHM`]).
pub const R_RANGES: [Part; 4] = [
    r("ERA-3AEB104V", "100 kΩ", 100e3, 0.001, "0.1 %"),
    r("ERA-3AEB224V", "220 kΩ", 220e3, 0.001, "0.1 %"),
    r("ERA-3AEB474V", "470 kΩ", 470e3, 0.001, "0.1 %"),
    r("ERA-3AEB105V", "1 MΩ", 1e6, 0.001, "0.1 %"),
];
/// Each range's feedback capacitor, C0G: one time constant, 4.7 µs, for
/// all four (the voltage path's pole matches it), 47 pF … 4.7 pF; the
/// 220 kΩ range's 21.3 pF is 18 pF with [`C_3P3`] beside it.
pub const C_RANGES: [Part; 4] = [
    c("KEMET", "C0603C470F5GACTU", "47 pF", 47e-12, 0.01, "1 %"),
    c("KEMET", "C0603C180F5GACTU", "18 pF", 18e-12, 0.01, "1 %"),
    c("KEMET", "C0603C100F5GACTU", "10 pF", 10e-12, 0.01, "1 %"),
    gjm("GJM1555C1H4R7WB01D", "4.7 pF", 4.7e-12),
];
/// 4.7 kΩ, 0.1 %: the multiplexed board's voltage path pole.
pub const R_4K7: Part = r("ERA-3AEB472V", "4.7 kΩ", 4.7e3, 0.001, "0.1 %");

/// Eight-channel analog multiplexer, 1.8–5.5 V ([`crate::models::adg708`]).
pub const ADG708: Part = unvalued("Analog Devices", "ADG708BRUZ", "TSSOP-16", "ADG708");

/// Four-channel precision multiplexer, 1.08–5.5 V
/// ([`crate::models::tmux1104`]).
pub const TMUX1104: Part = unvalued("Texas Instruments", "TMUX1104DGSR", "VSSOP-10", "TMUX1104");

/// 3.3 pF ± 0.05 pF C0G (0402): beside the 220 kΩ range's 18 pF.
pub const C_3P3: Part = gjm("GJM1555C1H3R3WB01D", "3.3 pF", 3.3e-12);
