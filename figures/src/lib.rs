//! Generated figures in the README and `docs/`.
//!
//! A figure block is the text between two marker lines of a Markdown
//! file:
//!
//! ```text
//! <!-- figures:NAME (generated: cargo xtask docs) -->
//! …
//! <!-- /figures:NAME -->
//! ```
//!
//! The test that measures a figure builds the block's text from what it
//! measured and calls [`check`]: the test fails when the file says
//! anything else. With `DOCS_UPDATE=1` in the environment (`cargo xtask
//! docs` sets it) [`check`] writes the measured text into the file
//! instead. So no figure in the docs is copied by hand, and none goes
//! stale without a test failing.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The environment variable that makes [`check`] rewrite blocks.
pub const UPDATE_VAR: &str = "DOCS_UPDATE";

/// Serialises the read-modify-write of files between the threads of one
/// test binary (cargo runs the binaries one after another).
static LOCK: Mutex<()> = Mutex::new(());

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// The opening marker line of block `name`.
pub fn open_marker(name: &str) -> String {
    format!("<!-- figures:{name} (generated: cargo xtask docs) -->")
}

/// The closing marker line of block `name`.
pub fn close_marker(name: &str) -> String {
    format!("<!-- /figures:{name} -->")
}

/// Where block `name` stands in `text`: the byte range of its body (the
/// lines between the markers, each line with its newline).
pub fn find(text: &str, name: &str) -> Result<std::ops::Range<usize>, String> {
    let open = open_marker(name);
    let close = close_marker(name);
    let start = match text.match_indices(&open).map(|(i, _)| i).collect::<Vec<_>>()[..] {
        [i] => i + open.len(),
        [] => return Err(format!("no line '{open}'")),
        _ => return Err(format!("'{open}' stands more than once")),
    };
    let start = start + text[start..].find('\n').map_or(0, |i| i + 1);
    let end = text[start..]
        .find(&close)
        .map(|i| start + i)
        .ok_or_else(|| format!("no '{close}' after '{open}'"))?;
    Ok(start..end)
}

/// The body of block `name` in `file` (relative to the repository root).
pub fn read(file: &str, name: &str) -> Result<String, String> {
    let path = root().join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{file}: {e}"))?;
    let at = find(&text, name).map_err(|e| format!("{file}: {e}"))?;
    Ok(text[at].to_string())
}

/// Check block `name` of `file` (relative to the repository root)
/// against `body`, the text the caller measured; with [`UPDATE_VAR`] set
/// to `1`, write `body` there instead. A trailing newline is added to
/// `body` where it lacks one.
pub fn check(file: &str, name: &str, body: &str) -> Result<(), String> {
    check_within(file, name, body, 0.0)
}

/// [`check`], but a number of the block may differ from the measured one
/// by up to `rel` of it, or by one unit of its last printed digit,
/// where all the text around the numbers is the same. Within that the
/// file is left as it stands, even under [`UPDATE_VAR`]. For figures a
/// build may move by a little without a change of the code: the
/// firmware's machine code depends on the checkout's folder, because
/// cargo hashes a path dependency outside the firmware's workspace
/// (dsp-core, instrument, link) by its absolute path, and the symbol
/// hashes order the code LLVM optimizes (builds of one commit in two
/// folders differ in their inlining); counts 0.2 % apart have been
/// seen between builds of one commit.
pub fn check_within(file: &str, name: &str, body: &str, rel: f64) -> Result<(), String> {
    let mut body = body.to_string();
    if !body.ends_with('\n') {
        body.push('\n');
    }
    let _guard = LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let path = root().join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{file}: {e}"))?;
    let at = find(&text, name).map_err(|e| format!("{file}: {e}"))?;
    if text[at.clone()] == body || (rel > 0.0 && close_enough(&text[at.clone()], &body, rel)) {
        return Ok(());
    }
    if std::env::var(UPDATE_VAR).as_deref() == Ok("1") {
        let new = format!("{}{}{}", &text[..at.start], body, &text[at.end..]);
        let tmp = path.with_extension("md.tmp");
        std::fs::write(&tmp, new).map_err(|e| format!("{}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &path).map_err(|e| format!("{file}: {e}"))?;
        eprintln!("{file}: figures:{name} updated");
        return Ok(());
    }
    Err(format!(
        "{file}: the figures of block '{name}' differ from what the code measures now.\n\
         In the file:\n{}\nMeasured:\n{body}\n\
         Run `cargo xtask docs` to write the measured figures into the docs.",
        &text[at]
    ))
}

/// Whether `a` and `b` are the same text but for numbers (runs of digits
/// and points), each pair within `rel` of the larger or one unit of the
/// last digit `a` prints.
pub fn close_enough(a: &str, b: &str, rel: f64) -> bool {
    let (x, y) = (split_numbers(a), split_numbers(b));
    x.len() == y.len()
        && x.iter().zip(&y).all(|(p, q)| match (p, q) {
            (Piece::Text(p), Piece::Text(q)) => p == q,
            (Piece::Number(p), Piece::Number(q)) => {
                let (Ok(u), Ok(v)) = (p.parse::<f64>(), q.parse::<f64>()) else {
                    return p == q;
                };
                let unit = p
                    .find('.')
                    .map_or(1.0, |i| 10f64.powi(-((p.len() - i - 1) as i32)));
                (u - v).abs() <= (rel * u.abs().max(v.abs())).max(unit * (1.0 + 1e-9))
            }
            _ => false,
        })
}

/// A piece of a figure block's text.
#[derive(Debug, PartialEq)]
enum Piece<'a> {
    Text(&'a str),
    Number(&'a str),
}

/// `s` cut into runs of digits (with their points) and the text between.
fn split_numbers(s: &str) -> Vec<Piece<'_>> {
    let mut out = vec![];
    let mut start = 0;
    let mut in_number = false;
    for (i, c) in s.char_indices() {
        let digit = c.is_ascii_digit() || (in_number && c == '.');
        if digit != in_number && i > start {
            out.push(if in_number {
                Piece::Number(&s[start..i])
            } else {
                Piece::Text(&s[start..i])
            });
            start = i;
        }
        in_number = digit;
    }
    if start < s.len() {
        out.push(if in_number {
            Piece::Number(&s[start..])
        } else {
            Piece::Text(&s[start..])
        });
    }
    out
}

/// The header every headline table of figures starts with.
pub const TABLE_HEADER: &str = "| figure | value |\n|---|---|\n";

/// A table of figures: [`TABLE_HEADER`], then a row per (figure, value).
pub fn table(rows: &[(String, String)]) -> String {
    let mut md = TABLE_HEADER.to_string();
    for (figure, value) in rows {
        md += &format!("| {figure} | {value} |\n");
    }
    md
}

/// Check (or rewrite, as [`check`] does) block `name` of `file` as one
/// table: [`TABLE_HEADER`], then the rows of each table in `sources`
/// ((file, block) pairs, each checked by the test that measures it), in
/// order. So the README's one table of headline figures is made of rows
/// the tests hold.
pub fn assemble(file: &str, name: &str, sources: &[(&str, &str)]) -> Result<(), String> {
    let mut body = TABLE_HEADER.to_string();
    for (src, block) in sources {
        let text = read(src, block)?;
        let rows = text
            .strip_prefix(TABLE_HEADER)
            .ok_or_else(|| format!("{src}: block '{block}' is not a table of figures"))?;
        body += rows;
    }
    check(file, name, &body)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_within_the_tolerance_are_close_enough() {
        let a = "| `array_channel` | one record | 7191 insn/record |\n| load | 29.2 % |\n";
        // 0.18 % and one unit of the last digit.
        let b = "| `array_channel` | one record | 7204 insn/record |\n| load | 29.3 % |\n";
        assert!(close_enough(a, b, 0.005));
        assert!(!close_enough(a, b, 0.001), "7191 against 7204 is 0.18 %");
        // One unit of the last digit, beyond the relative tolerance.
        assert!(close_enough("9.0 %", "9.1 %", 0.005));
        assert!(!close_enough("9.0 %", "9.2 %", 0.005));
        // A number that ends a sentence: its point is read with it.
        assert!(close_enough("took 40.", "took 41.", 0.0));
        assert!(!close_enough("took 40.", "took 42.", 0.0));
        // The text around the numbers must be the same.
        assert!(!close_enough("7191 insn/record", "7191 insn/block", 0.5));
        assert!(!close_enough("7191 insn", "7191 insn 3", 0.5));
        assert!(
            !close_enough("v1.2.3", "v1.2.4", 0.5),
            "not a number: the same text only"
        );
        assert_eq!(
            split_numbers("a 1.5 b."),
            vec![Piece::Text("a "), Piece::Number("1.5"), Piece::Text(" b.")]
        );
    }

    #[test]
    fn finds_the_body_between_the_markers() {
        let t = format!("a\n{}\nx\ny\n{}\nb\n", open_marker("n"), close_marker("n"));
        assert_eq!(&t[find(&t, "n").unwrap()], "x\ny\n");
        let empty = format!("{}\n{}\n", open_marker("e"), close_marker("e"));
        assert_eq!(&empty[find(&empty, "e").unwrap()], "");
    }

    #[test]
    fn a_missing_or_doubled_block_is_an_error() {
        assert!(find("nothing here", "n").unwrap_err().contains("no line"));
        let open_only = format!("{}\nx\n", open_marker("n"));
        assert!(find(&open_only, "n").unwrap_err().contains("no '<!-- /figures:n"));
        let twice = format!("{0}\n{1}\n{0}\n{1}\n", open_marker("n"), close_marker("n"));
        assert!(find(&twice, "n").unwrap_err().contains("more than once"));
    }
}
