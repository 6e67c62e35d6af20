//! Picks each binary's memory layout: the STM32G474 boards' (`../memory.x`,
//! the per-block code in CCM SRAM) or QEMU's lm3s6965evb's
//! (`memory-qemu.x`, the per-block code left in flash). Links with
//! cortex-m-rt's `link.x` and the per-block code's section (`hot-ram.x`)
//! for binaries only, so host builds stay clean.

use std::{env, fs, path::PathBuf};

/// Each binary and its memory file.
const LAYOUTS: [(&str, &str); 5] = [
    ("skin-board", "../memory.x"),
    ("skin-array-board", "../memory.x"),
    ("skin-qemu", "memory-qemu.x"),
    ("skin-array", "memory-qemu.x"),
    ("dsp-bench", "memory-qemu.x"),
];

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());
    // link.x includes `memory.x`, found in the first folder that has one
    // (the device crates' own come after this one): it includes the
    // binary's layout, `layout.x`, from a folder only that binary
    // searches.
    fs::write(out.join("memory.x"), "INCLUDE layout.x\n").unwrap();
    fs::copy("hot-ram.x", out.join("hot-ram.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=hot-ram.x");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    for (bin, src) in LAYOUTS {
        let dir = out.join(bin);
        fs::create_dir_all(&dir).unwrap();
        fs::copy(src, dir.join("layout.x")).unwrap();
        println!("cargo:rerun-if-changed={src}");
        println!("cargo:rustc-link-arg-bin={bin}=-L{}", dir.display());
    }
    // First: its patterns must take their sections before link.x's
    // `.text` takes every `.text.*`.
    println!("cargo:rustc-link-arg-bins=-Thot-ram.x");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
