//! A session's manifest, `session.json`: written when the session ends,
//! never before, so that a folder without one is a session that did not
//! end (killed, crashed, out of disk). It says how the stream ended, the
//! device's runs (segments: each start frame's firmware, digests and
//! sensors, and what arrived), the link's counts, the end frame's counts
//! checked against what arrived, each segment's clock fitted to the
//! host's UTC, the markers' count, and the data set's files.

use crate::session::{Finished, Outcome, Segment, Session};
use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::io::Write;

/// The manifest's file name.
pub use host_sim::recording::MANIFEST;

/// The manifest's layout version.
const LAYOUT: u32 = 3;

/// Write `session`'s manifest (replacing none: created once, whole).
pub(crate) fn write(session: &Session, done: &Finished) -> Result<()> {
    let text = serde_json::to_string_pretty(&manifest(session, done))?;
    let dir = session.dir();
    let mut tmp = tempfile::Builder::new()
        .prefix(".session-")
        .tempfile_in(dir)
        .with_context(|| format!("a new {MANIFEST} in {}", dir.display()))?;
    tmp.write_all(text.as_bytes())?;
    tmp.write_all(b"\n")?;
    tmp.as_file().sync_all()?;
    let path = dir.join(MANIFEST);
    tmp.persist_noclobber(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// The manifest's contents.
fn manifest(session: &Session, done: &Finished) -> Value {
    let s = &done.summary;
    let w = &done.written;
    let name = |p: &std::path::PathBuf| p.file_name().map(|n| n.to_string_lossy().into_owned());
    json!({
        "layout": LAYOUT,
        "tool": concat!("live ", env!("CARGO_PKG_VERSION")),
        "opened_utc": session.opened.map(|t| t.to_rfc3339()),
        "ended_utc": chrono::Utc::now().to_rfc3339(),
        "complete": done.outcome.is_complete(),
        "outcome": match &done.outcome {
            Outcome::Complete => "the stream ended with its end frame".to_string(),
            Outcome::Stopped => format!(
                "stopped by the user after {} records, the device running on: every record that arrived until then",
                s.records
            ),
            Outcome::Incomplete(why) => why.clone(),
        },
        "segments": session.segments().iter().map(|g| segment(g, session.skin())).collect::<Vec<_>>(),
        "skin": session.skin().map(|b| json!({
            "name": b.skin,
            "board": b.board,
            "sensors": b.sensors,
        })),
        "markers": session.markers(),
        "bytes": s.bytes,
        "frames": {
            "decoded": s.link.frames,
            "refused": s.link.bad,
            "lost": s.link.lost,
            "duplicates": s.link.repeated,
            "stray": session.stray,
        },
        "records": {
            "kept": s.records,
            "flagged": s.flagged,
            "set_aside_beyond_sensors": s.set_aside.beyond_sensors,
            "set_aside_not_later": s.set_aside.not_later,
            "per_sensor": s.availability.iter().map(|(&sensor, a)| {
                let interpolated = s.interpolated.get(&sensor).copied().unwrap_or(0);
                let mut row = crate::summary::availability_json(sensor, a, interpolated);
                if let Some(name) = session.skin().and_then(|b| b.name_of(sensor)) {
                    row["name"] = json!(name);
                }
                row
            }).collect::<Vec<_>>(),
        },
        "dataset": {
            "traces": w.traces.iter().filter_map(name).collect::<Vec<_>>(),
            "fragments": w.fragments.iter().filter_map(name).collect::<Vec<_>>(),
            "trace_rows": w.rows,
            "calibration_points": w.calibration_points,
            "faults": w.faults,
            "left_out": w.left_out,
        },
    })
}

/// One segment's entry: its start frame, what arrived, its end frame's
/// counts and whether they agree, and (with a skin) the sensors the
/// skin and the device do not share.
fn segment(g: &Segment, skin: Option<&crate::skin::Board>) -> Value {
    json!({
        "firmware": g.start.firmware_str(),
        "wire_version": g.start.version,
        "settings_digest": format!("{:08x}", g.start.settings_digest),
        "calibration_digest": format!("{:08x}", g.start.calibration_digest),
        "sensors": g.start.sensors,
        "sample_rate_hz": g.start.sample_rate_hz,
        // The power-up self-test the device ran before its first record.
        "self_test": crate::self_test::json(&g.start.self_test, g.start.sensors),
        "skin_mismatch": skin.map(|b| b.mismatch(g.start.sensors, g.start.device_id)),
        // The id the device reports (a board's: from its chip's unique
        // ID), which names it among a skin's boards.
        "device_id": format!("{:08x}", g.start.device_id),
        // The stored set's generation at the start (0: none stored), and
        // every set in force during the segment: the first from its
        // start, then each one the device applied while it ran, in force
        // for the records numbered after from_seq.
        "generation": g.start.generation,
        "settings_in_force": g.in_force().iter().map(|(seq, a)| json!({
            "generation": a.generation,
            "from_seq": seq,
            "t_us": a.t_us,
            "settings_digest": format!("{:08x}", a.settings_digest),
            "calibration_digest": format!("{:08x}", a.calibration_digest),
        })).collect::<Vec<_>>(),
        "first_seq": g.first_seq,
        // The recording started while the device ran (its start frame
        // written again by `live`, numbered first_seq).
        "joined": g.joined(),
        "last_seq": g.high_seq,
        "records_arrived": g.arrived,
        "records_kept": g.records,
        "frames_lost": g.lost(),
        "frames_duplicate": g.duplicates,
        // The device's clock against the host's UTC (the arrival line:
        // its offset holds the link's mean delay); null without arrival
        // times (a replay without them) or before two reads of records.
        "clock": g.clock.line().map(|l| l.json()),
        "cpu": g.cpu.map(|c| json!({
            "clock": c.unit(),
            "clock_hz": c.last.clock_hz,
            "period": c.last.period,
            "reports": c.reports,
            "blocks": c.blocks,
            "mean": c.mean,
            "max": c.max,
            "mean_share_percent": c.share(c.mean),
            "max_share_percent": c.share(f64::from(c.max)),
            "late": c.late,
            "missed": c.missed,
        })),
        "end": g.end.map(|e| json!({
            "records_sent": e.records,
            "dropped_on_device": e.dropped,
            "agrees": g.end_mismatch().is_none(),
            "mismatch": g.end_mismatch(),
        })),
    })
}
