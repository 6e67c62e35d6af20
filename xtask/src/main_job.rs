//! The main job: the firmware in QEMU measuring the simulated skin under
//! the paper's stretching, decoded to CSV, with plots and a summary of its
//! error against the truth. The figures come from `qemu_tests::summary`,
//! which the QEMU tests check the README and docs against.

use anyhow::{bail, Context, Result};
use host_sim::plot::{figure, Panel, Series};
use host_sim::recording::{self, LoggedRecord, LoggedToneRecord, Roles};
use qemu_tests::records;
use qemu_tests::summary::{self, Motion};
use std::fmt::Write as _;
use std::path::Path;

/// The main job: the multiplexed firmware (`out/firmware`) and the array
/// (`out/array`) in QEMU, a skin of hand-made sensors calibrated over the
/// link (`out/calibrate`), four boards read as one skin (`out/skin`),
/// the paper's experiments on the simulated skin
/// (`out/paper`), then the Cortex-M4 instruction counts.
pub fn all(root: &Path) -> Result<()> {
    println!("{}", run(&root.join("out/firmware"))?);
    println!("{}", run_array(&root.join("out/array"), &root.join("out/live"))?);
    println!("{}", run_calibration(&root.join("out/calibrate"))?);
    println!("{}", crate::main_skin::run(&root.join("out/skin"))?);
    let st = std::process::Command::new(crate::cargo::bin())
        // xtask's profile: host-sim's dependencies are xtask's, built.
        .args([
            "run",
            "--profile",
            "quick",
            "-q",
            "-p",
            "host-sim",
            "--",
            "paper",
            "--out",
        ])
        .arg(root.join("out/paper"))
        .status()
        .context("running host-sim")?;
    if !st.success() {
        bail!("host-sim paper failed");
    }
    crate::bench::cortex_m4()
}

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

/// A moving channel's two panels: its capacitance (truth, the firmware,
/// a fixed 6 kHz series meter), and the frequency the firmware chose with
/// the electrode resistance.
fn channel_panels(ch: u8, motion: Motion, recs: &[LoggedRecord]) -> [Panel; 2] {
    let rs: Vec<&LoggedRecord> = recs.iter().filter(|r| r.sensor == ch).collect();
    let valid: Vec<&&LoggedRecord> = rs.iter().filter(|r| r.valid() && r.truth.is_some()).collect();
    let capacitance = c_panel(
        format!("channel {ch}: capacitance ({motion})"),
        rs.iter().filter_map(|r| Some((r.t_s, r.truth?.c_pf))).collect(),
        vec![
            Series::new(
                "firmware, line-corrected",
                valid.iter().map(|r| (r.t_s, r.c_pf)).collect(),
            ),
            Series::dashed(
                "fixed 6 kHz series meter",
                rs.iter()
                    .filter_map(|r| Some((r.t_s, summary::lumped(r)?)))
                    .collect(),
            ),
        ],
    );
    let frequency = Panel {
        title: format!("channel {ch}: excitation frequency chosen by the firmware, and electrode resistance"),
        x_label: "time [s]".into(),
        y_label: "f [kHz] / R [MΩ]".into(),
        log_x: false,
        series: vec![
            Series::new("f [kHz]", rs.iter().map(|r| (r.t_s, r.freq_hz / 1e3)).collect()),
            Series::dashed(
                "R true [MΩ]",
                rs.iter()
                    .filter_map(|r| Some((r.t_s, r.truth?.r_ohm / 1e6)))
                    .collect(),
            ),
            Series::new(
                "R firmware [MΩ]",
                valid.iter().map(|r| (r.t_s, r.r_ohm / 1e6)).collect(),
            ),
        ],
    };
    [capacitance, frequency]
}

/// Run the multiplexed firmware's `paper` scenario in QEMU and write its
/// log, data set, plot and summary to `out`; returns the summary.
pub fn run(out: &Path) -> Result<String> {
    std::fs::create_dir_all(out)?;
    eprintln!("running the firmware in QEMU (20 s of simulated skin)...");
    let (run, recs) = records::run_scenario("paper")?;
    let run = run.ok()?;
    std::fs::write(out.join("firmware.log"), &run.stdout)?;
    let written = recording::write_dataset(out, &recs, &Roles::default())?;
    let figures = summary::channels(&recs);
    let p = skin_sim::sensor::SensorParams::PAPER;
    let mut md = format!(
        "# The firmware in QEMU on the simulated skin\n\n\
         {} copies of the paper's sensor (`SensorParams::PAPER`: {:.1} pF at rest, electrodes of \
         {:.0} + {:.0} kΩ of which {:.0} % in the tab leads), read through the auto-ranging front end; \
         the firmware's line model carries the leads' ratio. Line-corrected C from the firmware against \
         the simulated truth, over the records it flagged valid; for contrast, what a series meter fixed \
         at {:.0} Hz would read on the same sensor.\n\n{}",
        figures.len(),
        p.c_rest_farad * 1e12,
        p.top.r_rest_ohm / 1e3,
        p.bottom.r_rest_ohm / 1e3,
        100.0 * p.effects.get(instrument::effects::Effect::LeadResistance),
        summary::LUMPED_HZ,
        summary::channel_table(&figures)
    );
    let panels: Vec<Panel> = figures
        .iter()
        .filter(|c| matches!(c.motion, Motion::Moving { .. }))
        .flat_map(|c| channel_panels(c.channel, c.motion, &recs))
        .collect();
    figure(
        &out.join("firmware_paper.svg"),
        "Firmware in QEMU: the paper's stretching on the paper's sensor (simulated)",
        &panels,
    )
    .context("plot")?;
    writeln!(
        md,
        "\nWrote the recording as a data set (`host-sim decode`): {} trace files (one per moving channel \
         and frequency), {} fragments (runs too short for a trace), calibration.csv ({} points from the \
         held channels), faults.csv ({} records); and firmware.log, firmware_paper.svg.",
        written.traces.len(),
        written.fragments.len(),
        written.calibration_points,
        written.faults
    )?;
    std::fs::write(out.join("summary.md"), &md)?;
    Ok(md)
}

/// Run the array firmware's `paper` scenario in QEMU (`skin-array`:
/// sixteen of the paper's sensors read at once under its 20 mm/s
/// trapezoid) and write its log, data set (a trace per sensor and tone),
/// plot and summary to `out`; its record link's stream and the data set
/// `live` makes of it to `live_dir`. Returns the summary.
pub fn run_array(out: &Path, live_dir: &Path) -> Result<String> {
    std::fs::create_dir_all(out)?;
    eprintln!("running the array firmware in QEMU (10 s, 16 sensors at once)...");
    let (run, recs) = records::run_array("paper")?;
    let run = run.ok()?;
    std::fs::write(out.join("array.log"), &run.stdout)?;
    // The main job's own folder: its last run's session is replaced.
    let link = live::replay(&run.serial, live_dir, live::Earlier::Overwrite)?;
    let per_tone: Vec<LoggedRecord> = recs.iter().flat_map(LoggedToneRecord::per_tone).collect();
    let written = recording::write_dataset(out, &per_tone, &Roles::default())?;
    let figures = summary::sensors(&recs)?;
    let mut tones: Vec<u32> = figures.iter().flat_map(|s| s.tones.iter().copied()).collect();
    tones.sort_unstable();
    tones.dedup();
    let mut md = format!(
        "# The array in QEMU: {0} sensors at once\n\n\
         {0} of the paper's sensors on its 20 mm/s trapezoid, each later in its cycle than the last, read at \
         once through one comb excitation (tones {tones:?} Hz), each {1} times a second from two tones with \
         the model check. Line-corrected C against the simulated truth:\n\n{2}",
        figures.len(),
        summary::span(figures.iter().map(|s| s.rate), 1),
        summary::sensor_table(&figures)
    );
    let start = run.start_frame()?;
    writeln!(
        md,
        "\nBefore the first record, the board's power-up self-test (docs/hardware.md): {}.",
        live::self_test::line(&start.self_test, start.sensors)
    )?;
    let panels: Vec<Panel> = figures
        .iter()
        .step_by(8)
        .map(|s| {
            let rs: Vec<&LoggedToneRecord> = recs.iter().filter(|r| r.rec.sensor == s.sensor).collect();
            c_panel(
                format!("sensor {}: capacitance, {:.0} records/s", s.sensor, s.rate),
                rs.iter().filter_map(|r| Some((r.t_s(), r.truth?.c_pf))).collect(),
                vec![Series::new(
                    "firmware, two tones, line-corrected",
                    rs.iter()
                        .filter(|r| r.rec.flags.valid())
                        .map(|r| (r.t_s(), r.rec.c_farad as f64 * 1e12))
                        .collect(),
                )],
            )
        })
        .collect();
    figure(
        &out.join("array_paper.svg"),
        "The array in QEMU: every sensor at once (simulated)",
        &panels,
    )
    .context("plot")?;
    writeln!(
        md,
        "\nWrote the recording as a data set (`host-sim decode`, a record per tone): {} trace files, \
         {} fragments; and array.log, array_paper.svg.",
        written.traces.len(),
        written.fragments.len()
    )?;
    writeln!(
        md,
        "\n## The record link\n\nThe same records as frames on UART0 (postcard, CRC-32, COBS), kept as \
         `{}/stream.bin` and written as a data set beside it by `live` ({}): {}.",
        live_dir.display(),
        match &link.outcome {
            live::Outcome::Complete => "complete".to_string(),
            live::Outcome::Stopped => "stopped when asked (complete)".to_string(),
            live::Outcome::Incomplete(why) => format!("INCOMPLETE: {why}"),
        },
        link.summary.line()
    )?;
    if let live::Outcome::Incomplete(why) = link.outcome {
        bail!("the record link's stream is incomplete: {why}");
    }
    std::fs::write(out.join("summary.md"), &md)?;
    Ok(md)
}

/// The calibration workflow (`qemu_tests::calibration`): a skin of
/// sixteen hand-made sensors calibrated over the link, QEMU restarted,
/// the settings back, each sensor's stretch before and after. Writes the
/// holds, the calibration run's stream, the flash image, the report, a
/// plot and the summary to `out`; returns the summary.
pub fn run_calibration(out: &Path) -> Result<String> {
    eprintln!("calibrating a skin of sixteen hand-made sensors over the link in QEMU (three runs)...");
    let w = qemu_tests::calibration::run(out)?;
    live::calibrate::write_holds(&out.join("holds.csv"), &w.holds)?;
    std::fs::write(out.join("stream.bin"), &w.stream)?;
    std::fs::write(out.join("report.md"), &w.report)?;
    let stretch = |s: u8| Panel {
        title: format!("sensor {s}: stretch after calibration"),
        x_label: "time [s]".into(),
        y_label: "stretch [mm]".into(),
        log_x: false,
        series: vec![
            Series::new(
                "truth",
                w.after
                    .iter()
                    .filter(|r| r.rec.sensor == s)
                    .filter_map(|r| Some((r.t_s(), r.truth?.stretch_mm)))
                    .collect(),
            ),
            Series::new(
                "firmware, its own table (valid records)",
                w.after
                    .iter()
                    .filter(|r| r.rec.sensor == s && r.rec.flags.stretch_valid())
                    .map(|r| (r.t_s(), r.rec.stretch_mm as f64))
                    .collect(),
            ),
        ],
    };
    let worst = w
        .sensors
        .iter()
        .max_by(|a, b| a.after_mm.total_cmp(&b.after_mm))
        .map_or(0, |s| s.sensor);
    figure(
        &out.join("calibrated.svg"),
        "A skin of hand-made sensors after calibration over the link (QEMU)",
        &[stretch(0), stretch(worst)],
    )
    .context("plot")?;
    let fitted = w
        .outcomes
        .iter()
        .filter(|o| matches!(o, live::calibrate::Outcome::Fitted(_)))
        .count();
    let md = format!(
        "# Calibrating a skin over the link\n\n\
         Sixteen hand-made sensors (`SensorParams::hand_made`: rest C 0.8–1.2×, electrodes 0.5–1.5× the \
         paper's, 0–20 pF of cable, tab leads from none to the paper's), on a device with nothing stored \
         (`flash.bin`). The device ran the stairs (`holds.csv`: 0, 3, …, 30 mm held in turn) while \
         `live calibrate` read its records over the link (`stream.bin`), fitted each sensor, wrote the set \
         down the link (generation {}) and stopped it. QEMU restarted on the same flash: the set came \
         back{}. Then the skin on the paper's 20 mm/s trapezoid, read with the reference sensor's \
         constants (before) and with its own calibration (after):\n\n{}\n\
         {fitted} of 16 sensors fitted; the worst stretch RMS after is {:.3} mm, and {:.3} mm where the \
         skin holds still: in motion the slowest electrodes, read at the lowest tones while their \
         resistance peaks, scatter as their records' own σ says (error/σ RMS {}). `report.md` is \
         `live calibrate`'s own report:\n\n{}",
        w.generation,
        if w.came_back {
            " (the start line names its generation and digest)"
        } else {
            ": NOT (the start line does not name it)"
        },
        w.table(),
        w.worst_after_mm(),
        w.sensors
            .iter()
            .map(|s| s.after_still_moving_mm.0)
            .fold(0.0, f64::max),
        qemu_tests::summary::span(w.sensors.iter().map(|s| s.after_z_rms), 2),
        w.report
    );
    std::fs::write(out.join("summary.md"), &md)?;
    if !w.came_back {
        bail!("the restarted device does not name the set written");
    }
    Ok(md)
}
