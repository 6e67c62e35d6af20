//! `identify` on data from `rig-sim`, a generator written apart from
//! `skin-sim` (its own line discretisation, film dynamics, meter, noise
//! and effect shapes): one hidden effect per set, drawn over its physical
//! range.

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options, Report};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rig_sim::{Bench, Family};
use std::path::Path;

fn run(dir: &Path, bench: &Bench) -> Report {
    bench.write(dir).unwrap();
    identify(&read_dir(dir).unwrap(), Options::default()).unwrap()
}

fn named(r: &Report) -> Vec<&'static str> {
    r.accepted
        .iter()
        .flat_map(|a| a.effects.iter().map(|e| e.id()))
        .collect()
}

#[test]
#[ignore]
fn explore() {
    let tmp = tempfile::tempdir().unwrap();
    let n: u64 = std::env::var("SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let fam: Option<String> = std::env::var("FAMILY").ok();
    for seed in 0..n {
        let mut rng = ChaCha8Rng::seed_from_u64(5000 + seed);
        let lib = Family::IN_LIBRARY;
        let mut family = lib[rng.gen_range(0..lib.len())];
        if let Some(f) = &fam {
            family = *lib
                .iter()
                .chain(&Family::OUTSIDE)
                .find(|x| x.name() == f)
                .unwrap();
        }
        let (fx, meter, v) = family.draw(&mut rng);
        let b = Bench::new(fx, meter, seed);
        let t = std::time::Instant::now();
        let r = run(&tmp.path().join(format!("s{seed}")), &b);
        let nf = r.noise_floor_pf;
        let (base, fin) = (r.baseline().rms_pf, r.final_fit().rms_pf);
        let best = r.singles.first().map(|f| f.label()).unwrap_or_default();
        println!(
            "| {seed} | {} | {v:.4e} | {:.1} | {} | {:.2} | {:.1} | best {best} | {:.1}s | floor {nf:.4}",
            family.name(),
            base / nf,
            if r.unexplained {
                "UNEXPLAINED".to_string()
            } else {
                named(&r).join("+")
            },
            fin / nf,
            base / fin,
            t.elapsed().as_secs_f64()
        );
    }
}
