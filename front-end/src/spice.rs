//! ngspice in batch mode on a board's netlist: AC transfers, noise
//! spectra and transients, read back from its `wrdata` files.

use crate::circuit::Circuit;
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// The DAC's stimulus for a small-signal analysis: the bias, and 1 V AC.
pub const AC_STIMULUS: &str = "DC 1.65 AC 1";

/// Run ngspice on the netlist `text(dir)` writes (its `wrdata` files in
/// `dir`), and hand `read` that folder. Errors name what failed: ngspice
/// missing (and how to install it), its exit status and its messages.
pub fn run<T>(
    text: impl FnOnce(&Path) -> String,
    read: impl FnOnce(&Path) -> Result<T, String>,
) -> Result<T, String> {
    let dir = tempfile::tempdir().map_err(|e| format!("a temporary folder: {e}"))?;
    let cir = dir.path().join("board.cir");
    std::fs::write(&cir, text(dir.path())).map_err(|e| format!("{}: {e}", cir.display()))?;
    let out = Command::new("ngspice").arg("-b").arg(&cir).output().map_err(|e| {
        format!("ngspice did not start ({e}): `cargo xtask setup` (or apt-get install -y ngspice) installs it")
    })?;
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if !out.status.success() || log.contains("Error") || log.contains("error:") {
        // Its messages, not the netlist lines it echoes with them.
        let said: Vec<&str> = log.lines().filter(|l| l.len() < 300).collect();
        return Err(format!(
            "ngspice on {}: {}\n{}",
            cir.display(),
            out.status,
            said.join("\n")
        ));
    }
    read(dir.path())
}

/// The numbers of a `wrdata` file, a row a line.
fn rows(path: &Path) -> Result<Vec<Vec<f64>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.split_whitespace()
                .map(|v| {
                    v.parse::<f64>()
                        .map_err(|e| format!("{}:{}: {v}: {e}", path.display(), i + 1))
                })
                .collect()
        })
        .collect()
}

/// The AC values of `vectors` (`v(PA0)`, `i(VJ1_i)`) at each of
/// `freqs_hz`, the DAC driven by `stimulus` (the board's sensors as it
/// carries them; `extra`: more lines, such as a source of its own).
pub fn ac(
    board: &Circuit,
    stimulus: &str,
    extra: &str,
    vectors: &[&str],
    freqs_hz: &[f64],
) -> Result<Vec<Vec<Complex64>>, String> {
    let nodes = vectors;
    let text = |dir: &Path| {
        let mut c = format!("{extra}\n.control\nset wr_singlescale\nset numdgt=12\nset appendwrite\n");
        for f in freqs_hz {
            let _ = writeln!(
                c,
                "ac lin 1 {f:e} {f:e}\nwrdata {} {}",
                dir.join("ac.txt").display(),
                vectors.join(" ")
            );
        }
        c += "quit\n.endc";
        board.netlist(stimulus, &c)
    };
    run(text, |dir| {
        let rows = rows(&dir.join("ac.txt"))?;
        if rows.len() != freqs_hz.len() {
            return Err(format!(
                "ngspice wrote {} rows for {} frequencies",
                rows.len(),
                freqs_hz.len()
            ));
        }
        rows.iter()
            .map(|r| {
                (r.len() == 1 + 2 * nodes.len())
                    .then(|| {
                        (0..nodes.len())
                            .map(|k| Complex64::new(r[1 + 2 * k], r[2 + 2 * k]))
                            .collect()
                    })
                    .ok_or_else(|| format!("a row of {} numbers for {} nodes", r.len(), nodes.len()))
            })
            .collect()
    })
}

/// The noise spectral density at `node`, V/√Hz, from `from_hz` to
/// `to_hz` at `per_decade` points: (Hz, V/√Hz) rows.
pub fn noise(
    board: &Circuit,
    node: &str,
    from_hz: f64,
    to_hz: f64,
    per_decade: u32,
) -> Result<Vec<(f64, f64)>, String> {
    let text = |dir: &Path| {
        let c = format!(
            ".control\nset wr_singlescale\nset numdgt=12\nnoise v({node}) VDAC_{} dec {per_decade} {from_hz:e} {to_hz:e}\nsetplot noise1\nwrdata {} onoise_spectrum\nquit\n.endc",
            crate::array::DAC_PIN,
            dir.join("noise.txt").display()
        );
        board.netlist(AC_STIMULUS, &c)
    };
    run(text, |dir| {
        rows(&dir.join("noise.txt"))?
            .iter()
            .map(|r| {
                (r.len() == 2)
                    .then(|| (r[0], r[1]))
                    .ok_or_else(|| format!("a noise row of {} numbers", r.len()))
            })
            .collect()
    })
}

/// A transient of `stop_s` (steps of at most a quarter of `step_s`), the DAC playing
/// `stimulus` (`extra`: more lines, such as a source of its own): each
/// of `nodes` sampled every `step_s` from `from_s`, a row per instant
/// (time first).
pub fn tran(
    board: &Circuit,
    stimulus: &str,
    extra: &str,
    nodes: &[&str],
    step_s: f64,
    from_s: f64,
    stop_s: f64,
) -> Result<Vec<Vec<f64>>, String> {
    let vectors: Vec<String> = nodes.iter().map(|n| format!("v({n})")).collect();
    let text = |dir: &Path| {
        let c = format!(
            "{extra}\n.control\nset wr_singlescale\nset numdgt=12\noption reltol=1e-5\ntran {step_s:e} {stop_s:e} {from_s:e} {:e}\nlinearize\nwrdata {} {}\nquit\n.endc",
            step_s / 4.0,
            dir.join("tran.txt").display(),
            vectors.join(" ")
        );
        board.netlist(stimulus, &c)
    };
    run(text, |dir| rows(&dir.join("tran.txt")))
}
