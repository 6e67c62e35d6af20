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
    let mut body = body.to_string();
    if !body.ends_with('\n') {
        body.push('\n');
    }
    let _guard = LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let path = root().join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{file}: {e}"))?;
    let at = find(&text, name).map_err(|e| format!("{file}: {e}"))?;
    if text[at.clone()] == body {
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
