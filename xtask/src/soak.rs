//! `cargo xtask soak`: `live` as a lab runs it for a day, and killed.
//!
//! A simulated device on a TCP socket streams a skin's records
//! ([`live::synthetic`]: 16 sensors × 1,000 records/s, the array's two
//! tones each) to `live
//! --tcp`, with the dashboard open in headless Chromium. At random
//! moments `live` is killed (SIGKILL: a crash, the power) and started
//! again into a new folder; the device starts its stream over on each
//! new connection, until it has sent the whole duration and its end
//! frame. Each killed session is checked: its marker there, no manifest,
//! every file in whole lines, and every record up to its last flush (the
//! count its last health line gave) in `records.csv`, numbered without a
//! gap; the last session, ended cleanly, by its manifest's counts against
//! what the device sent. Resident memory is sampled throughout, and must
//! stay within 256 MiB. The dashboard's page is sampled every 5 s
//! through Chromium's DevTools: the frames it draws a second (at least
//! 20) and its JavaScript heap (at most 256 MiB). `--sensors 64` streams
//! a four-board skin's 64 × 1,000 records/s. A checked session's folder is
//! deleted (a day's records would fill a disk); the report is
//! `out/soak/report.md`.

use anyhow::{ensure, Context, Result};
use link::{Encoder, End, MAX_FRAME};
use rand::{Rng, SeedableRng};
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Records per second each sensor.
const RATE: u64 = 1000;
/// The dashboard's frame rate every sample keeps to, frames/s (a page
/// below it stutters visibly).
const FPS_MIN: f64 = 20.0;
/// Seconds between samples of the page.
const PAGE_EVERY_S: f64 = 5.0;
/// The bound on the page's JavaScript heap, MiB (as on `live`'s own
/// memory: a day's records must not pile up in the page).
const HEAP_MAX_MIB: f64 = 256.0;
/// The bound on `live`'s resident memory, KiB.
const RESIDENT_MAX_KIB: u64 = 256 * 1024;

/// What a soak does.
#[derive(Clone, Debug)]
pub struct Soak {
    /// Seconds of records the device sends (16 × 1,000 a second).
    pub seconds: u64,
    /// How fast: a multiple of real time, or None for as fast as `live`
    /// takes them.
    pub speed: Option<f64>,
    /// `live` is killed after a random time between these, s.
    pub kill_after_s: (f64, f64),
    /// The draw of the kills.
    pub seed: u64,
    /// Open the dashboard in headless Chromium, and measure it there.
    pub dashboard: bool,
    /// Sensors the device reads (16 a board; 64: a skin of four).
    pub sensors: u64,
}

impl Soak {
    /// The test command's: a minute of records in real time, killed
    /// every 8–20 s.
    pub fn minute() -> Self {
        Self {
            seconds: 60,
            speed: Some(1.0),
            kill_after_s: (8.0, 20.0),
            seed: 1,
            dashboard: true,
            sensors: 16,
        }
    }
}

/// One sample of the dashboard's page in headless Chromium.
#[derive(Clone, Copy, Debug)]
struct PageSample {
    /// s since the soak began.
    t: f64,
    /// Frames the page drew a second since the last sample (its
    /// `requestAnimationFrame` callbacks).
    fps: f64,
    /// Its JavaScript heap in use, MiB.
    heap_mib: f64,
    /// Elements in its document.
    nodes: u64,
}

/// One session of the soak, as checked.
struct Session {
    killed: bool,
    on_disk: u64,
    flushed: u64,
    peak_kib: u64,
}

/// Run `soak` with the `live` binary of the workspace at `root`; the
/// report, also written to `out/soak/report.md`.
pub fn run(root: &Path, soak: &Soak) -> Result<String> {
    crate::cargo::run(
        root,
        &["build", "--profile", crate::checks::TEST_PROFILE, "-p", "live"],
    )?;
    let live = root.join("target").join(crate::checks::TEST_PROFILE).join("live");
    let out = root.join("out/soak");
    if out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("removing {}", out.display()))?;
    }
    std::fs::create_dir_all(&out)?;
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let addr = listener.local_addr()?;
    let total = soak.seconds * soak.sensors * RATE;
    let device = Device::new(total, soak.speed, soak.sensors);
    let dev = device.clone();
    // Serves as long as the soak runs (a session killed as the end frame
    // left is followed by one that gets a stream of none).
    std::thread::spawn(move || dev.serve(listener));
    let mut rng = rand::rngs::StdRng::seed_from_u64(soak.seed);
    let start = Instant::now();
    let mut sessions = vec![];
    let mut rss = vec![];
    let mut page = vec![];
    loop {
        let dir = out.join(format!("session-{}", sessions.len() + 1));
        let kill_after = Duration::from_secs_f64(rng.gen_range(soak.kill_after_s.0..soak.kill_after_s.1));
        let s = one_session(
            &live,
            addr,
            &dir,
            soak.dashboard,
            kill_after,
            &device,
            start,
            (&mut rss, &mut page),
        )?;
        let killed = s.killed;
        sessions.push(s);
        if !killed {
            break;
        }
        std::fs::remove_dir_all(&dir)?;
    }
    let mut report = report(soak, &sessions, &rss, start.elapsed());
    if soak.dashboard {
        report += &page_report(&page);
    }
    std::fs::write(out.join("report.md"), &report)?;
    let peak = sessions.iter().map(|s| s.peak_kib).max().unwrap_or(0);
    ensure!(
        peak <= RESIDENT_MAX_KIB,
        "live's resident memory peaked at {peak} KiB:\n{report}"
    );
    if soak.dashboard {
        ensure!(!page.is_empty(), "the dashboard was never sampled:\n{report}");
        // (A sample that could not count the frames is slow too.)
        let slow = page.iter().find(|p| p.fps.is_nan() || p.fps < FPS_MIN);
        ensure!(
            slow.is_none(),
            "the dashboard drew {slow:?}, below {FPS_MIN} frames/s:\n{report}"
        );
        let big = page
            .iter()
            .find(|p| p.heap_mib.is_nan() || p.heap_mib > HEAP_MAX_MIB);
        ensure!(
            big.is_none(),
            "the dashboard's heap reached {big:?}, over {HEAP_MAX_MIB} MiB:\n{report}"
        );
    }
    Ok(report)
}

/// One run of `live` into `dir`: killed after `kill_after` unless the
/// stream ends first; checked. `rss` gains its samples (s since `start`,
/// KiB).
#[allow(clippy::too_many_arguments)]
fn one_session(
    live: &Path,
    addr: std::net::SocketAddr,
    dir: &Path,
    dashboard: bool,
    kill_after: Duration,
    device: &Device,
    start: Instant,
    (rss, page): (&mut Vec<(f64, u64)>, &mut Vec<PageSample>),
) -> Result<Session> {
    let mut cmd = Command::new(live);
    cmd.arg("--tcp").arg(addr.to_string()).arg("--dataset").arg(dir);
    if dashboard {
        cmd.args(["--serve", "127.0.0.1:0"]);
    }
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("starting live")?;
    let flushed = health(&mut child);
    let (browser, mut meter) = match dashboard {
        true => {
            let (b, m) = open_dashboard(&mut child)?;
            (Some(b), Some(m))
        }
        false => (None, None),
    };
    let begun = Instant::now();
    let mut peak = 0;
    let status = loop {
        if let Some(st) = child.try_wait()? {
            break Some(st);
        }
        if let Some(kib) = resident_kib(child.id()) {
            peak = peak.max(kib);
            rss.push((start.elapsed().as_secs_f64(), kib));
        }
        if let Some(m) = &mut meter {
            if let Some(s) = m.sample(start)? {
                page.push(s);
            }
        }
        if begun.elapsed() >= kill_after && !device.done() {
            child.kill()?;
            child.wait()?;
            break None;
        }
        std::thread::sleep(Duration::from_millis(250));
    };
    if let Some(mut b) = browser {
        let _ = b.kill();
        let _ = b.wait();
    }
    let flushed = *flushed.lock().unwrap_or_else(|p| p.into_inner());
    let on_disk = match status {
        None => check_killed(dir, flushed)?,
        Some(st) => {
            ensure!(st.success(), "live ended with {st} in {}", dir.display());
            check_clean(dir, device.sent_on_connection())?
        }
    };
    Ok(Session {
        killed: status.is_none(),
        on_disk,
        flushed,
        peak_kib: peak,
    })
}

/// The count of records `live`'s last health line gave (written when it
/// was printed), kept up to date from its stderr.
fn health(child: &mut Child) -> Arc<Mutex<u64>> {
    let count = Arc::new(Mutex::new(0));
    let c = Arc::clone(&count);
    if let Some(err) = child.stderr.take() {
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                let n = line
                    .split_once(" records from ")
                    .and_then(|(n, _)| n.parse::<u64>().ok());
                if let Some(n) = n {
                    *c.lock().unwrap_or_else(|p| p.into_inner()) = n;
                }
            }
        });
    }
    count
}

/// Headless Chromium on the dashboard `live` prints first, and what
/// measures its page.
fn open_dashboard(child: &mut Child) -> Result<(Child, Meter)> {
    let mut first = String::new();
    let out = child.stdout.take().context("live's stdout")?;
    let mut rd = BufReader::new(out);
    rd.read_line(&mut first)?;
    // The rest of stdout read and dropped, so that live never blocks.
    std::thread::spawn(move || std::io::copy(&mut rd, &mut std::io::sink()));
    let url = first
        .trim()
        .strip_prefix("dashboard: ")
        .with_context(|| format!("no dashboard address from live: {first:?}"))?
        .to_string();
    let port = live::devtools::free_port()?;
    let browser = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-precise-memory-info",
        ])
        .arg(format!("--remote-debugging-port={port}"))
        .arg(&url)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .context("chromium (Debian's package; `cargo xtask setup` installs it)")?;
    let mut page = live::devtools::Page::attach(port)?;
    // The page listed first may be the blank one before the dashboard's.
    let loaded = format!("location.href === {url:?} && document.readyState === 'complete' && !!document.getElementById('state')");
    page.until(&loaded, Duration::from_secs(30))?;
    // Each frame the page draws counted.
    page.eval(
        "window.soakFrames = 0; (function f() { window.soakFrames++; requestAnimationFrame(f); })(); true",
    )?;
    Ok((browser, Meter::new(page)?))
}

/// The dashboard's page, sampled every [`PAGE_EVERY_S`]: its frames
/// drawn since the last sample, its heap and its document's size.
struct Meter {
    page: live::devtools::Page,
    last: (Instant, f64),
}

impl Meter {
    fn new(mut page: live::devtools::Page) -> Result<Self> {
        let frames = page.eval("window.soakFrames")?.as_f64().unwrap_or(0.0);
        Ok(Self {
            page,
            last: (Instant::now(), frames),
        })
    }

    /// A sample, where one is due.
    fn sample(&mut self, start: Instant) -> Result<Option<PageSample>> {
        let dt = self.last.0.elapsed().as_secs_f64();
        if dt < PAGE_EVERY_S {
            return Ok(None);
        }
        let v = self.page.eval(
            "[window.soakFrames, performance.memory.usedJSHeapSize, document.getElementsByTagName('*').length]",
        )?;
        let num = |k: usize| v[k].as_f64().unwrap_or(f64::NAN);
        let frames = num(0);
        let s = PageSample {
            t: start.elapsed().as_secs_f64(),
            fps: (frames - self.last.1) / dt,
            heap_mib: num(1) / (1024.0 * 1024.0),
            nodes: num(2) as u64,
        };
        self.last = (Instant::now(), frames);
        Ok(Some(s))
    }
}

/// Resident memory of process `pid`, KiB.
fn resident_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// A killed session's folder: marked, no manifest, every file in whole
/// lines but where the kill cut a write ([`whole_but_a_cut_write`]),
/// and `records.csv` holding records numbered 1, 2, … without a gap, at
/// least the `flushed` its last health line gave. Its records.
fn check_killed(dir: &Path, flushed: u64) -> Result<u64> {
    let name = dir.display();
    if !dir.join("records.csv").exists() {
        // Killed before the start frame arrived: nothing written.
        ensure!(
            flushed == 0,
            "{name}: no records.csv, but {flushed} records were flushed"
        );
        return Ok(0);
    }
    ensure!(
        dir.join(live::INCOMPLETE).is_file(),
        "{name}: killed, but not marked INCOMPLETE"
    );
    ensure!(
        !dir.join(live::MANIFEST).exists(),
        "{name}: killed, but with a manifest"
    );
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let file = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        ensure!(!file.starts_with('.'), "{name}: a stray temporary {file}");
        if file.ends_with(".csv") {
            let bytes = std::fs::read(&path)?;
            ensure!(whole_but_a_cut_write(&bytes), "{name}/{file}: a line cut short");
        }
    }
    let text = std::fs::read_to_string(dir.join("records.csv"))?;
    // A line a kill cut (above) is the write the kill stopped: not flushed.
    let whole = text.rfind('\n').map_or("", |end| &text[..=end]);
    let mut n = 0u64;
    for line in whole.lines().skip(1) {
        let seq: u64 = line
            .split(',')
            .nth(1)
            .and_then(|s| s.parse().ok())
            .context("a seq")?;
        n += 1;
        ensure!(
            seq == n,
            "{name}/records.csv: record {n} has seq {seq}: a record lost"
        );
    }
    ensure!(
        n >= flushed,
        "{name}: {n} records on disk, {flushed} were flushed: records lost"
    );
    Ok(n)
}

/// A file's bytes end in whole lines, or in a line cut where the kernel
/// stops a write when its process is killed: a page boundary (4 KiB).
/// A write of many pages is copied page by page, and a kill (SIGKILL)
/// stops it between two of them: `live` writes each flush in one call,
/// so the file holds every line flushed before, and the killed flush
/// up to a page of the file (a soak's `records.csv` was cut at exactly
/// 35 MiB). A cut anywhere else is a line lost by the writer.
fn whole_but_a_cut_write(bytes: &[u8]) -> bool {
    const PAGE: usize = 4096;
    bytes.is_empty() || bytes.last() == Some(&b'\n') || bytes.len() % PAGE == 0
}

/// The last session, ended with the device's end frame: its manifest
/// complete, every record the device sent on its connection kept, none
/// lost, the end frame's count agreeing.
fn check_clean(dir: &Path, sent: u64) -> Result<u64> {
    let text = std::fs::read(dir.join(live::MANIFEST))?;
    let m: serde_json::Value = serde_json::from_slice(&text)?;
    let name = dir.display();
    ensure!(m["complete"] == true, "{name}: not complete: {}", m["outcome"]);
    ensure!(
        m["records"]["kept"] == sent,
        "{name}: kept {} of {sent}",
        m["records"]["kept"]
    );
    ensure!(
        m["frames"]["lost"] == 0,
        "{name}: {} frames lost",
        m["frames"]["lost"]
    );
    ensure!(
        m["segments"][0]["end"]["agrees"] == true,
        "{name}: the end frame disagrees"
    );
    ensure!(
        !dir.join(live::INCOMPLETE).exists(),
        "{name}: complete, but marked"
    );
    Ok(sent)
}

/// The simulated device: streams records to each connection, from a
/// start frame on, paced or not; the end frame once all are sent.
#[derive(Clone)]
struct Device {
    total: u64,
    speed: Option<f64>,
    sensors: u64,
    /// Records sent in all, and on the connection now.
    sent: Arc<AtomicU64>,
    on_connection: Arc<AtomicU64>,
}

impl Device {
    fn new(total: u64, speed: Option<f64>, sensors: u64) -> Self {
        Self {
            total,
            speed,
            sensors,
            sent: Arc::new(AtomicU64::new(0)),
            on_connection: Arc::new(AtomicU64::new(0)),
        }
    }

    fn sent_on_connection(&self) -> u64 {
        self.on_connection.load(Ordering::Relaxed)
    }

    /// Whether every record is sent.
    fn done(&self) -> bool {
        self.sent.load(Ordering::Relaxed) >= self.total
    }

    /// Serve each connection in turn, the records not yet sent and the
    /// end frame.
    fn serve(&self, listener: TcpListener) -> Result<()> {
        let begun = Instant::now();
        loop {
            let (sock, _) = listener.accept()?;
            self.stream(sock, begun)?;
        }
    }

    /// One connection: true once the end frame is sent, false where the
    /// peer went away.
    fn stream(&self, sock: TcpStream, begun: Instant) -> Result<bool> {
        let mut w = std::io::BufWriter::with_capacity(64 << 10, sock);
        let mut enc = Encoder::new();
        let mut buf = [0u8; MAX_FRAME];
        self.on_connection.store(0, Ordering::Relaxed);
        let frame = enc
            .start(&live::synthetic::skin_start(self.sensors as u8), &mut buf)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        if w.write_all(frame).is_err() {
            return Ok(false);
        }
        let mut n = 0u32;
        while self.sent.load(Ordering::Relaxed) < self.total {
            let k = self.sent.load(Ordering::Relaxed);
            let frame = enc
                .record(&live::synthetic::skin_record(k, self.sensors), &mut buf)
                .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            if w.write_all(frame).is_err() {
                return Ok(false);
            }
            // Counted as sent once in the socket's buffer: flushed every
            // 256 records (a sixteenth of a second), and paced.
            if k % 256 == 255 {
                if w.flush().is_err() {
                    return Ok(false);
                }
                self.pace(k, begun);
            }
            self.sent.fetch_add(1, Ordering::Relaxed);
            n += 1;
            self.on_connection.store(u64::from(n), Ordering::Relaxed);
        }
        let end = End {
            records: n,
            dropped: 0,
        };
        let frame = enc.end(&end, &mut buf).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        Ok(w.write_all(frame).and_then(|()| w.flush()).is_ok())
    }

    /// Wait until record `k` is due (at `speed` × real time).
    fn pace(&self, k: u64, begun: Instant) {
        if let Some(speed) = self.speed {
            let due = Duration::from_secs_f64(k as f64 / (self.sensors * RATE) as f64 / speed);
            if let Some(wait) = due.checked_sub(begun.elapsed()) {
                std::thread::sleep(wait);
            }
        }
    }
}

/// The report: each session, resident memory over time, the verdict.
fn report(soak: &Soak, sessions: &[Session], rss: &[(f64, u64)], took: Duration) -> String {
    let speed = soak.speed.map_or("as fast as live takes them".to_string(), |s| {
        format!("{s}× real time")
    });
    let mut md = format!(
        "# Soak: {} s of {} × 1,000 records/s through `live --tcp`{}, {speed}, killed every {}–{} s\n\n",
        soak.seconds,
        soak.sensors,
        if soak.dashboard {
            " with the dashboard open in headless Chromium"
        } else {
            ""
        },
        soak.kill_after_s.0,
        soak.kill_after_s.1
    );
    md += "| session | ended | records on disk | last flush said | lost before it | peak resident |\n|---:|---|---:|---:|---:|---:|\n";
    for (k, s) in sessions.iter().enumerate() {
        md += &format!(
            "| {} | {} | {} | {} | {} | {:.1} MiB |\n",
            k + 1,
            if s.killed {
                "killed"
            } else {
                "end frame; manifest checked"
            },
            s.on_disk,
            s.flushed,
            s.flushed.saturating_sub(s.on_disk),
            s.peak_kib as f64 / 1024.0
        );
    }
    md += "\nResident memory of `live` over time:\n\n| s | MiB |\n|---:|---:|\n";
    let step = (rss.len() / 20).max(1);
    for (t, kib) in rss.iter().step_by(step) {
        md += &format!("| {t:.0} | {:.1} |\n", *kib as f64 / 1024.0);
    }
    let peak = rss.iter().map(|r| r.1).max().unwrap_or(0);
    md += &format!(
        "\nPeak {:.1} MiB (bound 256 MiB); {} sessions, {} killed, no record lost before a flush; {:.0} s.\n",
        peak as f64 / 1024.0,
        sessions.len(),
        sessions.iter().filter(|s| s.killed).count(),
        took.as_secs_f64()
    );
    md
}

/// The dashboard's page over the soak: its frame rate and memory.
fn page_report(page: &[PageSample]) -> String {
    let mut md = "\nThe dashboard's page in headless Chromium (a sample every 5 s, each session's page new):\n\n| s | frames/s | JS heap | elements |\n|---:|---:|---:|---:|\n".to_string();
    let step = (page.len() / 20).max(1);
    for p in page.iter().step_by(step) {
        md += &format!(
            "| {:.0} | {:.1} | {:.1} MiB | {} |\n",
            p.t, p.fps, p.heap_mib, p.nodes
        );
    }
    let mut fps: Vec<f64> = page.iter().map(|p| p.fps).collect();
    fps.sort_by(f64::total_cmp);
    let heap = page.iter().map(|p| p.heap_mib).fold(0.0, f64::max);
    if let (Some(lo), Some(mid)) = (fps.first(), fps.get(fps.len() / 2)) {
        md += &format!(
            "\nFrames/s: median {mid:.1}, lowest {lo:.1} (bound {FPS_MIN}); JS heap at most {heap:.1} MiB (bound {HEAP_MAX_MIB}); {} samples.\n",
            page.len()
        );
    }
    md
}

#[cfg(test)]
mod tests {
    use super::whole_but_a_cut_write;

    #[test]
    fn only_a_write_cut_at_a_page_boundary_leaves_a_line_short() {
        assert!(whole_but_a_cut_write(b""));
        assert!(whole_but_a_cut_write(b"t,seq\n1,1\n"));
        assert!(!whole_but_a_cut_write(b"t,seq\n1,1\n2,"));
        let mut page_cut = b"t,seq\n".repeat(8192 / 6 + 1);
        page_cut.truncate(8192);
        assert_ne!(page_cut.last(), Some(&b'\n'));
        assert!(whole_but_a_cut_write(&page_cut));
        page_cut.pop();
        assert!(!whole_but_a_cut_write(&page_cut));
    }
}
