//! The figures of a firmware run against the simulated truth: one place
//! computes them, and the main job's summaries, the README's headline and
//! the docs' tables are all written from them (and checked against them
//! by the QEMU tests, through the `figures` crate).

use crate::records::{LoggedRecord, LoggedToneRecord};
use anyhow::{bail, Result};
use host_sim::numerics::rms_max;
use instrument::availability::Availability;
use std::fmt::Write as _;

/// The fixed frequency of the series meter the firmware is compared with,
/// Hz: the firmware's highest, 6 kHz's nearest coherent frequency.
pub const LUMPED_HZ: f64 = 5859.375;

/// What a series meter fixed at [`LUMPED_HZ`] would read on the true
/// sensor of `r` (its line through its tab leads), pF.
pub fn lumped(r: &LoggedRecord) -> Option<f64> {
    r.truth?.series_meter_pf(LUMPED_HZ)
}

/// How a channel's sensor was stretched, from its truth lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// Held at this stretch, mm.
    Held(f64),
    /// Moved from `lo` to `hi` mm at up to `rate` mm/s.
    Moving {
        /// Least stretch, mm.
        lo: f64,
        /// Largest stretch, mm.
        hi: f64,
        /// Fastest stretch rate seen between records, mm/s (rounded to
        /// whole mm/s: the rig's speed).
        rate: f64,
    },
}

impl Motion {
    fn of(recs: &[&LoggedRecord]) -> Motion {
        let s: Vec<(f64, f64)> = recs
            .iter()
            .filter_map(|r| Some((r.t_s, r.truth?.stretch_mm)))
            .collect();
        let (lo, hi) = s
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &(_, v)| {
                (a.min(v), b.max(v))
            });
        if hi - lo < 0.01 {
            return Motion::Held(lo);
        }
        let rate = s
            .windows(2)
            .filter(|w| w[1].0 > w[0].0)
            .map(|w| ((w[1].1 - w[0].1) / (w[1].0 - w[0].0)).abs())
            .fold(0.0, f64::max);
        Motion::Moving {
            lo,
            hi,
            rate: rate.round(),
        }
    }
}

impl std::fmt::Display for Motion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Motion::Held(s) => write!(f, "held at {s:.0} mm"),
            Motion::Moving { lo, hi, rate } => {
                write!(f, "{lo:.0}–{hi:.0} mm at {rate:.0} mm/s")
            }
        }
    }
}

/// One channel of the multiplexed firmware's run.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelFigures {
    /// Channel.
    pub channel: u8,
    /// How its sensor was stretched.
    pub motion: Motion,
    /// Its records: how many, the share valid, and why the others were
    /// not.
    pub availability: Availability,
    /// Line-corrected C against the truth over the valid records: RMS and
    /// max, pF.
    pub c_pf: (f64, f64),
    /// The same relative to the true C, %.
    pub c_pct: (f64, f64),
    /// Stretch against the truth, RMS, mm.
    pub stretch_rms_mm: f64,
    /// A series meter fixed at [`LUMPED_HZ`] on the same sensor: RMS and
    /// max error, pF.
    pub lumped_pf: (f64, f64),
}

/// The figures of every channel of a multiplexed run (`skin-qemu`).
pub fn channels(recs: &[LoggedRecord]) -> Vec<ChannelFigures> {
    let mut ids: Vec<u8> = recs.iter().map(|r| r.sensor).collect();
    ids.sort_unstable();
    ids.dedup();
    ids.into_iter()
        .map(|ch| {
            let rs: Vec<&LoggedRecord> = recs.iter().filter(|r| r.sensor == ch).collect();
            let valid: Vec<&&LoggedRecord> = rs.iter().filter(|r| r.valid() && r.truth.is_some()).collect();
            let err = |r: &&&LoggedRecord| r.truth.map_or(f64::NAN, |t| r.c_pf - t.c_pf);
            let (rms, mx, _) = rms_max(valid.iter().map(err));
            let (rrms, rmx, _) = rms_max(
                valid
                    .iter()
                    .map(|r| 100.0 * err(r) / r.truth.map_or(f64::NAN, |t| t.c_pf)),
            );
            let (srms, _, _) = rms_max(
                valid
                    .iter()
                    .map(|r| r.stretch_mm - r.truth.map_or(f64::NAN, |t| t.stretch_mm)),
            );
            let (lrms, lmx, _) = rms_max(rs.iter().filter_map(|r| Some(lumped(r)? - r.truth?.c_pf)));
            ChannelFigures {
                channel: ch,
                motion: Motion::of(&rs),
                availability: availability(rs.iter().map(|r| r.flags)),
                c_pf: (rms, mx),
                c_pct: (rrms, rmx),
                stretch_rms_mm: srms,
                lumped_pf: (lrms, lmx),
            }
        })
        .collect()
}

/// The table of [`channels`], a row per channel.
pub fn channel_table(rows: &[ChannelFigures]) -> String {
    let mut md = String::from(
        "| channel | stretching | records | valid | not valid: faults | C RMS | C max | stretch RMS | fixed 6 kHz series meter, RMS |\n\
         |---:|---|---:|---:|---|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {:.2} pF ({:.3} %) | {:.2} pF ({:.3} %) | {:.3} mm | {:.1} pF |",
            r.channel,
            r.motion,
            r.availability.records,
            percent(&r.availability),
            r.availability.why(),
            r.c_pf.0,
            r.c_pct.0,
            r.c_pf.1,
            r.c_pct.1,
            r.stretch_rms_mm,
            r.lumped_pf.0
        );
    }
    md
}

/// One sensor of the array's run.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorFigures {
    /// Sensor.
    pub sensor: u8,
    /// Its records: how many, the share valid, and why the others were
    /// not.
    pub availability: Availability,
    /// Records per second.
    pub rate: f64,
    /// Line-corrected C against the truth over the valid records: RMS and
    /// max, %.
    pub c_pct: (f64, f64),
    /// The tones its records used, Hz.
    pub tones: Vec<u32>,
}

/// The figures of every sensor of an array run (`skin-array`).
pub fn sensors(recs: &[LoggedToneRecord]) -> Result<Vec<SensorFigures>> {
    let mut ids: Vec<u8> = recs.iter().map(|r| r.rec.sensor).collect();
    ids.sort_unstable();
    ids.dedup();
    ids.into_iter()
        .map(|s| {
            let rs: Vec<&LoggedToneRecord> = recs.iter().filter(|r| r.rec.sensor == s).collect();
            let (Some(first), Some(last)) = (rs.first(), rs.last()) else {
                bail!("sensor {s}: no records");
            };
            if rs.len() < 2 || last.t_s() <= first.t_s() {
                bail!("sensor {s}: too few records for a rate");
            }
            let valid: Vec<&&LoggedToneRecord> = rs.iter().filter(|r| r.rec.flags.valid()).collect();
            let (rms, mx, _) = rms_max(valid.iter().filter_map(|r| Some(100.0 * r.c_error()?)));
            let mut tones: Vec<u32> = rs.iter().flat_map(|r| r.rec.f_hz.map(|f| f as u32)).collect();
            tones.sort_unstable();
            tones.dedup();
            Ok(SensorFigures {
                sensor: s,
                availability: availability(rs.iter().map(|r| r.rec.flags)),
                rate: (rs.len() - 1) as f64 / (last.t_s() - first.t_s()),
                c_pct: (rms, mx),
                tones,
            })
        })
        .collect()
}

/// The table of [`sensors`], a row per sensor.
pub fn sensor_table(rows: &[SensorFigures]) -> String {
    let mut md = String::from(
        "| sensor | records | per second | valid | not valid: faults | C RMS | C max | tones used [Hz] |\n\
         |---:|---:|---:|---:|---|---:|---:|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {:.1} | {} | {} | {:.3} % | {:.3} % | {:?} |",
            r.sensor,
            r.availability.records,
            r.rate,
            percent(&r.availability),
            r.availability.why(),
            r.c_pct.0,
            r.c_pct.1,
            r.tones
        );
    }
    md
}

/// The availability of records with these flags.
pub fn availability(flags: impl IntoIterator<Item = instrument::faults::Flags>) -> Availability {
    let mut a = Availability::new();
    for f in flags {
        a.count(f);
    }
    a
}

/// A table cell: the share valid with its counts, `97.2 % (2187 of 2250)`.
pub fn percent(a: &Availability) -> String {
    format!(
        "{:.1} % ({} of {})",
        100.0 * a.share().unwrap_or(0.0),
        a.valid,
        a.records
    )
}

/// Least and largest of `v` as "a–b" (or "a" when they agree) with
/// `decimals`.
pub fn span(v: impl IntoIterator<Item = f64>, decimals: usize) -> String {
    let (lo, hi) = v
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    let (a, b) = (format!("{lo:.decimals$}"), format!("{hi:.decimals$}"));
    if a == b {
        a
    } else {
        format!("{a}–{b}")
    }
}

/// The headline figures of a multiplexed run: each moving channel's C
/// error, and what a fixed 6 kHz series meter reads on the first (a
/// table of `figures`).
pub fn channel_headline(channels: &[ChannelFigures]) -> String {
    let mut rows = vec![];
    let moving: Vec<&ChannelFigures> = channels
        .iter()
        .filter(|c| matches!(c.motion, Motion::Moving { .. }))
        .collect();
    for c in &moving {
        rows.push((
            format!(
                "C error, multiplexed firmware in QEMU, channel {} ({})",
                c.channel, c.motion
            ),
            format!(
                "{:.3} % RMS, {:.3} % max ({} of {} records valid)",
                c.c_pct.0, c.c_pct.1, c.availability.valid, c.availability.records
            ),
        ));
    }
    if let Some(c) = moving.first() {
        rows.push((
            format!(
                "the same sensor (channel {}) read by a series meter fixed at 6 kHz",
                c.channel
            ),
            format!("{:.1} pF RMS off", c.lumped_pf.0),
        ));
    }
    figures::table(&rows)
}

/// The headline figures of an array run (a table of `figures`).
pub fn sensor_headline(sensors: &[SensorFigures]) -> String {
    let mut all = Availability::new();
    for s in sensors {
        all.add(&s.availability);
    }
    figures::table(&[(
        format!(
            "C error, array firmware in QEMU, {} sensors at once, {} records/s each",
            sensors.len(),
            span(sensors.iter().map(|s| s.rate), 1)
        ),
        format!(
            "{} % RMS, {} % max per sensor ({} of {} records valid, {} % per sensor)",
            span(sensors.iter().map(|s| s.c_pct.0), 3),
            span(sensors.iter().map(|s| s.c_pct.1), 2),
            all.valid,
            all.records,
            span(
                sensors
                    .iter()
                    .filter_map(|s| Some(100.0 * s.availability.share()?)),
                1
            )
        ),
    )])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn span_joins_least_and_largest() {
        assert_eq!(span([0.0571, 0.0612, 0.058], 3), "0.057–0.061");
        assert_eq!(span([250.0, 250.0], 1), "250.0");
    }
}
