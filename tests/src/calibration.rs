//! The calibration workflow on the QEMU skin, end to end, as a user runs
//! it on a board: sixteen hand-made sensors (each its own rest C,
//! electrodes, cable capacitance and tab leads:
//! `skin_sim::sensor::SensorParams::hand_made`) on a device with nothing
//! stored.
//!
//! 1. *Before*: the skin on the paper's 20 mm/s trapezoid, read with the
//!    reference sensor's constants on every sensor (the paper's table and
//!    leads, as the firmware once had them compiled in).
//! 2. *Calibration*: the device, nothing stored, runs the stairs (the
//!    skin held at 0, 3, …, 30 mm: `skin_sim::stairs`) while
//!    `live calibrate`'s library reads its records over the link, fits
//!    each sensor, writes the set down the link and stops the device.
//! 3. *After*: QEMU restarted on the same flash file: the set comes back
//!    (its generation and digest in the start line), and the skin on the
//!    same trapezoid is read with it.
//!
//! Each sensor's stretch error against the truth, before and after, and
//! the records marked valid more than 1 % off in C.

use anyhow::{bail, Result};
use host_sim::numerics::rms_max;
use host_sim::recording::LoggedToneRecord;
use instrument::availability::Availability;
use instrument::digest::Digest;
use instrument::stored::Stored;
use live::calibrate::{self as cal, Hold, Outcome};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// One sensor's figures.
#[derive(Clone, Copy, Debug)]
pub struct SensorFigures {
    /// Sensor.
    pub sensor: u8,
    /// Stretch RMS before (reference constants), mm, over every record
    /// with a C (what a reader ignoring the flags gets).
    pub before_all_mm: f64,
    /// Records marked valid before, and records.
    pub before_valid: (usize, usize),
    /// Stretch RMS after calibration over the records whose stretch is
    /// marked valid, mm.
    pub after_mm: f64,
    /// Its largest error, mm.
    pub after_max_mm: f64,
    /// Its mean (the table's bias), mm.
    pub after_mean_mm: f64,
    /// Stretch RMS after over the valid records of blocks where the skin
    /// held still, and where it moved, mm.
    pub after_still_moving_mm: (f64, f64),
    /// RMS of each valid record's C error over its own stated 1σ
    /// (`sigma_ln_c`): about 1 where the scatter is the noise the record
    /// declares.
    pub after_z_rms: f64,
    /// Records whose stretch is marked valid after, and records.
    pub after_valid: (usize, usize),
    /// Records marked valid more than 1 % off in C, before and after.
    pub c_off: (usize, usize),
    /// After: the availability of C over the records while the skin
    /// moved (the truth's stretch changed since the sensor's record
    /// before), and why the others were not valid.
    pub moving: Availability,
}

/// What the workflow measured.
#[derive(Debug)]
pub struct Workflow {
    /// The holds the calibration used.
    pub holds: Vec<Hold>,
    /// `live calibrate`'s report.
    pub report: String,
    /// The set written down the link, and its generation.
    pub set: Stored,
    /// Its generation.
    pub generation: u32,
    /// The restarted device's start line names that generation and the
    /// set's digest.
    pub came_back: bool,
    /// Each sensor's outcome.
    pub outcomes: Vec<Outcome>,
    /// Per sensor, before and after.
    pub sensors: Vec<SensorFigures>,
    /// The after run's records (with the truth).
    pub after: Vec<LoggedToneRecord>,
    /// The link's raw stream of the calibration run.
    pub stream: Vec<u8>,
    /// What the device answered each hold's sweep.
    pub sweeps: Vec<String>,
}

/// The holds of the stairs scenario, as a user's holds file gives them.
pub fn stairs_holds() -> Vec<Hold> {
    skin_sim::stairs::holds()
        .iter()
        .map(|h| Hold {
            stretch_mm: h.stretch_mm,
            from_s: h.from_s,
            to_s: h.to_s,
            sensor: None,
        })
        .collect()
}

/// Records of the trapezoid runs whose stretch the truth can judge: after
/// the first second (the tracker's start).
fn judged(recs: &[LoggedToneRecord], s: u8) -> Vec<&LoggedToneRecord> {
    recs.iter()
        .filter(|r| r.rec.sensor == s && r.truth.is_some() && r.t_s() >= 1.0)
        .collect()
}

/// C more than 1 % off the truth on a record marked valid.
fn c_off(r: &LoggedToneRecord) -> bool {
    r.rec.flags.valid() && r.c_error().is_some_and(|e| e.abs() > 0.01)
}

/// Run the workflow with its flash file in `dir`.
pub fn run(dir: &Path) -> Result<Workflow> {
    std::fs::create_dir_all(dir)?;
    let elf = crate::build_firmware("skin-array", &["qemu"])?;
    let flash = dir.join("flash.bin");
    match std::fs::remove_file(&flash) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e.into()),
        _ => {}
    }
    let flash_arg = format!("flash={}", flash.display());
    // 1. Before, on a thread of its own while the calibration runs.
    let before = std::thread::spawn(|| crate::records::run_array_args(&["skin"]));
    // 2. The calibration, over the link.
    let done = calibrate_over_link(&elf, &flash_arg, dir)?;
    let report = cal::report(&done.holds, &done.outcomes);
    // 3. After: a restart on the same flash.
    let (run, after) = crate::records::run_array_args(&["skin", &flash_arg])?;
    let run = run.ok()?;
    let want = format!(
        "settings: generation {} digest {:#010x}",
        done.generation,
        Digest::of(&done.set)
    );
    let came_back = run.stdout.lines().any(|l| l.starts_with(&want));
    let (before_run, before) = before
        .join()
        .map_err(|_| anyhow::anyhow!("the before run panicked"))??;
    before_run.ok()?;
    let sensors = (0..instrument::array::SENSORS as u8)
        .map(|s| sensor_figures(s, &before, &after))
        .collect();
    Ok(Workflow {
        holds: done.holds,
        report,
        set: done.set,
        generation: done.generation,
        came_back,
        outcomes: done.outcomes,
        sensors,
        after,
        stream: done.stream,
        sweeps: done.sweeps,
    })
}

/// Step 2: the device, nothing stored, on the stairs (`elf` with its
/// flash argument `flash_arg`), calibrated over the link by a guided
/// `live calibrate` that stops it; its log (kept in `dir` for a run that
/// goes wrong) in the error.
fn calibrate_over_link(elf: &Path, flash_arg: &str, dir: &Path) -> Result<cal::Done> {
    let holds = stairs_holds();
    let log = dir.join("calibration-run.defmt");
    let (mut qemu, sock) = crate::connect_qemu_tcp_logged(elf, &["stairs", flash_arg, "until-stop"], &log)?;
    // Guided, as a user on a stage that keeps to the stairs' schedule:
    // each hold begins when the stairs reach its stretch.
    let guide = cal::Guide {
        open: false,
        at_mm: holds.iter().map(|h| h.stretch_mm).collect(),
        settle_s: skin_sim::stairs::SETTLE_S,
        hold_s: skin_sim::stairs::HOLD_S - skin_sim::stairs::SETTLE_S,
        sweep: true,
    };
    let starts: Vec<f64> = holds
        .iter()
        .map(|h| h.from_s - skin_sim::stairs::SETTLE_S)
        .collect();
    let done = cal::guided(
        sock,
        &guide,
        |k, _, _| Ok(cal::Ready::At(starts[k])),
        &cal::Options::default(),
        true,
        Duration::from_secs(120),
    );
    let status = match &done {
        Ok(_) => qemu.wait()?,
        Err(_) => {
            // Ended by itself (its log says why), or still running.
            std::thread::sleep(Duration::from_millis(500));
            if qemu.try_wait()?.is_none() {
                let _ = qemu.kill();
            }
            qemu.wait()?
        }
    };
    // What the device said, for a run that went wrong.
    let said = || {
        let raw = std::fs::read(&log).unwrap_or_default();
        let lines = host_sim::recording::decode_defmt(elf, &raw).unwrap_or_default();
        let tail: Vec<String> = lines
            .iter()
            .rev()
            .take(12)
            .rev()
            .map(|(_, l)| l.clone())
            .collect();
        let err = std::fs::read_to_string(log.with_extension("err")).unwrap_or_default();
        format!(
            "QEMU {status}; its log ends:\n{}\nQEMU said: {err}",
            tail.join("\n")
        )
    };
    let done = match done {
        Ok(d) => d,
        Err(e) => return Err(e.context(format!("calibrating over the link ({})", said()))),
    };
    if !status.success() {
        bail!("the calibration run ended badly: {}", said());
    }
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(log.with_extension("err"));
    Ok(done)
}

/// Sensor `s`'s figures from the records `before` and `after`.
fn sensor_figures(s: u8, before: &[LoggedToneRecord], after: &[LoggedToneRecord]) -> SensorFigures {
    let b = judged(before, s);
    let a = judged(after, s);
    let err = |r: &&LoggedToneRecord| r.rec.stretch_mm as f64 - r.truth.map_or(f64::NAN, |t| t.stretch_mm);
    let before_all: Vec<f64> = b.iter().filter(|r| r.rec.c_farad > 0.0).map(err).collect();
    let after_valid: Vec<f64> = a
        .iter()
        .filter(|r| r.rec.flags.stretch_valid())
        .map(err)
        .collect();
    let (mut still, mut moving) = (vec![], vec![]);
    let mut availability = Availability::new();
    for p in a.windows(2) {
        let held = p[1].truth.map(|t| t.stretch_mm) == p[0].truth.map(|t| t.stretch_mm);
        if !held {
            availability.count(p[1].rec.flags);
        }
        if p[1].rec.flags.stretch_valid() {
            if held { &mut still } else { &mut moving }.push(err(&p[1]));
        }
    }
    let z: Vec<f64> = a
        .iter()
        .filter(|r| r.rec.flags.stretch_valid())
        .filter_map(|r| Some(r.c_error()? / r.rec.sigma_ln_c as f64))
        .collect();
    let (after_mm, after_max_mm, _) = rms_max(after_valid.iter().copied());
    SensorFigures {
        sensor: s,
        before_all_mm: rms_max(before_all).0,
        before_valid: (b.iter().filter(|r| r.rec.flags.stretch_valid()).count(), b.len()),
        after_mm,
        after_max_mm,
        after_mean_mm: after_valid.iter().sum::<f64>() / after_valid.len().max(1) as f64,
        after_still_moving_mm: (rms_max(still).0, rms_max(moving).0),
        after_z_rms: rms_max(z).0,
        after_valid: (after_valid.len(), a.len()),
        c_off: (
            b.iter().filter(|r| c_off(r)).count(),
            a.iter().filter(|r| c_off(r)).count(),
        ),
        moving: availability,
    }
}

impl Workflow {
    /// The before/after table, Markdown.
    pub fn table(&self) -> String {
        let mut md = String::from(
            "| sensor | before: stretch RMS (all records) | before: stretch valid | after: stretch RMS (valid) | held still / moving | max | error / stated σ (RMS) | after: stretch valid | after, moving: C valid | not valid: faults | valid > 1 % off in C, before / after |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for s in &self.sensors {
            let _ = writeln!(
                md,
                "| {} | {:.2} mm | {} of {} | {:.3} mm | {:.3} / {:.3} mm | {:.3} mm | {:.2} | {} of {} | {} | {} | {} / {} |",
                s.sensor,
                s.before_all_mm,
                s.before_valid.0,
                s.before_valid.1,
                s.after_mm,
                s.after_still_moving_mm.0,
                s.after_still_moving_mm.1,
                s.after_max_mm,
                s.after_z_rms,
                s.after_valid.0,
                s.after_valid.1,
                crate::summary::percent(&s.moving),
                s.moving.why(),
                s.c_off.0,
                s.c_off.1
            );
        }
        md
    }

    /// The worst sensor's stretch RMS after, mm.
    pub fn worst_after_mm(&self) -> f64 {
        self.sensors.iter().map(|s| s.after_mm).fold(0.0, f64::max)
    }
}
