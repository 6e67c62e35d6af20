//! The bill of materials: every ordered part of a board, one line per
//! part number, written from the same circuit as its netlist.

use crate::circuit::Circuit;

/// The CSV's columns.
pub const HEADER: [&str; 8] = [
    "references",
    "quantity",
    "value",
    "tolerance",
    "package",
    "manufacturer",
    "part number",
    "function",
];

/// The bill of materials of `board` as CSV: one row per part number in
/// the order the board first uses it; its references, how many, and
/// what they do (each function once).
pub fn csv(board: &Circuit) -> Result<String, String> {
    let mut groups: Vec<(crate::parts::Part, Vec<&str>, Vec<&str>)> = Vec::new();
    for e in &board.elements {
        let Some(part) = e.part else { continue };
        let i = match groups.iter().position(|(p, ..)| p.number == part.number) {
            Some(i) => i,
            None => {
                groups.push((part, Vec::new(), Vec::new()));
                groups.len() - 1
            }
        };
        let (_, refs, functions) = &mut groups[i];
        refs.push(&e.reference);
        if !functions.contains(&e.function.as_str()) {
            functions.push(&e.function);
        }
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(HEADER).map_err(|e| e.to_string())?;
    for (p, refs, functions) in &groups {
        let row = [
            refs.join(" "),
            refs.len().to_string(),
            p.value.to_string(),
            p.tolerance.to_string(),
            p.package.to_string(),
            p.manufacturer.to_string(),
            p.number.to_string(),
            summarise(functions),
        ];
        w.write_record(&row).map_err(|e| e.to_string())?;
    }
    String::from_utf8(w.into_inner().map_err(|e| e.to_string())?).map_err(|e| e.to_string())
}

/// A group's functions: those of several elements alike by their kind
/// (the text after "what: ") with how many ("feedback ×17"), the others
/// whole.
fn summarise(functions: &[&str]) -> String {
    let kind = |f: &str| f.rsplit(": ").next().unwrap_or(f).to_string();
    let mut out: Vec<(String, usize)> = Vec::new();
    for f in functions {
        let k = kind(f);
        let n = functions.iter().filter(|g| kind(g) == k).count();
        let text = if n > 1 { k } else { f.to_string() };
        if !out.iter().any(|(t, _)| *t == text) {
            out.push((text, n));
        }
    }
    let one = |(t, n): &(String, usize)| if *n > 1 { format!("{t} ×{n}") } else { t.clone() };
    out.iter().map(one).collect::<Vec<_>>().join("; ")
}
