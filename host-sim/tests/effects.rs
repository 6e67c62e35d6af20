//! Fitting a candidate effect to a data set with that effect hidden in it:
//! the parameter comes back, the residual falls to the noise, and the wrong
//! effect does not explain it.

use host_sim::dataset::read_dir;
use host_sim::effects::{fit, noise_floor, residual_rms, Effect};
use skin_sim::sensor::Effects;

fn set(dir: &std::path::Path, name: &str, fx: Effects) -> host_sim::dataset::DataSet {
    let d = dir.join(name);
    host_sim::experiments::dataset(
        &d,
        host_sim::experiments::with_effects(fx),
        host_sim::chain::Meter::LCR,
        11,
        indicatif::ProgressBar::hidden(),
    )
    .unwrap();
    read_dir(&d).unwrap()
}

#[test]
fn fitted_effects_recover_their_parameters_and_the_noise_floor() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "parasitic",
            Effects {
                parasitic_capacitance_farad: 8e-12,
                ..Default::default()
            },
            Effect::ParasiticCapacitance(0.0),
            50e-12,
            8e-12,
        ),
        (
            "contacts",
            Effects {
                contact_resistance_ohm: 25e3,
                ..Default::default()
            },
            Effect::ContactResistance(0.0),
            100e3,
            25e3,
        ),
    ];
    for (name, fx, right, max, truth) in cases {
        let ds = set(dir.path(), name, fx);
        let noise = noise_floor(&ds).unwrap();
        let before = residual_rms(&ds, Effect::None).unwrap();
        let (fitted, after) = fit(&ds, right, max).unwrap();
        let p = match fitted {
            Effect::ParasiticCapacitance(p) | Effect::ContactResistance(p) => p,
            Effect::None => unreachable!(),
        };
        println!("{name}: noise {noise:.3} pF, before {before:.3} pF, after {after:.3} pF, parameter {p:.4e} (true {truth:.4e})");
        assert!((p / truth - 1.0).abs() < 0.1, "{name}: {p} vs {truth}");
        assert!(after <= 1.5 * noise, "{name}: {after} vs noise {noise}");
        assert!(before >= 5.0 * after, "{name}: {before} → {after}");
        // The other effect cannot explain it down to the noise.
        let (wrong, wmax) = if name == "parasitic" {
            (Effect::ContactResistance(0.0), 100e3)
        } else {
            (Effect::ParasiticCapacitance(0.0), 50e-12)
        };
        let (_, w) = fit(&ds, wrong, wmax).unwrap();
        assert!(w > 2.0 * after, "{name}: wrong effect {w} vs right {after}");
    }
}
