//! The dashboard: a local web page of a running skin, served on
//! 127.0.0.1 while a session runs. The page (`web/index.html`) charts C,
//! R, stretch, the chosen frequency and the flags of the sensor chosen,
//! and shows every sensor's latest record; records reach it by
//! server-sent events (`/events`: first the latest records so far, read
//! from the session's `records.csv` in pages, then each batch as it
//! arrives). The server holds only the records not yet written to
//! `records.csv`, and each open page a page of it: its memory does not
//! grow with the session, nor with the pages open. The chart library (uPlot, from npm, with its
//! licence at `/uPlot.LICENSE`) is embedded in the binary: the page loads
//! nothing from the internet. A request is served only where its `Host`
//! names the bound address (or `localhost` and its port): a page of
//! another site that a DNS rebinding points at 127.0.0.1 gets nothing.
//! A page that falls behind the records is told the gap and reconnects
//! for the backlog, so it never shows fewer records without saying so.

use crate::markers::{Mark, Marker};
use crate::recorder::Command;
use crate::session::Arrived;
use anyhow::{Context, Result};
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use futures_util::stream::{self, Stream, StreamExt};
use instrument::availability::Availability;
use std::collections::{BTreeMap, VecDeque};
use std::convert::Infallible;
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use tokio::sync::broadcast;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;

const INDEX: &str = include_str!("../web/index.html");
const UPLOT_JS: &[u8] = include_bytes!(concat!(env!("UPLOT_DIST"), "/uPlot.iife.min.js"));
const UPLOT_CSS: &[u8] = include_bytes!(concat!(env!("UPLOT_DIST"), "/uPlot.min.css"));
const UPLOT_LICENSE: &[u8] = include_bytes!(env!("UPLOT_LICENSE"));

/// The live feed's version: what [`FIELDS`] and the events hold.
pub const FEED_VERSION: u32 = 2;

/// The fields of a record in the feed, in order: (name, unit). The first
/// seven are those of the feed before it was versioned, the next ten
/// version 1's, `host_utc_s` version 2's (a version only adds fields at
/// the end); a value the record lacks is null.
pub const FIELDS: [(&str, &str); 18] = [
    ("t_s", "s"),
    ("sensor", ""),
    ("c_pf", "pF"),
    ("r_ohm", "Ω"),
    ("stretch_mm", "mm"),
    ("chosen_hz", "Hz"),
    ("flag_bits", ""),
    ("segment", ""),
    ("seq", ""),
    ("f1_hz", "Hz"),
    ("z1_re_ohm", "Ω"),
    ("z1_im_ohm", "Ω"),
    ("f2_hz", "Hz"),
    ("z2_re_ohm", "Ω"),
    ("z2_im_ohm", "Ω"),
    ("chi2", ""),
    ("sigma_ln_c", ""),
    ("host_utc_s", "s"),
];

/// The feed's `schema` event: its version, the record's fields with
/// their units, and the flags' bits by name (which are faults).
pub fn schema_json() -> String {
    let flags: Vec<serde_json::Value> = (0..16u32)
        .filter_map(|bit| {
            let name = instrument::faults::Flags(1 << bit).names().next()?;
            Some(serde_json::json!({
                "bit": bit,
                "name": name,
                "fault": instrument::faults::Flags(1 << bit).0 & instrument::faults::Flags::FAULTS != 0,
            }))
        })
        .collect();
    serde_json::json!({
        "version": FEED_VERSION,
        "fields": FIELDS.iter().map(|(n, u)| serde_json::json!({"name": n, "unit": u})).collect::<Vec<_>>(),
        "flags": flags,
    })
    .to_string()
}

/// A finite value, or null.
fn value(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::Value::from(x)
    } else {
        serde_json::Value::Null
    }
}

/// What the page is sent: a batch of records as JSON, each an array of
/// [`FIELDS`].
fn batch_json(records: &[Arrived]) -> String {
    let rows: Vec<serde_json::Value> = records
        .iter()
        .map(|a| {
            let r = &a.record;
            let [t1, t2] = r.tones;
            serde_json::json!([
                r.t_us as f64 * 1e-6,
                r.sensor,
                value(r.c_farad as f64 * 1e12),
                value(r.r_ohm.into()),
                value(r.stretch_mm.into()),
                value(r.chosen_hz.into()),
                r.flags,
                a.segment,
                a.seq,
                value(t1.f_hz.into()),
                value(t1.z_re_ohm.into()),
                value(t1.z_im_ohm.into()),
                value(t2.f_hz.into()),
                value(t2.z_re_ohm.into()),
                value(t2.z_im_ohm.into()),
                value(r.chi2.into()),
                value(r.sigma_ln_c.into()),
                a.host_utc_us
                    .map_or(serde_json::Value::Null, |us| value(us as f64 * 1e-6))
            ])
        })
        .collect();
    serde_json::Value::Array(rows).to_string()
}

/// What the open pages are sent after their backlog.
#[derive(Clone, Debug)]
enum Message {
    /// New records, as JSON.
    Batch(Arc<String>),
    /// A named event's value, as JSON: `cpu` (how the device's CPU
    /// keeps up), `valid` (each sensor's share of records valid),
    /// `device` (its run and clock fit), `marker` (a marker written).
    Named(&'static str, Arc<String>),
    /// The stream is over: nothing more will come.
    End,
}

/// The records written to `records.csv` (how many, and its length in
/// bytes), those not yet (each with its index), whether the stream is
/// over, and the channel that carries what comes next.
#[derive(Clone)]
struct Shared {
    state: Arc<Mutex<Held>>,
    messages: broadcast::Sender<Message>,
    /// Where the page's markers go: the session's loop.
    marks: Option<std::sync::mpsc::Sender<Mark>>,
    /// Where the page's start and stop go: the session's loop.
    commands: Option<std::sync::mpsc::Sender<Command>>,
}

/// What the dashboard holds.
#[derive(Default)]
struct Held {
    on_disk: OnDisk,
    tail: VecDeque<(u64, Arrived)>,
    next: u64,
    ended: bool,
    /// Each named event's latest value, as JSON.
    latest: Vec<(&'static str, Arc<String>)>,
    /// When `valid` was last sent to the pages.
    valid_sent: Option<std::time::Instant>,
    /// When `device` was last sent to the pages, and of which segment.
    device_sent: Option<(u32, std::time::Instant)>,
    /// The running recording's `records.csv` (none: not recording).
    records_csv: Option<PathBuf>,
    /// The skin's sensors on this board, where described.
    skin: Option<Arc<crate::skin::Board>>,
    /// A skin of several boards: each board's health, and each board's
    /// sensors' availability (keyed by the skin's sensor numbers), with
    /// when the merged events were last sent.
    boards: BTreeMap<String, serde_json::Value>,
    boards_sent: Option<std::time::Instant>,
    valid_by_board: BTreeMap<String, Vec<serde_json::Value>>,
}

/// How much of `records.csv` holds whole records: how many, and its
/// length in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OnDisk {
    /// Records written.
    pub records: u64,
    /// Bytes written (whole lines, its header included).
    pub bytes: u64,
}

/// A running dashboard: hand it records as they arrive, and say how much
/// of `records.csv` is written.
pub struct Dashboard {
    shared: Shared,
    addr: SocketAddr,
    _runtime: tokio::runtime::Runtime,
}

impl Dashboard {
    /// Serve on `addr` (127.0.0.1 and a port; port 0 picks a free one);
    /// the page's markers are sent to `marks`, its start and stop to
    /// `commands` (none: refused). What records where is said by
    /// [`Dashboard::recording`].
    pub fn serve(
        addr: SocketAddr,
        marks: Option<std::sync::mpsc::Sender<Mark>>,
        commands: Option<std::sync::mpsc::Sender<Command>>,
    ) -> Result<Self> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .context("starting the dashboard's runtime")?;
        let (messages, _) = broadcast::channel(BATCHES_BEHIND);
        let shared = Shared {
            state: Arc::new(Mutex::new(Held::default())),
            messages,
            marks,
            commands,
        };
        let listener = runtime
            .block_on(tokio::net::TcpListener::bind(addr))
            .with_context(|| format!("serving the dashboard on {addr} (in use?)"))?;
        let addr = listener.local_addr()?;
        let app = Router::new()
            .route(
                "/",
                get(|| async { ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], INDEX) }),
            )
            .route(
                "/uPlot.iife.min.js",
                get(|| async { ([(header::CONTENT_TYPE, "text/javascript")], UPLOT_JS) }),
            )
            .route(
                "/uPlot.min.css",
                get(|| async { ([(header::CONTENT_TYPE, "text/css")], UPLOT_CSS) }),
            )
            .route(
                "/uPlot.LICENSE",
                get(|| async { ([(header::CONTENT_TYPE, "text/plain")], UPLOT_LICENSE) }),
            )
            .route("/events", get(events))
            .route("/marker", post(marker))
            .route("/recording", post(recording))
            .with_state(shared.clone())
            .layer(middleware::from_fn_with_state(hosts(addr), this_host_only));
        runtime.spawn(async move {
            let _ = axum::serve(listener, app).await;
        });
        Ok(Self {
            shared,
            addr,
            _runtime: runtime,
        })
    }

    /// Where it serves.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    fn state(&self) -> std::sync::MutexGuard<'_, Held> {
        self.shared.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Records that arrived: held until they are written, and pushed to
    /// the open pages.
    pub fn push(&self, records: &[Arrived]) {
        if records.is_empty() {
            return;
        }
        let batch = Arc::new(batch_json(records));
        // Under the lock, so that a page that opens now gets each record
        // once: in its backlog or in a batch.
        let mut state = self.state();
        for r in records {
            let k = state.next;
            state.tail.push_back((k, *r));
            state.next += 1;
        }
        let _ = self.shared.messages.send(Message::Batch(batch));
    }

    /// `records.csv` holds the first `on_disk.records` records: those are
    /// read from it, no longer held.
    pub fn written(&self, on_disk: OnDisk) {
        let mut state = self.state();
        while state.tail.front().is_some_and(|(k, _)| *k < on_disk.records) {
            state.tail.pop_front();
        }
        state.on_disk = on_disk;
    }

    /// The device's status (how its CPU keeps up): sent to the open
    /// pages, and kept for those that open later.
    pub fn status(&self, s: &link::Status) {
        let share = |t: f64| 100.0 * t / f64::from(s.period.max(1));
        let json = Arc::new(
            serde_json::json!({
                "t_us": s.t_us,
                "clock": match s.clock {
                    link::Clock::Cycles => "cycles",
                    link::Clock::Instructions => "instructions",
                },
                "clock_hz": s.clock_hz,
                "period": s.period,
                "blocks": s.blocks,
                "mean": s.mean,
                "max": s.max,
                "mean_share_percent": share(f64::from(s.mean)),
                "max_share_percent": share(f64::from(s.max)),
                "late": s.late,
                "missed": s.missed,
            })
            .to_string(),
        );
        self.named("cpu", json, true);
    }

    /// Each sensor's share of records valid so far, and the faults that
    /// stood on the others: at most once a second, or whenever `last`
    /// (the stream's end) says so, sent to the open pages and kept for
    /// those that open later (built only then: a session calls this for
    /// every chunk it reads).
    pub fn availability(
        &self,
        per_sensor: &BTreeMap<u8, Availability>,
        interpolated: &BTreeMap<u8, u64>,
        last: bool,
    ) {
        let now = std::time::Instant::now();
        {
            let mut state = self.state();
            let due = last
                || state
                    .valid_sent
                    .is_none_or(|t| now.duration_since(t) >= std::time::Duration::from_secs(1));
            if !due {
                return;
            }
            state.valid_sent = Some(now);
        }
        let rows: Vec<serde_json::Value> = per_sensor
            .iter()
            .map(|(&s, a)| {
                let filled = interpolated.get(&s).copied().unwrap_or(0);
                crate::summary::availability_json(s, a, filled)
            })
            .collect();
        let json = Arc::new(serde_json::Value::Array(rows).to_string());
        self.named("valid", json, true);
    }

    /// A recording starts (its folder) or stops (none): records are held
    /// and counted from its start, a page's backlog read from its
    /// `records.csv`; the pages are told (event `recording`, kept).
    pub fn recording(&self, dir: Option<&Path>) {
        {
            let mut state = self.state();
            state.records_csv = dir.map(|d| d.join(crate::RECORDS_CSV));
            state.tail.clear();
            state.next = 0;
            state.on_disk = OnDisk::default();
        }
        let json = serde_json::json!({
            "recording": dir.is_some(),
            "folder": dir.map(|d| d.display().to_string()),
        });
        self.named("recording", Arc::new(json.to_string()), true);
    }

    /// Records that arrived while nothing records: sent to the open
    /// pages, not held (a page that opens later starts from then).
    pub fn passing(&self, records: &[Arrived]) {
        if !records.is_empty() {
            let _ = self
                .shared
                .messages
                .send(Message::Batch(Arc::new(batch_json(records))));
        }
    }

    /// The skin whose sensors the board's are: their names, groups and
    /// places go with the `device` event.
    pub fn set_skin(&self, skin: Arc<crate::skin::Board>) {
        self.state().skin = Some(skin);
    }

    /// A marker written: sent to the open pages (event `marker`).
    pub fn marker(&self, m: &Marker) {
        if let Ok(json) = serde_json::to_string(m) {
            let _ = self
                .shared
                .messages
                .send(Message::Named("marker", Arc::new(json)));
        }
    }

    /// The device's run (`segment` of the session, its start frame) and
    /// its clock fitted to the host's so far: at once for a new run,
    /// else at most once a second, sent to the open pages (event
    /// `device`) and kept for those that open later.
    pub fn device(&self, segment: u32, start: &link::Start, clock: Option<crate::clock::Line>) {
        let skin = {
            let mut state = self.state();
            let t = std::time::Instant::now();
            let recent = state.device_sent.is_some_and(|(g, s)| {
                g == segment && t.duration_since(s) < std::time::Duration::from_secs(1)
            });
            if recent {
                return;
            }
            state.device_sent = Some((segment, t));
            state.skin.clone()
        };
        // Each input's sensor as the skin names it (null: not named).
        let named = |f: &dyn Fn(&crate::skin::Sensor) -> serde_json::Value| {
            skin.as_ref().map(|b| {
                (0..start.sensors)
                    .map(|i| {
                        b.sensors
                            .iter()
                            .find(|s| s.index == i)
                            .map_or(serde_json::Value::Null, f)
                    })
                    .collect::<Vec<_>>()
            })
        };
        let json = serde_json::json!({
            "segment": segment,
            "firmware": start.firmware_str(),
            "device_id": format!("{:08x}", start.device_id),
            "generation": start.generation,
            "sensors": start.sensors,
            "sample_rate_hz": start.sample_rate_hz,
            "self_test": crate::self_test::json(&start.self_test, start.sensors),
            "clock": clock.map(|l| l.json()),
            "skin": skin.as_ref().map(|b| b.skin.clone()),
            "names": named(&|s| serde_json::json!(s.name)),
            "groups": named(&|s| serde_json::json!(s.group)),
            "places": named(&|s| serde_json::json!(s.place)),
            "outlines": named(&|s| serde_json::json!(s.outline)),
        });
        self.named("device", Arc::new(json.to_string()), true);
    }

    /// A skin of several boards: its layout by the skin's sensor numbers
    /// (event `device`, with `boards`: their names), sent and kept.
    pub fn skin_layout(&self, json: serde_json::Value) {
        self.named("device", Arc::new(json.to_string()), true);
    }

    /// A skin of several boards: board `name`'s health (its device,
    /// clock, records, link) and its sensors' availability rows (keyed by
    /// the skin's sensor numbers); the merged events (`boards`, `valid`)
    /// sent at most once a second, or at once where `now` says.
    pub fn board(&self, name: &str, health: serde_json::Value, valid: Vec<serde_json::Value>, now: bool) {
        let t = std::time::Instant::now();
        let (boards, rows) = {
            let mut state = self.state();
            state.boards.insert(name.to_string(), health);
            state.valid_by_board.insert(name.to_string(), valid);
            let due = now
                || state
                    .boards_sent
                    .is_none_or(|s| t.duration_since(s) >= std::time::Duration::from_secs(1));
            if !due {
                return;
            }
            state.boards_sent = Some(t);
            let boards: Vec<serde_json::Value> = state.boards.values().cloned().collect();
            let rows: Vec<serde_json::Value> = state.valid_by_board.values().flatten().cloned().collect();
            (boards, rows)
        };
        self.named(
            "boards",
            Arc::new(serde_json::Value::Array(boards).to_string()),
            true,
        );
        self.named(
            "valid",
            Arc::new(serde_json::Value::Array(rows).to_string()),
            true,
        );
    }

    /// Keep `json` as event `name`'s latest value, and send it to the
    /// open pages where asked.
    fn named(&self, name: &'static str, json: Arc<String>, send: bool) {
        let mut state = self.state();
        match state.latest.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = json.clone(),
            None => state.latest.push((name, json.clone())),
        }
        if send {
            let _ = self.shared.messages.send(Message::Named(name, json));
        }
    }

    /// The stream is over: the pages are told, and their event streams
    /// close (a page that opens later gets the latest records and the
    /// end).
    pub fn end(&self) {
        let mut state = self.state();
        state.ended = true;
        // Each named event's last value (one held back by its pace
        // included), then the end.
        for (name, json) in &state.latest {
            let _ = self.shared.messages.send(Message::Named(name, json.clone()));
        }
        let _ = self.shared.messages.send(Message::End);
    }
}

/// How many batches a page may fall behind the newest before it is told
/// the gap (and reconnects for the backlog).
const BATCHES_BEHIND: usize = 1024;

/// The `Host` values a request may carry: the bound address, and
/// `localhost` with its port.
fn hosts(addr: SocketAddr) -> Arc<[String]> {
    Arc::from([addr.to_string(), format!("localhost:{}", addr.port())])
}

/// Serve a request only where its `Host` is one of `allowed`: 421
/// otherwise (a DNS rebinding's name, or none).
async fn this_host_only(State(allowed): State<Arc<[String]>>, request: Request, next: Next) -> Response {
    let host = request.headers().get(header::HOST).and_then(|h| h.to_str().ok());
    match host {
        Some(h) if allowed.iter().any(|a| a.eq_ignore_ascii_case(h)) => next.run(request).await,
        _ => (
            StatusCode::MISDIRECTED_REQUEST,
            "this dashboard answers requests for its own address only\n",
        )
            .into_response(),
    }
}

/// What a page's event stream carries, in order.
#[derive(Clone, Debug, PartialEq)]
enum Out {
    /// The page starts over (event `backlog`): this many records came
    /// before the latest ones it is sent next.
    Backlog(u64),
    /// Records: of the backlog, or new.
    Batch(Arc<String>),
    /// The page fell behind by this many batches (event `gap`): the
    /// stream ends, and the page reconnects for the backlog.
    Gap(u64),
    /// A named event (`cpu`, `valid`) and its JSON.
    Named(&'static str, Arc<String>),
    /// The stream is over (event `end`).
    End,
}

/// The latest records a page is sent when it opens, at most (bytes of
/// `records.csv`).
#[cfg(not(test))]
const BACKLOG_BYTES: u64 = 16 << 20;
#[cfg(test)]
const BACKLOG_BYTES: u64 = 1 << 20;
/// Records in one page of the backlog.
const PAGE_RECORDS: usize = 2000;

/// A page's stream: the backlog (`before` records it is not sent, then
/// `pages`), the records not yet written (`tail`), then (unless the
/// stream has `ended`) the batches from `rx`, up to and including the
/// end or a gap.
fn page_stream(
    before: u64,
    pages: impl Stream<Item = String> + Send + 'static,
    tail: Vec<Arrived>,
    ended: bool,
    latest: Vec<(&'static str, Arc<String>)>,
    rx: broadcast::Receiver<Message>,
) -> impl Stream<Item = Out> + Send {
    let schema = Out::Named("schema", Arc::new(schema_json()));
    let first = stream::iter([schema, Out::Backlog(before)])
        .chain(stream::iter(latest.into_iter().map(|(n, j)| Out::Named(n, j))))
        .chain(pages.map(|p| Out::Batch(Arc::new(p))))
        .chain(stream::iter(
            (!tail.is_empty()).then(|| Out::Batch(Arc::new(batch_json(&tail)))),
        ));
    let live = tokio_stream::wrappers::BroadcastStream::new(rx)
        .map(|m| match m {
            Ok(Message::Batch(b)) => Out::Batch(b),
            Ok(Message::Named(n, j)) => Out::Named(n, j),
            Ok(Message::End) => Out::End,
            Err(BroadcastStreamRecvError::Lagged(n)) => Out::Gap(n),
        })
        // The dashboard gone without its end: the end all the same.
        .chain(stream::once(async { Out::End }));
    let rest = match ended {
        true => stream::once(async { Out::End }).boxed(),
        false => live.boxed(),
    };
    first.chain(rest).scan(false, |over, out| {
        let next = (!*over).then(|| {
            *over = matches!(out, Out::End | Out::Gap(_));
            out
        });
        async move { next }
    })
}

/// `/events`: [`page_stream`] as server-sent events, its backlog the
/// latest [`BACKLOG_BYTES`] of `records.csv`.
async fn events(State(shared): State<Shared>) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let (on_disk, tail, ended, latest, rx, records_csv) = {
        let state = shared.state.lock().unwrap_or_else(|p| p.into_inner());
        let tail: Vec<Arrived> = state.tail.iter().map(|(_, r)| *r).collect();
        let latest = state.latest.clone();
        (
            state.on_disk,
            tail,
            state.ended,
            latest,
            shared.messages.subscribe(),
            state.records_csv.clone(),
        )
    };
    let backlog = records_csv
        .and_then(|p| Backlog::open(&p, on_disk).ok())
        .unwrap_or_default();
    let before = on_disk.records.saturating_sub(backlog.records);
    let pages = stream::unfold(backlog, |mut b| async move {
        let page = b.page()?;
        Some((page, b))
    });
    let events = page_stream(before, pages, tail, ended, latest, rx).map(|out| {
        Ok(match out {
            Out::Backlog(n) => Event::default().event("backlog").data(n.to_string()),
            Out::Batch(b) => Event::default().data(b.as_str()),
            Out::Gap(n) => Event::default().event("gap").data(n.to_string()),
            Out::Named(n, j) => Event::default().event(n).data(j.as_str()),
            Out::End => Event::default().event("end").data("end"),
        })
    });
    Sse::new(events).keep_alive(KeepAlive::default())
}

/// What a client sends as a marker: its text, and where a program
/// other than the page sends it, its name (letters, digits, `-`, `_`)
/// and the host's UTC it was made at (µs; default: when it arrives).
#[derive(serde::Deserialize)]
struct MarkerBody {
    text: String,
    source: Option<String>,
    host_utc_us: Option<i64>,
}

/// A client's name for itself as a marker's source: at most 16 of its
/// letters, digits, `-` and `_` (else `dashboard`).
fn source_name(s: Option<&str>) -> String {
    let name: String = s
        .unwrap_or("")
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
        .take(16)
        .collect();
    if name.is_empty() {
        "dashboard".into()
    } else {
        name
    }
}

/// `POST /marker` (JSON `{"text": …}`; a form of another site cannot
/// send JSON without the preflight this server never grants): the marker
/// written, as JSON, or why not.
async fn marker(State(shared): State<Shared>, body: axum::Json<MarkerBody>) -> Response {
    let Some(marks) = &shared.marks else {
        return (StatusCode::CONFLICT, "this session takes no markers (a replay)\n").into_response();
    };
    let mut m = Mark::now(&source_name(body.source.as_deref()), &body.text);
    if let Some(t) = body.host_utc_us {
        m.host_utc_us = t;
    }
    if m.text.is_empty() {
        return (StatusCode::UNPROCESSABLE_ENTITY, "a marker needs a text\n").into_response();
    }
    let (tx, rx) = tokio::sync::oneshot::channel();
    m.reply = Some(tx);
    if marks.send(m).is_err() {
        return (StatusCode::CONFLICT, "the session has ended\n").into_response();
    }
    match tokio::time::timeout(std::time::Duration::from_secs(5), rx).await {
        Ok(Ok(Ok(w))) => axum::Json(w).into_response(),
        Ok(Ok(Err(why))) => (StatusCode::CONFLICT, format!("{why}\n")).into_response(),
        _ => (StatusCode::SERVICE_UNAVAILABLE, "the session did not answer\n").into_response(),
    }
}

/// What a client sends to start or stop a recording: `start` (into
/// `folder` where it says, else the next of the run's folders) or
/// `stop`.
#[derive(serde::Deserialize)]
struct RecordingBody {
    action: String,
    folder: Option<PathBuf>,
}

/// `POST /recording` (JSON, as [`marker`]): the recording's folder as
/// JSON once started or stopped, or why not.
async fn recording(State(shared): State<Shared>, body: axum::Json<RecordingBody>) -> Response {
    let Some(commands) = &shared.commands else {
        return (StatusCode::CONFLICT, "this run takes no recordings (a replay)\n").into_response();
    };
    let (tx, rx) = tokio::sync::oneshot::channel();
    let command = match body.action.as_str() {
        "start" => Command::Start(body.0.folder, Some(tx)),
        "stop" => Command::Stop(Some(tx)),
        other => {
            return (
                StatusCode::UNPROCESSABLE_ENTITY,
                format!("'{other}': start or stop\n"),
            )
                .into_response();
        }
    };
    if commands.send(command).is_err() {
        return (StatusCode::CONFLICT, "the session has ended\n").into_response();
    }
    match tokio::time::timeout(std::time::Duration::from_secs(10), rx).await {
        Ok(Ok(Ok(dir))) => {
            axum::Json(serde_json::json!({ "folder": dir.display().to_string() })).into_response()
        }
        Ok(Ok(Err(why))) => (StatusCode::CONFLICT, format!("{why}\n")).into_response(),
        _ => (StatusCode::SERVICE_UNAVAILABLE, "the session did not answer\n").into_response(),
    }
}

/// The latest records of `records.csv`, read a page at a time.
#[derive(Default)]
struct Backlog {
    lines: Option<std::io::Take<BufReader<File>>>,
    /// Records it holds.
    records: u64,
}

impl Backlog {
    /// The last lines of `path` within its first `on_disk.bytes`, at
    /// most [`BACKLOG_BYTES`] of them.
    fn open(path: &Path, on_disk: OnDisk) -> std::io::Result<Self> {
        let mut file = BufReader::new(File::open(path)?);
        let from = on_disk.bytes.saturating_sub(BACKLOG_BYTES);
        file.seek(SeekFrom::Start(from))?;
        // The header, or the line the window cuts.
        let mut skipped = vec![];
        let cut = file.read_until(b'\n', &mut skipped)? as u64;
        let len = on_disk.bytes.saturating_sub(from + cut);
        let mut records = 0;
        let mut counted = (&mut file).take(len);
        loop {
            let buf = counted.fill_buf()?;
            if buf.is_empty() {
                break;
            }
            records += buf.iter().filter(|&&b| b == b'\n').count() as u64;
            let n = buf.len();
            counted.consume(n);
        }
        file.seek(SeekFrom::Start(from + cut))?;
        Ok(Self {
            lines: Some(file.take(len)),
            records,
        })
    }

    /// The next page as a batch's JSON; None at its end.
    fn page(&mut self) -> Option<String> {
        let lines = self.lines.as_mut()?;
        let mut rows = Vec::with_capacity(PAGE_RECORDS);
        let mut line = String::new();
        while rows.len() < PAGE_RECORDS {
            line.clear();
            match lines.read_line(&mut line) {
                Ok(0) | Err(_) => break,
                Ok(_) => rows.extend(row_of_line(&line)),
            }
        }
        if rows.is_empty() {
            self.lines = None;
            return None;
        }
        Some(serde_json::Value::Array(rows).to_string())
    }
}

/// A `records.csv` line as the page takes a record (see [`batch_json`]):
/// a field with no value (empty, or not finite) is null.
fn row_of_line(line: &str) -> Option<serde_json::Value> {
    let f: Vec<&str> = line.trim_end().split(',').collect();
    if f.len() != 18 {
        return None;
    }
    let num = |i: usize| -> serde_json::Value {
        f[i].parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .map_or(serde_json::Value::Null, serde_json::Value::from)
    };
    let t_us: f64 = f[2].parse().ok()?;
    Some(serde_json::json!([
        t_us * 1e-6,
        f[3].parse::<u8>().ok()?,
        num(10),
        num(11),
        num(12),
        num(13),
        f[16].parse::<u16>().ok()?,
        f[0].parse::<u32>().ok()?,
        f[1].parse::<u32>().ok()?,
        num(4),
        num(5),
        num(6),
        num(7),
        num(8),
        num(9),
        num(14),
        num(15),
        f[17]
            .parse::<f64>()
            .map_or(serde_json::Value::Null, |us| value(us * 1e-6))
    ]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    fn collect(s: impl Stream<Item = Out> + Send) -> Vec<Out> {
        tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap()
            .block_on(s.collect())
    }

    /// The feed's first event on every connection.
    fn schema() -> Out {
        Out::Named("schema", Arc::new(schema_json()))
    }

    /// The schema names every field a batch row holds, in order, and
    /// each flag with whether it is a fault; a row from the stream and
    /// the same record's line of `records.csv` are the same row.
    #[test]
    fn the_feed_names_every_field_and_a_line_reads_as_its_record() {
        let s: serde_json::Value = serde_json::from_str(&schema_json()).unwrap();
        assert_eq!(s["version"], FEED_VERSION);
        assert_eq!(s["fields"].as_array().unwrap().len(), FIELDS.len());
        assert_eq!(s["flags"][8]["name"], "MODEL");
        assert_eq!(s["flags"][9]["fault"], false);
        let r = link::Record {
            t_us: 1500,
            sensor: 3,
            tones: [
                link::Tone {
                    f_hz: 1000.0,
                    z_re_ohm: 1.25e5,
                    z_im_ohm: -7.5e5,
                },
                link::Tone {
                    f_hz: 4000.0,
                    z_re_ohm: 1.0e5,
                    z_im_ohm: -2.0e5,
                },
            ],
            c_farad: 2.05e-10,
            r_ohm: 7.0e5,
            stretch_mm: f32::NAN,
            chosen_hz: 4000.0,
            chi2: 3.5,
            sigma_ln_c: 0.001,
            flags: 512,
        };
        let a = Arrived {
            segment: 2,
            seq: 41,
            host_utc_us: Some(1_796_300_000_123_456),
            record: r,
        };
        let row: serde_json::Value = serde_json::from_str(&batch_json(&[a])).unwrap();
        let mut line = vec![];
        crate::records_csv::line(&mut line, 2, 41, &r, a.host_utc_us);
        let from_csv = row_of_line(std::str::from_utf8(&line).unwrap()).unwrap();
        assert_eq!(row[0].as_array().unwrap().len(), FIELDS.len());
        assert_eq!(row[0][4], serde_json::Value::Null, "no stretch: null");
        assert_eq!(row[0][17], from_csv[17], "the arrival, to the µs");
        for (i, (name, _)) in FIELDS.iter().enumerate() {
            let (x, y) = (&row[0][i], &from_csv[i]);
            match (x.as_f64(), y.as_f64()) {
                (Some(x), Some(y)) => assert!((x - y).abs() <= 1e-6 * x.abs().max(1.0), "{name}: {x} vs {y}"),
                _ => assert_eq!(x, y, "{name}"),
            }
        }
    }

    #[test]
    fn a_page_that_falls_behind_is_told_the_gap_and_its_stream_ends() {
        let (tx, rx) = broadcast::channel(2);
        for k in 0..5 {
            tx.send(Message::Batch(Arc::new(format!("[{k}]")))).unwrap();
        }
        tx.send(Message::End).unwrap();
        let got = collect(page_stream(0, stream::empty(), vec![], false, vec![], rx));
        assert_eq!(got, [schema(), Out::Backlog(0), Out::Gap(4)]);
    }

    #[test]
    fn a_page_that_keeps_up_gets_every_batch_then_the_end() {
        let (tx, rx) = broadcast::channel(8);
        for k in 0..3 {
            tx.send(Message::Batch(Arc::new(format!("[{k}]")))).unwrap();
        }
        tx.send(Message::Named("cpu", Arc::new("{}".into()))).unwrap();
        tx.send(Message::End).unwrap();
        tx.send(Message::Batch(Arc::new("[9]".into()))).unwrap();
        let pages = stream::iter(["[7]".to_string(), "[8]".to_string()]);
        let cpu = Arc::new("{\"late\":0}".to_string());
        let got = collect(page_stream(
            5,
            pages,
            vec![],
            false,
            vec![("cpu", cpu.clone())],
            rx,
        ));
        let batch = |k: u32| Out::Batch(Arc::new(format!("[{k}]")));
        assert_eq!(
            got,
            [
                schema(),
                Out::Backlog(5),
                Out::Named("cpu", cpu),
                batch(7),
                batch(8),
                batch(0),
                batch(1),
                batch(2),
                Out::Named("cpu", Arc::new("{}".into())),
                Out::End
            ]
        );
        // A page that opens after the end: the backlog and the end.
        let (_tx, rx) = broadcast::channel(8);
        assert_eq!(
            collect(page_stream(
                0,
                stream::iter(["[1]".to_string()]),
                vec![],
                true,
                vec![],
                rx
            )),
            [schema(), Out::Backlog(0), batch(1), Out::End]
        );
    }

    /// The status line of `GET /` with `host` (None: no Host header).
    fn status(addr: SocketAddr, host: Option<&str>) -> String {
        let mut sock = std::net::TcpStream::connect(addr).unwrap();
        let host = host.map_or(String::new(), |h| format!("Host: {h}\r\n"));
        write!(sock, "GET / HTTP/1.1\r\n{host}Connection: close\r\n\r\n").unwrap();
        let mut text = String::new();
        sock.read_to_string(&mut text).unwrap();
        text.lines().next().unwrap_or_default().to_string()
    }

    /// The share valid is built and kept at most once a second, and
    /// always at the stream's end: the last page sees the final counts.
    #[test]
    fn the_share_valid_is_throttled_but_its_last_value_always_kept() {
        let d = Dashboard::serve("127.0.0.1:0".parse().unwrap(), None, None).unwrap();
        let counts = |valid: u64| {
            let mut a = Availability::new();
            for k in 0..10 {
                a.count(instrument::faults::Flags(if k < valid { 0 } else { 256 }));
            }
            BTreeMap::from([(0u8, a)])
        };
        let kept = |d: &Dashboard| {
            let state = d.state();
            let (_, json) = state.latest.iter().find(|(n, _)| *n == "valid").cloned().unwrap();
            serde_json::from_str::<serde_json::Value>(&json).unwrap()[0]["valid"].clone()
        };
        let none = BTreeMap::new();
        d.availability(&counts(3), &none, false);
        assert_eq!(kept(&d), 3);
        d.availability(&counts(4), &none, false);
        assert_eq!(kept(&d), 3, "within the second: not built again");
        d.availability(&counts(5), &none, true);
        assert_eq!(kept(&d), 5, "the end: always");
    }

    #[test]
    fn the_dashboard_holds_only_the_records_not_yet_written() {
        let d = Dashboard::serve("127.0.0.1:0".parse().unwrap(), None, None).unwrap();
        d.push(&[Arrived::default(); 10]);
        d.written(OnDisk {
            records: 7,
            bytes: 900,
        });
        assert_eq!(
            d.state().tail.iter().map(|(k, _)| *k).collect::<Vec<_>>(),
            [7, 8, 9]
        );
        d.push(&[Arrived::default(); 2]);
        d.written(OnDisk {
            records: 12,
            bytes: 1500,
        });
        assert!(d.state().tail.is_empty());
    }

    #[test]
    fn the_backlog_is_the_latest_whole_lines_in_pages() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("records.csv");
        let mut text = crate::records_csv::HEADER.to_string();
        let n = 30_000u64;
        for k in 0..n {
            text += &format!(
                "1,{k},{},{},2000,1,-1,0,0,0,205.5,700000,NaN,2000,,0.001,0,1796300000123456\n",
                1000 * k,
                k % 16
            );
        }
        std::fs::write(&path, &text).unwrap();
        // Written so far: all but a line cut in half.
        let bytes = text.len() as u64 - 30;
        let mut b = Backlog::open(
            &path,
            OnDisk {
                records: n - 1,
                bytes,
            },
        )
        .unwrap();
        let mut rows = vec![];
        while let Some(page) = b.page() {
            let p: Vec<serde_json::Value> = serde_json::from_str(&page).unwrap();
            assert!(p.len() <= PAGE_RECORDS);
            rows.extend(p);
        }
        assert_eq!(rows.len() as u64, b.records);
        assert!(
            b.records > 1000 && (b.records as usize) < n as usize,
            "{}",
            b.records
        );
        // The latest, in order, up to the last whole line; no value as null.
        let last = &rows[rows.len() - 1];
        assert_eq!(last[0].as_f64(), Some((1000 * (n - 2)) as f64 * 1e-6));
        assert_eq!(last[4], serde_json::Value::Null);
        assert_eq!(last[2].as_f64(), Some(205.5));
        // No file yet: no backlog.
        assert!(Backlog::open(&dir.path().join("none.csv"), OnDisk::default()).is_err());
    }

    #[test]
    fn a_request_for_another_host_is_refused() {
        let d = Dashboard::serve("127.0.0.1:0".parse().unwrap(), None, None).unwrap();
        let (addr, port) = (d.addr(), d.addr().port());
        for host in [
            addr.to_string(),
            format!("localhost:{port}"),
            format!("LOCALHOST:{port}"),
        ] {
            assert!(status(addr, Some(&host)).contains(" 200 "), "{host}");
        }
        for host in [
            "evil.example",
            &format!("evil.example:{port}"),
            "127.0.0.1",
            &format!("127.0.0.2:{port}"),
        ] {
            assert!(status(addr, Some(host)).contains(" 421 "), "{host}");
        }
        assert!(!status(addr, None).contains(" 200 "));
    }
}
