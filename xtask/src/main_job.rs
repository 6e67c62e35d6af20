//! The main job: the firmware in QEMU measuring the simulated skin under
//! the paper's stretching, decoded to CSV, with plots and a summary of its
//! error against the truth.

use anyhow::{Context, Result};
use host_sim::numerics::rms_max;
use host_sim::plot::{figure, Panel, Series};
use host_sim::recording::{self, Rec, Roles};
use qemu_tests::records;
use std::fmt::Write as _;
use std::path::Path;

/// What a fixed 6 kHz series meter would read on the true sensor of `r`
/// (its line through its tab leads).
fn lumped_6k(r: &Rec) -> Option<f64> {
    r.truth?.series_meter_pf(5859.375)
}

/// Run the `paper` scenario and write everything to `out`.
/// A capacitance-against-time panel: the truth (pF), then `measured`.
fn c_panel(title: String, truth: Vec<(f64, f64)>, measured: Vec<Series>) -> Panel {
    let mut series = vec![Series::new("truth", truth)];
    series.extend(measured);
    Panel {
        title,
        x_label: "time [s]".into(),
        y_label: "C [pF]".into(),
        log_x: false,
        series,
    }
}

pub fn run(out: &Path) -> Result<String> {
    std::fs::create_dir_all(out)?;
    eprintln!("running the firmware in QEMU (20 s of simulated skin)...");
    let (run, recs) = records::run_scenario("paper")?;
    let run = run.ok()?;
    std::fs::write(out.join("firmware.log"), &run.stdout)?;
    let written = recording::write_dataset(out, &recs, &Roles::default())?;
    let files = written.traces;
    let mut md = String::from(
        "# The firmware in QEMU on the simulated skin\n\n\
         Eight copies of the paper's sensor (`SensorParams::PAPER`: 205 pF, 350 + 361 kΩ with 64 % in\n\
         the tab leads, cycled), read through the auto-ranging front end; the firmware's line model\n\
         carries the leads' ratio `identify` found on the paper's static sweep.\n\
         Channel 0: the paper's 20 mm/s trapezoid; channel 1: 10 mm/s; channels 2–7 held at 4–14 mm.\n\
         Line-corrected C from the firmware against the simulated truth (records flagged settling are\n\
         the one block after each frequency switch and carry no value); for contrast, what a series\n\
         meter fixed at 6 kHz would read on the same sensor.\n\n\
         | ch | records | valid | corrected RMS | max | RMS | max | stretch RMS | fixed 6 kHz lumped RMS | max |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut panels = vec![];
    for ch in 0..8u8 {
        let rs: Vec<&Rec> = recs.iter().filter(|r| r.channel == ch).collect();
        let valid: Vec<&&Rec> = rs.iter().filter(|r| r.valid() && r.truth.is_some()).collect();
        let err = |r: &&&Rec| r.c_pf - r.truth.unwrap().c_pf;
        let (rms, mx, _) = rms_max(valid.iter().map(err));
        let (rrms, rmx, _) = rms_max(valid.iter().map(|r| 100.0 * err(r) / r.truth.unwrap().c_pf));
        let (srms, _, _) = rms_max(valid.iter().map(|r| r.stretch_mm - r.truth.unwrap().stretch_mm));
        let (lrms, lmx, _) = rms_max(rs.iter().filter_map(|r| Some(lumped_6k(r)? - r.truth?.c_pf)));
        writeln!(
            md,
            "| {ch} | {} | {} | {rms:.2} pF | {mx:.2} pF | {rrms:.3} % | {rmx:.3} % | {srms:.3} mm | {lrms:.1} pF | {lmx:.1} pF |",
            rs.len(),
            valid.len()
        )?;
        if ch < 2 {
            let t = |r: &Rec| r.t_s;
            panels.push(c_panel(
                format!(
                    "channel {ch}: capacitance ({} mm/s)",
                    if ch == 0 { 20 } else { 10 }
                ),
                rs.iter().filter_map(|r| Some((t(r), r.truth?.c_pf))).collect(),
                vec![
                    Series::new(
                        "firmware, line-corrected",
                        valid.iter().map(|r| (t(r), r.c_pf)).collect(),
                    ),
                    Series::dashed(
                        "fixed 6 kHz lumped meter",
                        rs.iter().filter_map(|r| Some((t(r), lumped_6k(r)?))).collect(),
                    ),
                ],
            ));
            panels.push(Panel {
                title: format!(
                    "channel {ch}: excitation frequency chosen by the firmware, and electrode resistance"
                ),
                x_label: "time [s]".into(),
                y_label: "f [kHz] / R [MΩ]".into(),
                log_x: false,
                series: vec![
                    Series::new("f [kHz]", rs.iter().map(|r| (t(r), r.freq_hz / 1e3)).collect()),
                    Series::dashed(
                        "R true [MΩ]",
                        rs.iter()
                            .filter_map(|r| Some((t(r), r.truth?.r_ohm / 1e6)))
                            .collect(),
                    ),
                    Series::new(
                        "R firmware [MΩ]",
                        valid.iter().map(|r| (t(r), r.r_ohm / 1e6)).collect(),
                    ),
                ],
            });
        }
    }
    figure(
        &out.join("firmware_paper.svg"),
        "Firmware in QEMU: the paper's stretching on the paper's sensor (simulated)",
        &panels,
    )
    .context("plot")?;
    writeln!(
        md,
        "\nWrote the recording as a data set (`host-sim decode`): {} trace files (one per moving channel and frequency), \
         {} fragments (runs too short for a trace), calibration.csv ({} points from the held channels), faults.csv; \
         and firmware.log, firmware_paper.svg.",
        files.len(),
        written.fragments.len(),
        written.calibration_points
    )?;
    std::fs::write(out.join("summary.md"), &md)?;
    Ok(md)
}

/// The array in QEMU: sixteen of the paper's sensors read at once under
/// its 20 mm/s trapezoid (`skin-array paper`), decoded to a data set (a
/// trace per sensor and tone), with a plot and a summary of each sensor's
/// error against the truth; written to `out`.
pub fn run_array(out: &Path) -> Result<String> {
    std::fs::create_dir_all(out)?;
    eprintln!("running the array firmware in QEMU (10 s, 16 sensors at once)...");
    let (run, recs) = records::run_array("paper")?;
    let run = run.ok()?;
    std::fs::write(out.join("array.log"), &run.stdout)?;
    let per_tone: Vec<Rec> = recs.iter().flat_map(recording::ToneRec::per_tone).collect();
    let written = recording::write_dataset(out, &per_tone, &Roles::default())?;
    let mut md = String::from(
        "# The array in QEMU: sixteen sensors at once\n\n\
         Sixteen of the paper's sensors on its 20 mm/s trapezoid, sensor s 0.6·s s ahead in its cycle,\n\
         read at once through one comb excitation (500–6000 Hz), each 250 times a second from two tones\n\
         with the model check. Line-corrected C against the simulated truth:\n\n\
         | sensor | records | per second | valid | C RMS | max | model flags | tones used [Hz] |\n\
         |---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    let mut panels = vec![];
    for s in 0..16u8 {
        let rs: Vec<&recording::ToneRec> = recs.iter().filter(|r| r.rec.channel == s).collect();
        let (Some(first), Some(last)) = (rs.first(), rs.last()) else {
            anyhow::bail!("sensor {s}: no records");
        };
        let rate = (rs.len() - 1) as f64 / (last.t_s() - first.t_s());
        let valid: Vec<&&recording::ToneRec> = rs.iter().filter(|r| r.rec.flags.valid()).collect();
        let (rms, mx, _) = rms_max(valid.iter().filter_map(|r| Some(100.0 * r.c_error()?)));
        let model = rs
            .iter()
            .filter(|r| r.rec.flags.has(instrument::faults::Flags::MODEL))
            .count();
        let mut tones: Vec<u32> = rs.iter().flat_map(|r| r.rec.f_hz.map(|f| f as u32)).collect();
        tones.sort_unstable();
        tones.dedup();
        writeln!(
            md,
            "| {s} | {} | {rate:.1} | {} | {rms:.3} % | {mx:.3} % | {model} | {tones:?} |",
            rs.len(),
            valid.len()
        )?;
        if s == 0 || s == 8 {
            let t = |r: &recording::ToneRec| r.t_s();
            panels.push(c_panel(
                format!("sensor {s}: capacitance, 250 records/s"),
                rs.iter().filter_map(|r| Some((t(r), r.truth?.c_pf))).collect(),
                vec![Series::new(
                    "firmware, two tones, line-corrected",
                    valid
                        .iter()
                        .map(|r| (t(r), r.rec.c_farad as f64 * 1e12))
                        .collect(),
                )],
            ));
        }
    }
    figure(
        &out.join("array_paper.svg"),
        "The array in QEMU: sixteen sensors at once (simulated)",
        &panels,
    )
    .context("plot")?;
    writeln!(
        md,
        "\nWrote the recording as a data set (`host-sim decode`, a record per tone): {} trace files, {} fragments; \
         and array.log, array_paper.svg.",
        written.traces.len(),
        written.fragments.len()
    )?;
    std::fs::write(out.join("summary.md"), &md)?;
    Ok(md)
}
