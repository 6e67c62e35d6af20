//! The dashboard's chart library comes from npm (`web/package.json`,
//! pinned by `web/package-lock.json`): installed here when missing, then
//! embedded into the binary, so the page loads nothing from the internet.

use std::path::Path;
use std::process::Command;

fn main() {
    let web = Path::new(env!("CARGO_MANIFEST_DIR")).join("web");
    let dist = web.join("node_modules/uplot/dist");
    println!("cargo:rerun-if-changed=web/package-lock.json");
    println!("cargo:rerun-if-changed=web/index.html");
    if !dist.join("uPlot.iife.min.js").is_file() {
        let st = Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund"])
            .current_dir(&web)
            .status();
        match st {
            Ok(s) if s.success() => {}
            Ok(s) => panic!("`npm ci` in {} failed ({s}): the dashboard's chart library (uPlot) comes from npm", web.display()),
            Err(e) => panic!("npm is needed to build live's dashboard (apt-get install -y npm, or `cargo xtask setup`): {e}"),
        }
    }
    println!("cargo:rustc-env=UPLOT_DIST={}", dist.display());
    println!(
        "cargo:rustc-env=UPLOT_LICENSE={}",
        web.join("node_modules/uplot/LICENSE").display()
    );
}
