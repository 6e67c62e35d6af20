//! The files a lab builds from, generated from each board's circuit and
//! kept in the repository (`front-end/<board>/`): its netlist, its bill
//! of materials and its schematic. `tests/files.rs` holds them to the
//! circuit; `DOCS_UPDATE=1` rewrites them (`cargo xtask docs`).

use crate::circuit::Circuit;
use std::path::{Path, PathBuf};

/// The netlist's own analyses, for a lab that opens it in ngspice: the
/// operating point and the sensors' band.
const ANALYSES: &str = ".op\n.ac dec 20 100 100k";

/// Each file of `board`: (name, contents).
pub fn of(board: &Circuit) -> Result<Vec<(&'static str, String)>, String> {
    Ok(vec![
        ("board.cir", board.netlist(crate::spice::AC_STIMULUS, ANALYSES)),
        ("bom.csv", crate::bom::csv(board)?),
        ("schematic.svg", crate::schematic::svg(board)),
    ])
}

/// The folder that keeps board `name`'s files.
pub fn folder(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
}

/// Compare board `name`'s files in the repository with what its circuit
/// gives; with `update`, write them instead. Errors name each file that
/// differs.
pub fn check(name: &str, board: &Circuit, update: bool) -> Result<(), String> {
    let dir = folder(name);
    let mut stale = Vec::new();
    for (file, text) in of(board)? {
        let path = dir.join(file);
        if update {
            std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            stale.push(path.display().to_string());
        }
    }
    if stale.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "not what the circuit gives: {} (DOCS_UPDATE=1 cargo test -p front-end --test files rewrites them)",
            stale.join(", ")
        ))
    }
}
