use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rig_sim::{Bench, Family};

#[test]
#[ignore]
fn scratch() {
    let tmp = tempfile::tempdir().unwrap();
    let seed: u64 = std::env::var("SEED").unwrap().parse().unwrap();
    use rand::Rng;
    let mut rng =
        ChaCha8Rng::seed_from_u64(std::env::var("BASE").map_or(9000, |b| b.parse().unwrap()) + seed);
    let family = match std::env::var("FAMILY") {
        Ok(fam) => *Family::IN_LIBRARY
            .iter()
            .chain(&Family::OUTSIDE)
            .find(|x| x.name() == fam)
            .unwrap(),
        Err(_) => Family::IN_LIBRARY[rng.gen_range(0..Family::IN_LIBRARY.len())],
    };
    let fam = family.name();
    let (fx, meter, v) = family.draw(&mut rng);
    println!("{fam} {v:e} {meter:?}");
    let b = Bench::new(fx, meter, seed);
    b.write(tmp.path()).unwrap();
    if let Ok(d) = std::env::var("KEEP") {
        b.write(std::path::Path::new(&d)).unwrap();
    }
    let r = identify(&read_dir(tmp.path()).unwrap(), Options::default()).unwrap();
    println!("{}", r.verdict());
    for (i, f) in r.singles.iter().take(2).enumerate() {
        for (fe, res) in f.files.iter().zip(&f.residual) {
            println!(
                "single {i} {} rms {:.4} own-floor {:.4} base-floor {:.4}",
                fe.file,
                fe.rms_pf,
                host_sim::baseline::noise_sigma(res),
                r.noise_pf.iter().find(|x| x.0 == fe.file).map_or(0.0, |x| x.1)
            );
        }
    }
    for f in r.singles.iter().take(4).chain(r.pairs.iter().take(3)) {
        println!(
            "{} {} rms {:.4} nf {:.4} bic {:.1}",
            f.label(),
            host_sim::identify::params_text(f),
            f.rms_pf,
            r.noise_floor_pf,
            f.bic
        );
    }
}
