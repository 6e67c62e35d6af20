//! Cross-check of the fixed-point 30-element ladder against ngspice's AC
//! analysis of the full two-electrode circuit (separate top and bottom
//! resistors, as in the paper's Figure 5), which also checks that adding
//! both electrodes' resistance into one series R is exact.
//!
//! Needs `ngspice` (Debian package `ngspice`; `cargo xtask test` installs
//! it). Without it the test fails and says how to install it: a check
//! that was not run never passes.

use dsp_core::tline::LineModel;
use std::fmt::Write as _;
use std::process::Command;

const N: usize = 30;
const R_TOP: f64 = 350e3;
const R_BOTTOM: f64 = 362e3;
const C: f64 = 210e-12;

fn netlist(out: &std::path::Path) -> String {
    let mut s =
        String::from("* DE sensor read from one end: 30 elements, both electrodes\nV1 in 0 DC 0 AC 1\n");
    let (mut t, mut b) = ("in".to_string(), "0".to_string());
    for k in 1..=N {
        writeln!(s, "Rt{k} {t} t{k} {}", R_TOP / N as f64).unwrap();
        writeln!(s, "Rb{k} {b} b{k} {}", R_BOTTOM / N as f64).unwrap();
        writeln!(s, "C{k} t{k} b{k} {}", C / N as f64).unwrap();
        (t, b) = (format!("t{k}"), format!("b{k}"));
    }
    writeln!(
        s,
        ".control\nac dec 10 100 50k\nwrdata {} i(v1)\nquit\n.endc\n.end",
        out.display()
    )
    .unwrap();
    s
}

#[test]
fn ladder_30_matches_ngspice_ac() {
    assert!(
        Command::new("ngspice").arg("--version").output().is_ok(),
        "ngspice is not installed: `cargo xtask setup` (or apt-get install -y ngspice) installs it"
    );
    let dir = tempfile::tempdir().unwrap();
    let (cir, data) = (dir.path().join("ladder.cir"), dir.path().join("ac.txt"));
    std::fs::write(&cir, netlist(&data)).unwrap();
    let out = Command::new("ngspice").arg("-b").arg(&cir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&data).unwrap();
    let mut worst = 0f64;
    let mut rows = 0;
    println!(
        "{:>10} {:>14} {:>14} {:>10}",
        "f [Hz]", "|Z| spice [Ω]", "|Z| dsp [Ω]", "rel. diff"
    );
    for line in text.lines() {
        let v: Vec<f64> = line.split_whitespace().map(|x| x.parse().unwrap()).collect();
        let (f, i) = (v[0], num_complex::Complex64::new(v[1], v[2]));
        let z_spice = -1.0 / i; // SPICE current flows into the source's + node
        let z = LineModel::Ladder(N as u8)
            .impedance((R_TOP + R_BOTTOM) as f32, C as f32, f as f32)
            .unwrap();
        let z = num_complex::Complex64::new(z.re as f64, z.im as f64);
        let e = (z - z_spice).norm() / z_spice.norm();
        println!("{f:>10.1} {:>14.1} {:>14.1} {e:>10.2e}", z_spice.norm(), z.norm());
        worst = worst.max(e);
        rows += 1;
    }
    println!(
        "30-element ladder vs ngspice, {rows} frequencies 100 Hz-50 kHz: max relative difference {worst:.2e}"
    );
    assert!(rows >= 25, "ngspice wrote {rows} rows");
    assert!(worst < 1e-4, "max relative difference {worst:e}");
}
