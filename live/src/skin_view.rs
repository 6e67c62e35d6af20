//! The dashboard of a skin of several boards: every board's records on
//! one page, each sensor by its number in the skin's description (its
//! place in the file), its time the skin's axis (the host's UTC through
//! its board's clock fit as it stands, less the session's start); each
//! board's device, clock and link in the `boards` event. Records pass
//! to the open pages as they arrive and are not held for pages opened
//! later (each board's own recording holds them).

use crate::dashboard::Dashboard;
use crate::session::{Arrived, Session};
use crate::skin::Skin;
use serde_json::{json, Value};
use std::collections::BTreeMap;

/// One board's side of the skin's dashboard.
#[derive(Clone, Debug)]
pub struct SkinView {
    /// The board's name.
    pub board: String,
    /// Its inputs' numbers in the skin (an input the skin does not name
    /// is not shown).
    pub numbers: BTreeMap<u8, u8>,
    /// The skin's time 0: the host's UTC, s since the Unix epoch.
    pub epoch_utc_s: f64,
    /// How often its port was opened again.
    pub reconnects: u32,
}

impl SkinView {
    /// Board `board` of `skin`, its time counted from `epoch_utc_s`.
    pub fn new(skin: &Skin, board: &str, epoch_utc_s: f64) -> Self {
        let numbers = skin
            .sensors
            .iter()
            .enumerate()
            .filter(|(n, s)| s.board == board && *n < 256)
            .map(|(n, s)| (s.index, n as u8))
            .collect();
        Self {
            board: board.to_string(),
            numbers,
            epoch_utc_s,
            reconnects: 0,
        }
    }

    /// The records `session` just took, on the skin's numbers and axis,
    /// to the pages; the board's health and availability (at the end:
    /// `last`).
    pub fn show(&self, d: &Dashboard, session: &Session, last: bool) {
        let mapped: Vec<Arrived> = session
            .fresh()
            .iter()
            .filter_map(|a| self.map(session, a))
            .collect();
        d.passing(&mapped);
        let rows = session
            .availability()
            .iter()
            .filter_map(|(i, a)| {
                let filled = session.interpolated().get(i).copied().unwrap_or(0);
                Some(crate::summary::availability_json(
                    *self.numbers.get(i)?,
                    a,
                    filled,
                ))
            })
            .collect();
        d.board(&self.board, self.health(session), rows, last);
    }

    /// Record `a` on the skin's number and axis (none: its input is not
    /// in the skin, or it has no time on the host's clock yet).
    fn map(&self, session: &Session, a: &Arrived) -> Option<Arrived> {
        let number = *self.numbers.get(&a.record.sensor)?;
        let line = session
            .segments()
            .get(a.segment.checked_sub(1)? as usize)?
            .clock
            .line();
        let host_s = match (line, a.host_utc_us) {
            (Some(l), _) => l.host_of(a.record.t_us as f64 * 1e-6),
            (None, Some(us)) => us as f64 * 1e-6,
            (None, None) => return None,
        };
        let mut m = *a;
        m.record.sensor = number;
        m.record.t_us = ((host_s - self.epoch_utc_s).max(0.0) * 1e6).round() as u64;
        Some(m)
    }

    /// The board's device, clock and link as the `boards` event gives it.
    fn health(&self, session: &Session) -> Value {
        let seg = session.segments().last();
        let stats = session.stats();
        json!({
            "board": self.board,
            "device_id": seg.map(|g| format!("{:08x}", g.start.device_id)),
            "self_test": seg.map(|g| crate::self_test::json(&g.start.self_test, g.start.sensors)),
            "segments": session.segments().len(),
            "records": session.segments().iter().map(|g| g.records).sum::<u64>(),
            "frames": stats.frames,
            "refused": stats.bad,
            "lost": stats.lost,
            "reconnects": self.reconnects,
            "clock": seg.and_then(|g| g.clock.line()).map(|l| l.json()),
            "ended": session.end().is_some(),
        })
    }
}

/// The skin's layout for its dashboard: each sensor's name, group,
/// place and outline by its number, and the boards' names.
pub fn layout_json(skin: &Skin, boards: &[&str]) -> Value {
    let field =
        |f: &dyn Fn(&crate::skin::Sensor) -> Value| skin.sensors.iter().take(256).map(f).collect::<Vec<_>>();
    json!({
        "segment": null,
        "sensors": skin.sensors.len().min(256),
        "skin": skin.name,
        "boards": boards,
        "names": field(&|s| json!(s.name)),
        "groups": field(&|s| json!(s.group)),
        "places": field(&|s| json!(s.place)),
        "outlines": field(&|s| json!(s.outline)),
        "board_of": field(&|s| json!(s.board)),
    })
}
