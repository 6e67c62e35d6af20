//! The schematic drawing, from the same circuit as the netlist: each
//! block of the board in a panel, each part as its symbol with its
//! reference and value, each pin labelled with its net (nets connect by
//! name, as on a schematic with net labels). The Nucleo's pins are
//! flags named for the G474 pin the firmware maps.

use crate::circuit::{Circuit, Element, Kind};
use std::fmt::Write as _;

/// A part's cell, px.
const CELL: (f64, f64) = (150.0, 96.0);
/// Parts on one row of a panel.
const PER_ROW: usize = 8;
/// A panel's title bar, px.
const TITLE: f64 = 22.0;

/// The board as an SVG drawing.
pub fn svg(board: &Circuit) -> String {
    let mut blocks: Vec<(&str, Vec<&Element>)> = Vec::new();
    for e in &board.elements {
        match blocks.iter_mut().find(|(b, _)| *b == e.block) {
            Some((_, v)) => v.push(e),
            None => blocks.push((&e.block, vec![e])),
        }
    }
    let width = PER_ROW as f64 * CELL.0 + 20.0;
    let mut body = String::new();
    let mut y = 40.0;
    for (name, parts) in &blocks {
        // Each row as tall as its tallest part.
        let heights: Vec<f64> = parts
            .chunks(PER_ROW)
            .map(|row| row.iter().map(|e| height(e)).fold(CELL.1, f64::max))
            .collect();
        let h = TITLE + heights.iter().sum::<f64>();
        let _ = write!(
            body,
            r##"<rect x="10" y="{y}" width="{}" height="{h}" fill="none" stroke="#999"/><text x="16" y="{}" class="t">{}</text>"##,
            width - 20.0,
            y + 15.0,
            escape(name)
        );
        for (i, e) in parts.iter().enumerate() {
            let x = 10.0 + (i % PER_ROW) as f64 * CELL.0;
            let top = y + TITLE + heights[..i / PER_ROW].iter().sum::<f64>();
            body += &symbol(e, x, top, heights[i / PER_ROW]);
        }
        y += h + 10.0;
    }
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{}" viewBox="0 0 {width} {}" font-family="sans-serif" font-size="10"><style>.t{{font-weight:bold;font-size:12px}} .n{{fill:#05a}} .v{{fill:#555}} path,line,polygon,rect.s{{fill:none;stroke:#000;stroke-width:1.2}}</style><rect width="100%" height="100%" fill="#fff"/><text x="10" y="24" class="t">{}</text>{body}</svg>
"##,
        y,
        y,
        escape(&board.title)
    )
}

/// The height part `e` needs, px: a device's box grows with its pins.
fn height(e: &Element) -> f64 {
    match e.kind {
        Kind::Device(model) => {
            let (left, right) = sides(model, e.nodes.len());
            44.0 + PITCH * left.len().max(right.len()).max(1) as f64
        }
        _ => CELL.1,
    }
}

/// A device's pin: its node's index and its name.
type NamedPin = (usize, &'static str);

/// A device's pin spacing, px.
const PITCH: f64 = 11.0;

/// Device `model`'s pins (of `count`) split into the left side (its
/// sources, S…) and the right (the rest), each as (index, name).
fn sides(model: &str, count: usize) -> (Vec<NamedPin>, Vec<NamedPin>) {
    let names = crate::models::pins(model);
    (0..count)
        .map(|i| (i, names.get(i).copied().unwrap_or("")))
        .partition(|(_, n)| n.starts_with('S'))
}

/// Net `n` as its label reads ("GND" for node 0).
fn net(n: &str) -> &str {
    if n == "0" {
        "GND"
    } else {
        n
    }
}

/// Element `e`'s symbol in the cell at (x, y), `h` tall: its drawing,
/// its pins' stubs with their nets' labels, its reference and value.
fn symbol(e: &Element, x: f64, y: f64, h: f64) -> String {
    let (cx, cy) = (x + CELL.0 / 2.0, y + h / 2.0);
    let value = e.part.map_or("", |p| p.value);
    let mut s = format!(
        r#"<text x="{cx}" y="{}" text-anchor="middle">{}</text><text x="{cx}" y="{}" text-anchor="middle" class="v">{}</text>"#,
        y + 14.0,
        escape(&e.reference),
        y + h - 8.0,
        escape(value)
    );
    let pins = drawing(&mut s, e, cx, cy);
    for ((px, py, side), n) in pins.iter().zip(&e.nodes) {
        let (dx, anchor) = if *side == "l" {
            (-14.0, "end")
        } else {
            (14.0, "start")
        };
        let _ = write!(
            s,
            r#"<line x1="{px}" y1="{py}" x2="{}" y2="{py}"/><text x="{}" y="{}" text-anchor="{anchor}" class="n">{}</text>"#,
            px + dx,
            px + dx + dx.signum() * 2.0,
            py + 3.5,
            escape(net(n))
        );
    }
    s
}

/// A pin's end: (x, y, side: "l" or "r"), px.
type Pin = (f64, f64, &'static str);

/// Element `e`'s drawing centred on (cx, cy) into `s`; its pins' ends in
/// the order of its nodes.
fn drawing(s: &mut String, e: &Element, cx: f64, cy: f64) -> Vec<Pin> {
    match e.kind {
        Kind::Resistor => {
            let _ = write!(
                s,
                r#"<path d="M{} {cy} l5 -6 l10 12 l10 -12 l10 12 l10 -12 l5 6"/>"#,
                cx - 25.0
            );
            two(cx, cy, 25.0)
        }
        Kind::Capacitor => {
            let (x0, x1, y0, y1) = (cx - 4.0, cx + 4.0, cy - 12.0, cy + 12.0);
            let _ = write!(
                s,
                r#"<line x1="{x0}" y1="{y0}" x2="{x0}" y2="{y1}"/><line x1="{x1}" y1="{y0}" x2="{x1}" y2="{y1}"/>"#
            );
            two(cx, cy, 4.0)
        }
        Kind::OpAmp => opamp(s, cx, cy),
        Kind::Connector => connector(s, e.nodes.len(), cx, cy),
        Kind::Device(model) => device(s, model, e.nodes.len(), cx, cy),
        Kind::AdcPin => flag(s, "ADC", cx, cy),
        Kind::DacPin => flag(s, "DAC", cx, cy),
        Kind::GpioPin => flag(s, "GPIO", cx, cy),
    }
}

/// An op-amp's triangle: + and − on the left, the output on the right.
fn opamp(s: &mut String, cx: f64, cy: f64) -> Vec<Pin> {
    let (l, r, top, bottom) = (cx - 22.0, cx + 22.0, cy - 22.0, cy + 22.0);
    let _ = write!(
        s,
        r#"<polygon points="{l},{top} {l},{bottom} {r},{cy}"/><text x="{}" y="{}">+</text><text x="{}" y="{}">−</text>"#,
        l + 3.0,
        cy - 7.0,
        l + 3.0,
        cy + 15.0
    );
    vec![(l, cy - 10.0, "l"), (l, cy + 10.0, "l"), (r, cy, "r")]
}

/// A connector of `count` pins, numbered from 1, its pins on the right.
fn connector(s: &mut String, count: usize, cx: f64, cy: f64) -> Vec<Pin> {
    let top = cy - 8.0 * count as f64;
    let _ = write!(
        s,
        r#"<rect class="s" x="{}" y="{top}" width="24" height="{}"/>"#,
        cx - 12.0,
        16.0 * count as f64
    );
    (0..count)
        .map(|i| {
            let y = top + 8.0 + 16.0 * i as f64;
            let _ = write!(
                s,
                r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#,
                cx + 9.0,
                y + 3.5,
                i + 1
            );
            (cx + 12.0, y, "r")
        })
        .collect()
}

/// A pin of the Nucleo: a flag saying `what` it is (ADC, DAC, GPIO), its
/// one pin on the left.
fn flag(s: &mut String, what: &str, cx: f64, cy: f64) -> Vec<Pin> {
    let (l, r, tip, top, bottom) = (cx - 20.0, cx + 12.0, cx + 20.0, cy - 9.0, cy + 9.0);
    let _ = write!(
        s,
        r#"<polygon points="{l},{top} {r},{top} {tip},{cy} {r},{bottom} {l},{bottom}"/><text x="{}" y="{}" text-anchor="middle">{what}</text>"#,
        cx - 2.0,
        cy + 4.0
    );
    vec![(l, cy, "l")]
}

/// A device's box, its `count` pins named as its model names them
/// ([`crate::models::pins`]): its sources on the left, the rest on the
/// right, [`PITCH`] apart, in node order.
fn device(s: &mut String, model: &str, count: usize, cx: f64, cy: f64) -> Vec<Pin> {
    let (left, right) = sides(model, count);
    let rows = left.len().max(right.len()) as f64;
    let top = cy - PITCH * rows / 2.0;
    let _ = write!(
        s,
        r#"<rect class="s" x="{}" y="{top}" width="36" height="{}"/>"#,
        cx - 18.0,
        PITCH * rows
    );
    let mut pins = vec![(0.0, 0.0, "l"); count];
    for (side, list) in [("l", &left), ("r", &right)] {
        for (row, (i, name)) in list.iter().enumerate() {
            let (x, tx, anchor) = if side == "l" {
                (cx - 18.0, cx - 16.0, "start")
            } else {
                (cx + 18.0, cx + 16.0, "end")
            };
            let y = top + PITCH * (row as f64 + 0.5);
            let _ = write!(
                s,
                r#"<text x="{tx}" y="{}" text-anchor="{anchor}" font-size="7">{name}</text>"#,
                y + 2.5
            );
            pins[*i] = (x, y, side);
        }
    }
    pins
}

/// A two-pin part's pins, `half` either side of its centre.
fn two(cx: f64, cy: f64, half: f64) -> Vec<Pin> {
    vec![(cx - half, cy, "l"), (cx + half, cy, "r")]
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
