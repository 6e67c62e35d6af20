//! The paper's experiments on the simulated skin: the effects the paper
//! reports must appear (and only where it reports them), and the line
//! correction must remove them.

use host_sim::experiments::{self as exp, Ctx};

fn ctx(dir: &tempfile::TempDir) -> Ctx {
    let mut c = Ctx::new(dir.path(), 3).unwrap();
    c.periods = 1;
    c
}

#[test]
fn undershoot_at_2_and_6_khz_not_at_500_hz_and_correction_removes_it() {
    let dir = tempfile::tempdir().unwrap();
    let c = ctx(&dir);
    let (_, acc) = exp::accuracy(&c).unwrap();
    assert_eq!(acc.len(), 3);
    let [f500, f2k, f6k] = [&acc[0], &acc[1], &acc[2]];
    // [rms pF, max pF, rms %, max %, undershoot pF]
    // The lumped meter: no visible undershoot at 500 Hz (< 1 % of C),
    // clear ones at 2 and 6 kHz, and ≥ 10 % RMS error at 6 kHz. The chain
    // runs the firmware's frequency set, whose lowest is 586 Hz: the lumped
    // error grows as x² = (ωRC)² there, so the 500 Hz bound scales by
    // (f / 500 Hz)².
    let low = 2.1 * (f500.freq_hz / 500.0).powi(2);
    assert!(
        f500.lumped[4] < low,
        "{} Hz undershoot {:?}",
        f500.freq_hz,
        f500.lumped
    );
    assert!(f2k.lumped[4] > 10.0, "2 kHz undershoot {:?}", f2k.lumped);
    assert!(f6k.lumped[4] > 20.0, "6 kHz undershoot {:?}", f6k.lumped);
    assert!(f6k.lumped[2] >= 10.0, "{:?}", f6k.lumped);
    // The line-corrected reading stays on the truth: ≤ 0.5 % RMS, no
    // undershoot, and every valid record within the channel's tolerance
    // (0.8 %) plus the truth's own change over a block.
    for a in &acc {
        assert!(a.corrected[2] <= 0.5, "{a:?}");
        assert!(a.corrected[3] <= 1.0, "{a:?}");
        // No dip beyond the noise: < 1 pF where the line is well
        // conditioned; pinned at 5859 Hz the resistance peak reaches
        // x = ωRC ≈ 12, where the inversion amplifies a 5.12 ms block's
        // noise several-fold (why the firmware's policy steps down there),
        // so the bound is 1 % of C.
        let dip = if a.freq_hz > 5e3 { 2.1 } else { 1.0 };
        assert!(a.corrected[4] < dip, "{a:?}");
        // Hardly any rejected readings where the line is well conditioned;
        // pinned at 5859 Hz, the readings near the resistance peak are
        // flagged UNCERTAIN (the bound on their error passes 0.8 %; the
        // lock-in's window passes √2 times the bare tone's noise), the
        // rest are kept.
        let rejected = if a.freq_hz > 5e3 { 45 } else { 1 };
        assert!(a.corrected_missing * 100 <= rejected * a.readings, "{a:?}");
    }
    assert!(f500.corrected[2] < 0.1 && f2k.corrected[2] < 0.1, "{acc:?}");
    for f in ["500", "2000", "6000"] {
        assert!(dir.path().join(format!("adc_20mmps_{f}hz.csv")).is_file());
    }
    assert!(dir.path().join("accuracy_20mmps.svg").is_file());
}

#[test]
fn paper_runs_everything_and_writes_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let c = ctx(&dir);
    let (md, _) = exp::paper(&c).unwrap();
    for name in [
        "summary.md",
        "sweep.csv",
        "calibration.csv",
        "resistance_settling.csv",
        "resistance_10mmps.csv",
        "resistance_20mmps.csv",
        "trace_10mmps_500hz.csv",
        "trace_20mmps_6000hz.csv",
        "fig7_sweep.svg",
        "fig8_9_resistance.svg",
        "fig10_capacitance.svg",
        "fig13_14_elements.svg",
        "accuracy_20mmps.svg",
    ] {
        let p = dir.path().join(name);
        assert!(
            p.is_file() && std::fs::metadata(&p).unwrap().len() > 100,
            "{name}"
        );
    }
    for section in ["Fig. 7", "Fig. 8", "Fig. 10", "Fig. 13", "20 mm/s trapezoid"] {
        assert!(md.contains(section), "{section}");
    }
    // Fig. 7: the lumped capacitance falls with frequency at every stretch.
    let sweep = std::fs::read_to_string(dir.path().join("sweep.csv")).unwrap();
    let rows: Vec<Vec<f64>> = sweep
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    for s in [0.0, 15.0, 30.0] {
        let cs: Vec<f64> = rows.iter().filter(|r| r[0] == s).map(|r| r[2]).collect();
        assert!(
            cs.len() > 10 && cs.windows(2).all(|w| w[1] < w[0] + 0.1),
            "{s}: {cs:?}"
        );
        assert!(cs[cs.len() - 1] < 0.8 * cs[0]);
    }
}

#[test]
fn elements_converge_to_the_measurement() {
    let dir = tempfile::tempdir().unwrap();
    let c = ctx(&dir);
    let (_, runs) = exp::capacitance(&c).unwrap();
    let md = exp::elements(&c, &runs, &exp::calibration(&c).unwrap()).unwrap();
    // RMS sim − meas for n = 1, 2, 4, 30 must fall with n (Fig. 13).
    let rms: Vec<f64> = md
        .lines()
        .filter(|l| {
            l.starts_with("| 1 |")
                || l.starts_with("| 2 |")
                || l.starts_with("| 4 |")
                || l.starts_with("| 30 |")
        })
        .map(|l| {
            l.split('|')
                .nth(2)
                .unwrap()
                .trim()
                .trim_end_matches(" pF")
                .parse()
                .unwrap()
        })
        .collect();
    assert_eq!(rms.len(), 4, "{md}");
    assert!(rms.windows(2).all(|w| w[1] < w[0]), "{rms:?}");
    assert!(rms[3] < 1.0, "{rms:?}");
}

/// The simulated paper's sensor (`SensorParams::PAPER`) against every
/// number of the paper's text: only the predictions are judged (within
/// the printed precision, or off); the inputs and fitted numbers are
/// reproduced to their printed precision and the dynamic ones the
/// dynamics were set from within 10 %, but never called "within".
#[test]
fn the_papers_sensor_holds_every_static_number_of_the_text() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = ctx(&dir);
    c.sensor = skin_sim::sensor::SensorParams::PAPER;
    let claims = exp::parse_claims(exp::CLAIMS_CSV).unwrap();
    let runs = exp::lcr_runs(&c);
    let cal = exp::calibration(&c).unwrap();
    let out = exp::compare(&c, &claims, &runs, &cal).unwrap();
    let table = exp::table(&out);
    println!("{table}");
    let modelled = claims
        .iter()
        .filter(|c| c.role != "geometry" && c.role != "setup")
        .count();
    assert_eq!(out.len(), modelled);
    for o in &out {
        let c = &o.claim;
        assert!(o.sim.is_finite(), "{}", c.id);
        let row = table
            .lines()
            .find(|l| l.starts_with(&format!("| {} |", c.id)))
            .unwrap_or_else(|| panic!("{}", c.id));
        let judged = row.ends_with("| within |") || row.ends_with("| **off** |");
        assert_eq!(judged, c.role == "predict", "{row}");
        match c.role.as_str() {
            "fit" | "input" => assert!(
                o.within(),
                "{}: paper {} vs simulation {} (tolerance {})",
                c.id,
                c.value,
                o.sim,
                c.tolerance()
            ),
            "dynamic" => assert!(
                o.deviation().abs() <= 0.1 * c.value.abs(),
                "{}: paper {} vs simulation {}",
                c.id,
                c.value,
                o.sim
            ),
            "predict" => {}
            r => panic!("{}: unknown use {r}", c.id),
        }
    }
    // Tolerances are the printed precision: ±5.0 pF on the relaxed
    // 180 pF (a 20 % band, ±36 pF, would test nothing).
    let relaxed = out.iter().find(|o| o.claim.id == "relaxed_2k_20").unwrap();
    assert!((relaxed.claim.tolerance() - 5.02).abs() < 0.01);
    // The predictions the model misses are named.
    let missed = exp::misses(&out);
    assert!(
        table.contains(&format!("the model misses {}.", missed.join(", "))),
        "{table}"
    );
    // Fig. 13's order: the paper's simulation nearer the measurement as
    // n grows, and 60 elements no better than 30.
    let fig13 = out.iter().find(|o| o.claim.id == "fig13_order").unwrap();
    let meas = &runs
        .iter()
        .find(|r| r.rate == 10.0 && r.freq_hz == 6000.0)
        .unwrap()
        .readings;
    let (holds, rms) = exp::fig13_order(meas, &cal);
    assert_eq!(fig13.sim, holds);
    println!("Fig. 13 RMS by n: {rms:?}");
    assert!(out.iter().any(|o| o.claim.id == "undershoot_500_20"));
    // Every parameter of the paper's sensor says how it is known: the
    // tab leads assumed.
    let prov = exp::provenance(&c.sensor);
    let leads = prov.iter().find(|p| p.0.starts_with("tab leads")).unwrap();
    assert_eq!(leads.2, exp::Known::Assumed);
    assert!(exp::provenance_table(&c.sensor).contains("| 0.6415 | **assumed** |"));
    // The static ratios are held to the printed precision (±1.25 %).
    let sweep = out.iter().filter(|o| o.claim.id.starts_with("sweep_6k")).count();
    assert_eq!(sweep, 3);
    // The reference sensor is not the paper's: its 6 kHz ratios are off
    // by tens of percent.
    let rc = ctx(&dir);
    let reference = exp::compare(&rc, &claims, &exp::lcr_runs(&rc), &exp::calibration(&rc).unwrap()).unwrap();
    let off = reference
        .iter()
        .filter(|o| o.claim.id.starts_with("sweep_6k") && o.deviation() < -20.0)
        .count();
    assert_eq!(off, 3);
}

/// The firmware's channel on the paper's sensor, with its calibration's
/// tab leads in the inversion: every valid record within 0.5 % of the
/// truth, ≤ 0.1 % RMS, at the two lower frequencies of its set (its
/// current is small: the records the noise cannot vouch for are flagged,
/// not reported).
#[test]
fn the_channel_corrects_the_papers_tab_leads() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = ctx(&dir);
    c.sensor = skin_sim::sensor::SensorParams::PAPER;
    let (_, acc) = exp::accuracy(&c).unwrap();
    for a in &acc[..2] {
        assert!(a.corrected[2] <= 0.1 && a.corrected[3] <= 0.5, "{a:?}");
        assert!(a.corrected_missing * 2 < a.readings, "{a:?}");
        // The lumped reading is off by several percent.
        assert!(a.lumped[2] > 2.0, "{a:?}");
    }
}

/// `docs/paper.md` shows what `host-sim paper` prints with its defaults
/// (the paper's sensor, seed 1, two periods), and the README's headline
/// its accuracy at 2 kHz (the frequency of the paper's undershoots; the
/// firmware's 1953 Hz).
#[test]
fn the_docs_show_what_host_sim_paper_prints() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = Ctx::new(dir.path(), 1).unwrap();
    c.sensor = skin_sim::sensor::SensorParams::PAPER;
    let (md, acc) = exp::paper(&c).unwrap();
    let body = md.split_once("\n\n").map_or(md.as_str(), |(_, b)| b);
    figures::check("docs/paper.md", "paper-summary", body).unwrap();
    let a = &acc[1];
    let line = figures::table(&[
        (
            format!(
                "C error, the paper's sensor on its 20 mm/s trapezoid at {:.0} Hz: a series meter (host-sim)",
                a.freq_hz
            ),
            format!("{:.1} % RMS, {:.1} % max", a.lumped[2], a.lumped[3]),
        ),
        (
            format!(
                "the same, line-corrected by the firmware's channel on a simulated ADC, {:.0} Hz",
                a.freq_hz
            ),
            format!(
                "{:.2} % RMS, {:.2} % max ({} of {} records vouched for)",
                a.corrected[2],
                a.corrected[3],
                a.readings - a.corrected_missing,
                a.readings
            ),
        ),
    ]);
    figures::check("docs/figures.md", "headline-paper", &line).unwrap();
}
