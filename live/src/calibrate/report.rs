//! The reports: a calibration's fit per sensor, and a check of the
//! stored set against fresh holds.

use super::*;
use instrument::faults::Flags;
use std::fmt::Write as _;

/// A global value in its unit.
pub(crate) fn fmt_value(g: usize, v: f64) -> String {
    match g {
        0 => format!("{v:.4}"),
        1 => format!("{:.2} kΩ", v / 1e3),
        2 => format!("{:.2} pF", v * 1e12),
        _ => format!("{:.2}·10⁻³", v * 1e3),
    }
}

/// The report of a calibration, Markdown: a row per sensor, then what the
/// data left unresolved and why sensors were refused.
pub fn report(holds: &[Hold], outcomes: &[Outcome]) -> String {
    let mut md = String::new();
    let s = SensorFit::stretches(holds);
    let held = match holds.iter().any(|h| h.sensor.is_some()) {
        true => format!("{} holds, each sensor at its own stretches", holds.len()),
        false => format!("{} holds ({s:?} mm)", holds.len()),
    };
    let _ = writeln!(
        md,
        "{held}. Per sensor: the fitted tab leads ℓ, contact and parasitic capacitance \
         (±1σ), C and R at rest, χ²/dof, how far the uncalibrated reading's C is from the fitted \
         line's (RMS over the holds), and the stretch error the reference sensor's table would give \
         on the uncalibrated reading (RMS over the holds) against the new table's (its points are \
         the fit's, so 0 at the holds: the measurement after the restart is the test).\n"
    );
    let open = outcomes
        .iter()
        .any(|o| matches!(o, Outcome::Fitted(f) if f.open_cp.is_some()));
    if open {
        md.push_str(
            "With an open fixture (every sensor unplugged, its cable left on): its records are fitted \
             with the holds, and its C_p alone is in the last column.\n\n",
        );
    }
    md.push_str("| sensor | records | ℓ | contact kΩ | parasitic pF | film tan δ ×10⁻³ | C rest pF | R rest kΩ | χ²/dof | uncalibrated C off | stretch RMS, reference table | outcome |");
    md.push_str(if open { " open fixture pF |\n" } else { "\n" });
    md.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|");
    md.push_str(if open { "---|\n" } else { "\n" });
    let mut notes = vec![];
    for (i, o) in outcomes.iter().enumerate() {
        match o {
            Outcome::NotInUse => {}
            Outcome::Refused(why) => {
                let _ = writeln!(
                    md,
                    "| {i} | | | | | | | | | | | refused |{}",
                    if open { " |" } else { "" }
                );
                notes.push(format!(
                    "sensor {i} refused: {why}; the device keeps its set for it"
                ));
            }
            Outcome::Fitted(f) => {
                let s = SensorFit::stretches(&for_sensor(holds, i as u8));
                fitted_row(&mut md, i, f, &s, open);
                for u in f.unresolved() {
                    notes.push(format!("sensor {i}: {u}"));
                }
            }
        }
    }
    if !notes.is_empty() {
        md.push('\n');
        for n in notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    md
}

/// Sensor `i`'s row of [`report`] for its fit `f` at stretches `s`
/// (mm), with the open fixture's column when `open`.
fn fitted_row(md: &mut String, i: usize, f: &SensorFit, s: &[f64], open: bool) {
    let reference = instrument::calib::REFERENCE;
    let pm = |g: usize, k: f64, d: usize| match f.sigma[g].is_nan() {
        true if f.values[g] <= BOUNDS[g].0 => "none".to_string(),
        true => format!("{:.*} (limit)", d, f.values[g] * k),
        false => format!("{:.*} ± {:.*}", d, f.values[g] * k, d, f.sigma[g] * k),
    };
    let off = rms(f
        .c_read_farad
        .iter()
        .zip(&f.c_farad)
        .map(|(r, c)| 100.0 * (r / c - 1.0)));
    let before = rms(f
        .c_read_farad
        .iter()
        .zip(s)
        .map(|(c, s)| reference.stretch(*c as f32) as f64 - s));
    let _ = write!(
        md,
        "| {i} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.2} | {off:.2} % | {before:.2} mm | stored |",
        f.records,
        pm(0, 1.0, 4),
        pm(1, 1e-3, 2),
        pm(2, 1e12, 3),
        pm(3, 1e3, 2),
        f.c_farad[0] * 1e12,
        f.r_ohm[0] / 1e3,
        f.chi2_dof,
    );
    let _ = match (open, f.open_cp) {
        (false, _) => writeln!(md),
        (true, Some((c, e))) => writeln!(md, " {:.3} ± {:.3} |", c * 1e12, e * 1e12),
        (true, None) => writeln!(md, " |"),
    };
}

/// One sensor measured again at known stretches (a device running with
/// its calibration).
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// Sensor.
    pub sensor: u8,
    /// Per hold (in the holds' order): the stretch held, mm, and the mean
    /// stretch of the records whose stretch the device vouched for (NaN:
    /// none).
    pub holds: Vec<(f64, f64)>,
    /// Records in the holds, and those whose stretch is vouched for.
    pub records: (usize, usize),
}

impl Check {
    /// RMS of the holds' errors, mm (NaN where a hold had no vouched
    /// record).
    pub fn rms_mm(&self) -> f64 {
        rms(self.holds.iter().map(|(want, got)| got - want))
    }
}

/// Each sensor's stretch at each hold, as the device read it: what a
/// calibration is judged by after the device restarted with it.
pub fn verify(records: &[link::Record], holds: &[Hold]) -> Vec<Check> {
    let mut sensors: Vec<u8> = records.iter().map(|r| r.sensor).collect();
    sensors.sort_unstable();
    sensors.dedup();
    sensors
        .into_iter()
        .map(|s| {
            let mut all = (0, 0);
            let holds = for_sensor(holds, s)
                .iter()
                .map(|h| {
                    let (mut sum, mut n) = (0.0, 0usize);
                    for r in records.iter().filter(|r| r.sensor == s) {
                        let t = r.t_us as f64 * 1e-6;
                        if t < h.from_s || t >= h.to_s {
                            continue;
                        }
                        all.0 += 1;
                        if Flags(r.flags).stretch_valid() {
                            all.1 += 1;
                            sum += r.stretch_mm as f64;
                            n += 1;
                        }
                    }
                    (h.stretch_mm, if n > 0 { sum / n as f64 } else { f64::NAN })
                })
                .collect();
            Check {
                sensor: s,
                holds,
                records: all,
            }
        })
        .collect()
}

/// The report of a check, Markdown: a row per sensor.
pub fn check_report(holds: &[Hold], checks: &[Check]) -> String {
    let mut md = format!(
        "{} holds ({:?} mm), each sensor's stretch as the device read it (the mean of the records whose \
         stretch it vouched for) against the stretch held.\n\n| sensor | stretch RMS over the holds | worst hold | \
         records vouched for |\n|---|---|---|---|\n",
        holds.len(),
        holds.iter().map(|h| h.stretch_mm).collect::<Vec<_>>()
    );
    for c in checks {
        let worst = c
            .holds
            .iter()
            .filter(|(_, got)| !got.is_nan())
            .max_by(|a, b| (a.1 - a.0).abs().total_cmp(&(b.1 - b.0).abs()))
            .map_or(String::new(), |(want, got)| {
                format!("{:+.3} mm at {want} mm", got - want)
            });
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} of {} |",
            c.sensor,
            match c.rms_mm() {
                v if v.is_nan() => "not vouched for at every hold".to_string(),
                v => format!("{v:.3} mm"),
            },
            worst,
            c.records.1,
            c.records.0
        );
    }
    md
}

/// RMS of `v` (NaN if empty).
pub(crate) fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}
