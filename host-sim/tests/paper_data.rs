//! The founding paper's own measurements (`data/paper`, transcribed from
//! its text) through `identify`: the uniform line with the recorded
//! electrode resistances misses the static sweep by far more than the
//! paper's reporting precision; a fraction of each electrode's resistance
//! in its tab leads explains it, and nothing else in the library does.

use host_sim::dataset::read_dir;
use host_sim::identify::{identify, Options};
use std::path::PathBuf;

fn paper() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/paper/dataset")
}

#[test]
fn identify_names_tab_leads_on_the_papers_static_sweep() {
    let r = identify(&read_dir(&paper()).unwrap(), Options::default()).unwrap();
    let j = r.json();
    let noise = j["noise_floor_pf"].as_f64().unwrap();
    let before = j["baseline"]["rms_pf"].as_f64().unwrap();
    // The stated precisions: 2.9 pF for "~" values, 0.72 % of C for the
    // 6 kHz ratios.
    assert!((2.0..3.0).contains(&noise), "{noise}");
    assert!(before > 10.0 * noise, "baseline {before} pF");
    assert_eq!(j["unexplained"], false, "{}", r.markdown("data/paper", None));
    let e = &j["effects"][0];
    assert_eq!(e["id"], "lead_resistance", "{}", r.markdown("data/paper", None));
    let beta = e["params"]["lead_fraction"].as_f64().unwrap();
    let sigma = e["uncertainty"]["lead_fraction"].as_f64().unwrap();
    assert!((0.55..0.70).contains(&beta), "{beta}");
    assert!(sigma > 0.0 && sigma < 0.05, "{sigma}");
    // The simulated paper's sensor, and the firmware's line model on it,
    // carry this fit.
    let installed = skin_sim::sensor::SensorParams::PAPER
        .effects
        .get(instrument::effects::Effect::LeadResistance);
    assert!(
        (installed - beta).abs() < sigma,
        "{installed} vs {beta} ± {sigma}"
    );
    let after = j["final"]["rms_pf"].as_f64().unwrap();
    assert!(
        after <= 1.5 * noise && after * 10.0 < before,
        "{after} vs {before}"
    );
    // A fixed contact resistance is the runner-up: it cannot follow the
    // electrodes' 20–25 % drop at 30 mm.
    let contact = r
        .singles
        .iter()
        .find(|f| f.label() == "contact_resistance")
        .unwrap();
    assert!(contact.rms_pf > 1.5 * noise, "{}", contact.rms_pf);
}

/// Out of fit: the paper's dynamic numbers predicted from the effect
/// found on its static sweep. The 500 Hz undershoot comes out right; the
/// paper's own simulation, which puts the whole recorded resistance into
/// the line, would miss a sensor with tab leads by tens of percent, where
/// the paper reports 3–5 %: the contradiction the README names.
#[test]
fn the_papers_dynamic_numbers_are_predicted_out_of_fit() {
    let r = identify(&read_dir(&paper()).unwrap(), Options::default()).unwrap();
    let (md, out) = host_sim::experiments::predict_paper(&r.final_fit().params).unwrap();
    assert!(md.contains("Prediction out of fit"));
    let get = |id: &str| {
        out.iter()
            .find(|o| o.claim.id == id)
            .unwrap_or_else(|| panic!("{id}"))
    };
    // The numbers the dynamics were set from: reproduced within 10 %,
    // and not judged.
    for id in ["relaxed_2k_20", "undershoot_2k_10", "undershoot_2k_20"] {
        let o = get(id);
        assert!((o.deviation() / o.claim.value).abs() <= 0.1, "{id}: {}", o.sim);
        assert_eq!(o.verdict(), "set the dynamics");
    }
    assert!(get("undershoot_500_10").within());
    assert_eq!(get("undershoot_500_10").verdict(), "within");
    for (id, low) in [("sim_diff_2k", 10.0), ("sim_diff_6k", 20.0)] {
        let o = get(id);
        assert!(o.sim.is_finite() && o.sim > low && !o.within(), "{id}: {}", o.sim);
    }
}

/// Every mechanism `identify` tried, against all of the paper's printed
/// numbers at once: the baseline misses the 6 kHz static points, tab
/// leads fit every static point within its printed precision; each row
/// is judged on all six predictions, and a mechanism is consistent only
/// where no number excludes it.
#[test]
fn every_mechanism_is_set_against_every_printed_number() {
    let ds = read_dir(&paper()).unwrap();
    let r = identify(&ds, Options::default()).unwrap();
    let (md, rows) = host_sim::experiments::consistency(&ds, &r).unwrap();
    println!("{md}");
    assert_eq!(rows.len(), 1 + r.singles.len() + r.pairs.len());
    let base = &rows[0];
    assert!(base.label.starts_with("baseline"));
    assert!(
        base.statics_off
            .iter()
            .filter(|s| s.0.starts_with("6000 Hz"))
            .count()
            >= 3,
        "{:?}",
        base.statics_off
    );
    let leads = rows
        .iter()
        .find(|m| m.label == "lead_resistance")
        .expect("tab leads tried");
    assert!(leads.statics_off.is_empty(), "{:?}", leads.statics_off);
    assert_eq!(leads.static_points, 6);
    for m in &rows {
        assert_eq!(
            m.dynamics.iter().filter(|o| o.claim.predicted()).count(),
            6,
            "{}",
            m.label
        );
        assert_eq!(m.consistent(), m.excluded_by().is_empty());
        let (off, ex) = (m.statics_off.len(), m.excluded_by().len());
        assert!(ex >= off, "{}", m.label);
        assert!(md.contains(&format!("| {}", m.label)));
    }
}
