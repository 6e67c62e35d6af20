//! A board's circuit as one list of parts and their nets: what the
//! netlist, the bill of materials and the schematic are all written from.

use crate::parts::Part;
use std::fmt::Write as _;

/// What an element is, and how the netlist writes it.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    /// A resistor: nodes [a, b], Ω from its part.
    Resistor,
    /// A capacitor: nodes [a, b], F from its part.
    Capacitor,
    /// One section of an op-amp package: nodes [in+, in−, out]; its
    /// supplies are VDDA and GND ([`crate::models::opamp`]).
    OpAmp,
    /// A connector: one node per pin. Off-board on the other side: a
    /// sensor's connector carries a sensor ([`Circuit::sensors`]), the
    /// Nucleo's carries its pins ([`Kind::AdcPin`], [`Kind::DacPin`]).
    Connector,
    /// An ADC input of the G474 on the Nucleo pin its node is named
    /// after ([`crate::models::ADC_INPUT`]); not a part of the BOM.
    AdcPin,
    /// The DAC's output pin (PA4): the stimulus of an analysis.
    DacPin,
    /// A GPIO pin of the Nucleo driving a logic line (a multiplexer's
    /// address), as the board's [`Circuit::drives`] set it.
    GpioPin,
    /// A device with a SPICE model of its own (`models`): its nodes in
    /// the model's order, the supply last.
    Device(&'static str),
}

/// One element of a board.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Reference designator (R12, U3A, J4; the pin's name for a pin).
    pub reference: String,
    /// What it is.
    pub kind: Kind,
    /// The part ordered (None: a pin of the Nucleo).
    pub part: Option<Part>,
    /// Its nodes, in the order [`Kind`] gives.
    pub nodes: Vec<String>,
    /// What it does (the BOM's last column).
    pub function: String,
    /// The schematic's block it is drawn in.
    pub block: String,
}

impl Element {
    /// Its value in SI units (Ω, F) as the netlist writes it.
    pub fn value(&self) -> f64 {
        self.part.map_or(0.0, |p| p.si)
    }
}

/// A board: its elements, and the sensors its connectors carry in a
/// simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Circuit {
    /// Title (the netlist's first line).
    pub title: String,
    /// Every element, in the order the schematic draws them.
    pub elements: Vec<Element>,
    /// Per sensor connector (its reference): the sensor it carries.
    pub sensors: Vec<(String, Sensor)>,
    /// Sections of each sensor's line ([`SECTIONS`]; fewer for a
    /// transient, where the line's fine shape is not what is asked).
    pub sections: usize,
    /// What drives each GPIO pin (its SPICE source's value: `DC 3.3`, a
    /// `PWL(…)`); a pin not listed is low.
    pub drives: Vec<(String, String)>,
}

/// A DE sensor as a simulation sees it off the board: a line of
/// `sections` R-C elements, both electrodes, read from one end, and its
/// cable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Both electrodes' resistance, Ω (half each).
    pub r_ohm: f64,
    /// Capacitance between them, F.
    pub c_farad: f64,
    /// The cable's capacitance between its two conductors, F.
    pub cable_farad: f64,
    /// The cable's capacitance from the bottom tab's conductor to
    /// ground (a shield), F.
    pub shield_farad: f64,
}

/// Sections of a sensor's line in the netlist: midpoint sections, within
/// 10⁻³ of the continuous line up to x = 2π·f·R·C = 8 (`tests/array.rs`).
pub const SECTIONS: usize = 30;

impl Sensor {
    /// The paper's sensor at rest ([`skin_spec::design`]), no cable.
    pub const PAPER: Self = Self {
        r_ohm: skin_spec::design::SENSOR_R_REST_OHM,
        c_farad: skin_spec::design::SENSOR_C_REST_FARAD,
        cable_farad: 0.0,
        shield_farad: 0.0,
    };

    /// Its impedance between the tabs at `f_hz`, Ω: the open line
    /// z/γ·coth(γ), z = R, y = jωC per unit length, with the cable in
    /// parallel.
    pub fn impedance(&self, f_hz: f64) -> num_complex::Complex64 {
        let w = std::f64::consts::TAU * f_hz;
        let j = num_complex::Complex64::i();
        let gamma = (self.r_ohm * j * w * self.c_farad).sqrt();
        let line = self.r_ohm / gamma / gamma.tanh();
        let y = 1.0 / line + j * w * self.cable_farad;
        1.0 / y
    }
}

impl Circuit {
    /// An empty board.
    pub fn new(title: &str) -> Self {
        Self {
            title: title.to_string(),
            elements: Vec::new(),
            sensors: Vec::new(),
            sections: SECTIONS,
            drives: Vec::new(),
        }
    }

    /// Add an element.
    pub fn add(
        &mut self,
        reference: &str,
        kind: Kind,
        part: Option<Part>,
        nodes: &[&str],
        function: &str,
        block: &str,
    ) {
        self.elements.push(Element {
            reference: reference.to_string(),
            kind,
            part,
            nodes: nodes.iter().map(|n| n.to_string()).collect(),
            function: function.to_string(),
            block: block.to_string(),
        });
    }

    /// The element `reference`.
    pub fn element(&self, reference: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.reference == reference)
    }

    /// The same board with element `reference`'s value times `factor`
    /// (a tolerance corner).
    pub fn scaled(&self, reference: &str, factor: f64) -> Self {
        let mut c = self.clone();
        for e in c.elements.iter_mut().filter(|e| e.reference == reference) {
            if let Some(p) = e.part.as_mut() {
                p.si *= factor;
            }
        }
        c
    }

    /// The same board with lines of `sections` sections.
    pub fn with_sections(&self, sections: usize) -> Self {
        Self {
            sections: sections.max(1),
            ..self.clone()
        }
    }

    /// The same board with GPIO pin `pin` driven by `source` (a SPICE
    /// source's value).
    pub fn driven(&self, pin: &str, source: &str) -> Self {
        let mut c = self.clone();
        c.drives.retain(|(p, _)| p != pin);
        c.drives.push((pin.to_string(), source.to_string()));
        c
    }

    /// Every connector carrying `sensor`.
    pub fn with_sensors(&self, sensor: Sensor) -> Self {
        let mut c = self.clone();
        for (_, s) in c.sensors.iter_mut() {
            *s = sensor;
        }
        c
    }

    /// The SPICE netlist: the models, every element, the sensors on
    /// their connectors, the supply, the DAC driven by `stimulus`, then
    /// `extra` (an analysis's own lines: its sources, its `.control`).
    pub fn netlist(&self, stimulus: &str, extra: &str) -> String {
        let mut s = format!(
            "* {}\n* Generated by the front-end crate: do not edit.\n",
            self.title
        );
        s += crate::models::OPAMP;
        s += crate::models::ADC_INPUT;
        for e in &self.elements {
            if let Kind::Device(model) = e.kind {
                if !s.contains(&format!(".subckt {model} ")) {
                    s += &crate::models::device(model);
                }
            }
        }
        s += "\nVDDA VDDA 0 3.3\n";
        for e in &self.elements {
            let n = e.nodes.join(" ");
            let line = match e.kind {
                Kind::Resistor => format!("{} {n} {:e}", spice_name('R', &e.reference), e.value()),
                Kind::Capacitor => format!("{} {n} {:e}", spice_name('C', &e.reference), e.value()),
                Kind::OpAmp => format!("X{} {n} VDDA 0 MCP6024", e.reference),
                Kind::Connector => format!("* {} ({}): {n}", e.reference, e.function),
                Kind::AdcPin => format!("XADC_{} {n} ADC_INPUT", e.reference),
                Kind::DacPin => format!("VDAC_{} {n} 0 {stimulus}", e.reference),
                Kind::GpioPin => {
                    let drive = self
                        .drives
                        .iter()
                        .find(|(p, _)| *p == e.reference)
                        .map_or("DC 0", |(_, d)| d);
                    format!("VGPIO_{} {n} 0 {drive}", e.reference)
                }
                Kind::Device(model) => format!("X{} {n} {model}", e.reference),
            };
            let _ = writeln!(s, "{line}");
        }
        for (j, sensor) in &self.sensors {
            if let Some(e) = self.element(j) {
                s += &crate::models::sensor(j, &e.nodes[0], &e.nodes[1], sensor, self.sections);
            }
        }
        s += extra;
        s += "\n.end\n";
        s
    }
}

/// A reference as SPICE names an element of kind `letter`: itself where
/// it starts with the letter (R12), else prefixed (a resistor RT1 stays,
/// a capacitor named otherwise gets a C).
fn spice_name(letter: char, reference: &str) -> String {
    if reference.starts_with(letter) {
        reference.to_string()
    } else {
        format!("{letter}{reference}")
    }
}
