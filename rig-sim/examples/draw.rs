use rand::SeedableRng;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let seed: u64 = a[1].parse().unwrap();
    let fam = rig_sim::Family::IN_LIBRARY.iter().find(|f| f.name() == a[2]).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5000 + seed);
    let (fx, m, v) = fam.draw(&mut rng);
    println!("{v} {:?} {:?}", fx.stretch_bump, fx.resistance_bump);
    rig_sim::Bench::new(fx, m, seed).write(std::path::Path::new(&a[3])).unwrap();
}
