//! Headless Chromium driven through its DevTools protocol (a WebSocket
//! per page): the dashboard's tests click its buttons with it, and the
//! soak measures the page's frame rate and memory.

use anyhow::{bail, Context, Result};
use std::io::{BufRead, BufReader, Read, Write};
use std::time::{Duration, Instant};

/// Headless Chromium showing `url`, driven through DevTools: killed
/// (and its profile removed) when dropped.
pub struct Browser {
    child: std::process::Child,
    profile: std::path::PathBuf,
    /// Its first page, once attached.
    pub page: Page,
}

impl Browser {
    /// Chromium started on `url` with a profile of its own (a new folder
    /// under the system's temporary one) and `extra` switches, its page
    /// attached.
    pub fn open(url: &str, extra: &[&str]) -> Result<Self> {
        let port = free_port()?;
        let profile = std::env::temp_dir().join(format!("live-devtools-{}-{port}", std::process::id()));
        let mut child = std::process::Command::new("chromium")
            .args(["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"])
            .args([
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
            ])
            .args(extra)
            .arg(format!("--remote-debugging-port={port}"))
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg(url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .context("chromium (Debian's package; `cargo xtask setup` installs it)")?;
        match Page::attach(port) {
            Ok(page) => Ok(Self { child, profile, page }),
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                Err(e)
            }
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

/// A page of Chromium, JavaScript evaluated in it.
pub struct Page {
    ws: tungstenite::WebSocket<std::net::TcpStream>,
    id: u64,
}

impl Page {
    /// Chromium's first page, on DevTools port `port` (Chromium started
    /// with `--remote-debugging-port=PORT`), waiting up to 30 s for it.
    pub fn attach(port: u16) -> Result<Self> {
        let t0 = Instant::now();
        let url = loop {
            if let Some(url) = first_page(port) {
                break url;
            }
            if t0.elapsed() > Duration::from_secs(30) {
                bail!("no DevTools page on port {port} within 30 s");
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        let (ws, _) = tungstenite::connect(url.as_str()).context("connecting to the page's DevTools")?;
        let config = *ws.get_config();
        let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.into_inner() else {
            bail!("DevTools over TLS");
        };
        let ws =
            tungstenite::WebSocket::from_raw_socket(s, tungstenite::protocol::Role::Client, Some(config));
        Ok(Self { ws, id: 0 })
    }

    /// `expression`'s value in the page (a promise awaited); an error for
    /// an exception it throws.
    pub fn eval(&mut self, expression: &str) -> Result<serde_json::Value> {
        self.evaluate(expression)?
            .map_err(|e| anyhow::anyhow!("{expression}: {e}"))
    }

    /// Wait until `expression` is true in the page (at most `limit`): an
    /// exception (the page not there yet) is not true.
    pub fn until(&mut self, expression: &str, limit: Duration) -> Result<()> {
        let t0 = Instant::now();
        while !matches!(self.evaluate(expression)?, Ok(serde_json::Value::Bool(true))) {
            if t0.elapsed() > limit {
                bail!("never within {limit:?}: {expression}");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        Ok(())
    }

    /// The page as it is drawn now, `width` × `height` CSS pixels, as a
    /// PNG written to `path`.
    pub fn screenshot(&mut self, path: &std::path::Path, width: u32, height: u32) -> Result<()> {
        use base64::Engine as _;
        self.call(
            "Emulation.setDeviceMetricsOverride",
            serde_json::json!({"width": width, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        )?;
        let shot = self.call("Page.captureScreenshot", serde_json::json!({"format": "png"}))?;
        let data = shot["data"].as_str().context("no image in DevTools' answer")?;
        let png = base64::engine::general_purpose::STANDARD
            .decode(data)
            .context("DevTools' image")?;
        std::fs::write(path, png).with_context(|| format!("writing {}", path.display()))
    }

    /// DevTools method `method` with `params`: its result.
    fn call(&mut self, method: &str, params: serde_json::Value) -> Result<serde_json::Value> {
        self.id += 1;
        let msg = serde_json::json!({"id": self.id, "method": method, "params": params});
        self.ws.send(tungstenite::Message::text(msg.to_string()))?;
        loop {
            let m = self.ws.read()?;
            let Ok(text) = m.to_text() else { continue };
            let v: serde_json::Value = serde_json::from_str(text).unwrap_or_default();
            if v["id"] == self.id {
                if v["error"].is_object() {
                    bail!("{method}: {}", v["error"]);
                }
                return Ok(v["result"].clone());
            }
        }
    }

    /// `expression`'s value, or the exception it threw.
    fn evaluate(&mut self, expression: &str) -> Result<Result<serde_json::Value, serde_json::Value>> {
        let params =
            serde_json::json!({"expression": expression, "returnByValue": true, "awaitPromise": true});
        let result = self.call("Runtime.evaluate", params)?;
        let exception = &result["exceptionDetails"];
        Ok(match exception.is_object() {
            true => Err(exception.clone()),
            false => Ok(result["result"]["value"].clone()),
        })
    }
}

/// The WebSocket address of the first page Chromium's DevTools on `port`
/// lists, if it answers yet. The connection stays open (HTTP/1.1): the
/// body is read to its Content-Length.
fn first_page(port: u16) -> Option<String> {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    write!(s, "GET /json/list HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n").ok()?;
    let mut r = BufReader::new(s);
    let mut len = 0;
    loop {
        let mut line = String::new();
        r.read_line(&mut line).ok()?;
        match line.trim_end() {
            "" => break,
            h => {
                if let Some((k, v)) = h.split_once(':') {
                    if k.eq_ignore_ascii_case("content-length") {
                        len = v.trim().parse().ok()?;
                    }
                }
            }
        }
    }
    let mut body = vec![0; len];
    r.read_exact(&mut body).ok()?;
    let pages: serde_json::Value = serde_json::from_slice(&body).ok()?;
    pages.as_array()?.iter().find(|p| p["type"] == "page")?["webSocketDebuggerUrl"]
        .as_str()
        .map(str::to_string)
}

/// A free TCP port of this machine (for Chromium's DevTools).
pub fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}
