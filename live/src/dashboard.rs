//! The dashboard: a local web page of a running skin, served on
//! 127.0.0.1 while a session runs. The page (`web/index.html`) charts C,
//! R, stretch, the chosen frequency and the flags of the sensor chosen,
//! and shows every sensor's latest record; records reach it by
//! server-sent events (`/events`: first every record so far, then each
//! batch as it arrives). The chart library (uPlot, from npm, with its
//! licence at `/uPlot.LICENSE`) is embedded in the binary: the page loads
//! nothing from the internet.

use anyhow::{Context, Result};
use axum::http::header;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream, StreamExt};
use link::Record;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::sync::broadcast;

const INDEX: &str = include_str!("../web/index.html");
const UPLOT_JS: &[u8] = include_bytes!(concat!(env!("UPLOT_DIST"), "/uPlot.iife.min.js"));
const UPLOT_CSS: &[u8] = include_bytes!(concat!(env!("UPLOT_DIST"), "/uPlot.min.css"));
const UPLOT_LICENSE: &[u8] = include_bytes!(env!("UPLOT_LICENSE"));

/// What the page is sent: a batch of records as JSON.
fn batch_json(records: &[Record]) -> String {
    let rows: Vec<serde_json::Value> = records
        .iter()
        .map(|r| {
            serde_json::json!([
                r.t_us as f64 * 1e-6,
                r.sensor,
                r.c_farad as f64 * 1e12,
                r.r_ohm,
                r.stretch_mm,
                r.chosen_hz,
                r.flags
            ])
        })
        .collect();
    serde_json::Value::Array(rows).to_string()
}

/// What the open pages are sent after their backlog.
#[derive(Clone)]
enum Message {
    /// New records, as JSON.
    Batch(Arc<String>),
    /// The stream is over: nothing more will come.
    End,
}

/// The records so far, whether the stream is over, and the channel that
/// carries what comes next.
#[derive(Clone)]
struct Shared {
    records: Arc<Mutex<(Vec<Record>, bool)>>,
    messages: broadcast::Sender<Message>,
}

/// A running dashboard: hand it records as they arrive.
pub struct Dashboard {
    shared: Shared,
    addr: SocketAddr,
    _runtime: tokio::runtime::Runtime,
}

impl Dashboard {
    /// Serve on `addr` (127.0.0.1 and a port; port 0 picks a free one).
    pub fn serve(addr: SocketAddr) -> Result<Self> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .context("starting the dashboard's runtime")?;
        let (messages, _) = broadcast::channel(1024);
        let shared = Shared {
            records: Arc::new(Mutex::new((vec![], false))),
            messages,
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
            .with_state(shared.clone());
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

    /// Records that arrived: kept for pages that open later, and pushed
    /// to the open ones.
    pub fn push(&self, records: &[Record]) {
        if records.is_empty() {
            return;
        }
        let batch = Arc::new(batch_json(records));
        // Under the lock, so that a page that opens now gets each record
        // once: in its backlog or in a batch.
        let mut all = self.shared.records.lock().unwrap_or_else(|p| p.into_inner());
        all.0.extend_from_slice(records);
        let _ = self.shared.messages.send(Message::Batch(batch));
    }

    /// The stream is over: the pages are told, and their event streams
    /// close (a page that opens later gets every record and the end).
    pub fn end(&self) {
        let mut all = self.shared.records.lock().unwrap_or_else(|p| p.into_inner());
        all.1 = true;
        let _ = self.shared.messages.send(Message::End);
    }
}

/// `/events`: every record so far (event `backlog`), then each new
/// batch, and `end` when the stream is over (the event stream closes).
async fn events(
    axum::extract::State(shared): axum::extract::State<Shared>,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let (backlog, ended, rx) = {
        let all = shared.records.lock().unwrap_or_else(|p| p.into_inner());
        (batch_json(&all.0), all.1, shared.messages.subscribe())
    };
    // Named: a page that reconnects starts over from it.
    let first = stream::once(async move { Ok(Event::default().event("backlog").data(backlog)) });
    let end = stream::once(async { Ok(Event::default().event("end").data("end")) });
    let rest: std::pin::Pin<Box<dyn Stream<Item = Result<Event, Infallible>> + Send>> = if ended {
        Box::pin(end)
    } else {
        Box::pin(
            tokio_stream::wrappers::BroadcastStream::new(rx)
                .take_while(|m| {
                    let go = !matches!(m, Ok(Message::End));
                    async move { go }
                })
                .filter_map(|m| async move {
                    match m {
                        Ok(Message::Batch(b)) => Some(Ok(Event::default().data(b.as_str()))),
                        _ => None,
                    }
                })
                .chain(end),
        )
    };
    Sse::new(first.chain(rest)).keep_alive(KeepAlive::default())
}
