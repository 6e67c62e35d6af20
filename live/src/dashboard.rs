//! The dashboard: a local web page of a running skin, served on
//! 127.0.0.1 while a session runs. The page (`web/index.html`) charts C,
//! R, stretch, the chosen frequency and the flags of the sensor chosen,
//! and shows every sensor's latest record; records reach it by
//! server-sent events (`/events`: first every record so far, then each
//! batch as it arrives). The chart library (uPlot, from npm, with its
//! licence at `/uPlot.LICENSE`) is embedded in the binary: the page loads
//! nothing from the internet. A request is served only where its `Host`
//! names the bound address (or `localhost` and its port): a page of
//! another site that a DNS rebinding points at 127.0.0.1 gets nothing.
//! A page that falls behind the records is told the gap and reconnects
//! for the backlog, so it never shows fewer records without saying so.

use anyhow::{Context, Result};
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream, StreamExt};
use link::Record;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::sync::broadcast;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;

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
#[derive(Clone, Debug)]
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
        let (messages, _) = broadcast::channel(BATCHES_BEHIND);
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
    /// Every record so far (event `backlog`: a page that reconnects
    /// starts over from it).
    Backlog(String),
    /// New records.
    Batch(Arc<String>),
    /// The page fell behind by this many batches (event `gap`): the
    /// stream ends, and the page reconnects for the backlog.
    Gap(u64),
    /// The stream is over (event `end`).
    End,
}

/// A page's stream: `backlog`, then (unless the stream has `ended`) the
/// batches from `rx`, up to and including the end or a gap.
fn page_stream(
    backlog: String,
    ended: bool,
    rx: broadcast::Receiver<Message>,
) -> impl Stream<Item = Out> + Send {
    let first = stream::once(async move { Out::Backlog(backlog) });
    let live = tokio_stream::wrappers::BroadcastStream::new(rx)
        .map(|m| match m {
            Ok(Message::Batch(b)) => Out::Batch(b),
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

/// `/events`: [`page_stream`] as server-sent events.
async fn events(State(shared): State<Shared>) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let (backlog, ended, rx) = {
        let all = shared.records.lock().unwrap_or_else(|p| p.into_inner());
        (batch_json(&all.0), all.1, shared.messages.subscribe())
    };
    let events = page_stream(backlog, ended, rx).map(|out| {
        Ok(match out {
            Out::Backlog(b) => Event::default().event("backlog").data(b),
            Out::Batch(b) => Event::default().data(b.as_str()),
            Out::Gap(n) => Event::default().event("gap").data(n.to_string()),
            Out::End => Event::default().event("end").data("end"),
        })
    });
    Sse::new(events).keep_alive(KeepAlive::default())
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

    #[test]
    fn a_page_that_falls_behind_is_told_the_gap_and_its_stream_ends() {
        let (tx, rx) = broadcast::channel(2);
        for k in 0..5 {
            tx.send(Message::Batch(Arc::new(format!("[{k}]")))).unwrap();
        }
        tx.send(Message::End).unwrap();
        let got = collect(page_stream("[]".into(), false, rx));
        assert_eq!(got, [Out::Backlog("[]".into()), Out::Gap(4)]);
    }

    #[test]
    fn a_page_that_keeps_up_gets_every_batch_then_the_end() {
        let (tx, rx) = broadcast::channel(8);
        for k in 0..3 {
            tx.send(Message::Batch(Arc::new(format!("[{k}]")))).unwrap();
        }
        tx.send(Message::End).unwrap();
        tx.send(Message::Batch(Arc::new("[9]".into()))).unwrap();
        let got = collect(page_stream("[]".into(), false, rx));
        let batch = |k: u32| Out::Batch(Arc::new(format!("[{k}]")));
        assert_eq!(
            got,
            [Out::Backlog("[]".into()), batch(0), batch(1), batch(2), Out::End]
        );
        // A page that opens after the end: the backlog and the end.
        let (_tx, rx) = broadcast::channel(8);
        assert_eq!(
            collect(page_stream("[1]".into(), true, rx)),
            [Out::Backlog("[1]".into()), Out::End]
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

    #[test]
    fn a_request_for_another_host_is_refused() {
        let d = Dashboard::serve("127.0.0.1:0".parse().unwrap()).unwrap();
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
