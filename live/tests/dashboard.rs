//! The dashboard in a real browser (headless Chromium, Debian's
//! `chromium`, which `cargo xtask setup` installs): against a replay, the
//! page shows every record it was sent, and a screenshot of its charts is
//! written to `out/dashboard.png`.

mod common;

use link::{Body, Encoder, End, Record, Start, Tone, MAX_FRAME, VERSION};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

/// Two sensors on a slow triangle of stretch, `n` records each, and a
/// last one of sensor 1 without values.
fn stream(n: u32) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let start = Start {
        version: VERSION,
        firmware: Start::firmware_field("dashboard test"),
        sensors: 2,
        // Sensor 1's stage failed the power-up self-test.
        self_test: link::SelfTest {
            verdict: link::Verdict::Failed,
            failed: 1 << 2,
            ..link::SelfTest::default()
        },
        ..Start::default()
    };
    let mut bytes = enc.frame(Body::Start(start), &mut out).unwrap().to_vec();
    for k in 0..n {
        for sensor in 0..2u8 {
            let s = 15.0 - ((k as f32 / n as f32) * 30.0 - 15.0).abs();
            let rec = Record {
                t_us: 4000 * u64::from(k) + 2000,
                sensor,
                tones: [
                    Tone {
                        f_hz: 500.0,
                        z_re_ohm: 4e5,
                        z_im_ohm: -1.6e6,
                    },
                    Tone {
                        f_hz: 2000.0,
                        z_re_ohm: 2e5,
                        z_im_ohm: -3.9e5,
                    },
                ],
                c_farad: (205.0 + 2.0 * s + 10.0 * f32::from(sensor)) * 1e-12,
                r_ohm: 7e5 * (1.0 + 0.02 * s),
                stretch_mm: s,
                chosen_hz: if s > 10.0 { 1000.0 } else { 2000.0 },
                flags: u16::from(k % 50 == 0) * 64,
                ..Record::default()
            };
            bytes.extend_from_slice(enc.frame(Body::Record(rec), &mut out).unwrap());
        }
    }
    // Sensor 1's last record has no values (NaN on the device): a gap,
    // not a broken page.
    let nan = Record {
        t_us: 4000 * u64::from(n) + 2000,
        sensor: 1,
        c_farad: f32::NAN,
        r_ohm: f32::NAN,
        stretch_mm: f32::NAN,
        chosen_hz: f32::NAN,
        flags: 256,
        ..Record::default()
    };
    bytes.extend_from_slice(enc.frame(Body::Record(nan), &mut out).unwrap());
    let end = End {
        records: 2 * n + 1,
        dropped: 0,
    };
    bytes.extend_from_slice(enc.frame(Body::End(end), &mut out).unwrap());
    bytes
}

/// `live --replay` of [`stream`]`(n)` serving the dashboard for
/// `linger` s after the stream: its folder, the process and the
/// dashboard's address (printed first).
fn serve_replay(n: u32, linger: u32) -> (tempfile::TempDir, std::process::Child, String) {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("stream.bin");
    std::fs::write(&file, stream(n)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_live"))
        .arg("--replay")
        .arg(&file)
        .arg("--dataset")
        .arg(tmp.path().join("ds"))
        .args(["--serve", "127.0.0.1:0", "--linger", &linger.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let url = first
        .trim()
        .strip_prefix("dashboard: ")
        .expect("the dashboard's address")
        .to_string();
    (tmp, child, url)
}

/// Headless Chromium on `url` with `args`; its stdout.
fn chromium(url: &str, args: &[&str]) -> String {
    let out = Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"])
        .arg("--virtual-time-budget=4000")
        .args(args)
        .arg(url)
        .stderr(Stdio::null())
        .output()
        .expect("chromium (Debian's package; `cargo xtask setup` installs it)");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn the_page_shows_every_record_it_was_sent() {
    let (_tmp, mut child, url) = serve_replay(400, 120);
    let dom = chromium(&url, &["--dump-dom"]);
    let shot = Path::new(env!("CARGO_MANIFEST_DIR")).join("../out/dashboard.png");
    std::fs::create_dir_all(shot.parent().unwrap()).unwrap();
    chromium(
        &url,
        &[
            "--window-size=1280,1100",
            &format!("--screenshot={}", shot.display()),
        ],
    );
    let _ = child.kill();
    let _ = child.wait();
    let count = |id: &str| -> Option<u64> {
        let tag = format!("id=\"{id}\">");
        let at = dom.find(&tag)? + tag.len();
        dom[at..].split('<').next()?.parse().ok()
    };
    assert_eq!(count("records"), Some(801), "{dom}");
    assert_eq!(count("sensors"), Some(2));
    assert_eq!(count("flagged"), Some(17));
    assert!(dom.contains("sensor 0: C"), "no charts: {dom}");
    // The device's self-test, as its start frame gave it.
    assert!(
        dom.contains("self-test FAILED on sensor 1: sensor 1's records refused"),
        "no self-test: {dom}"
    );
    // The table's row of sensor 1: its last record's values as dashes.
    let row = dom
        .split("<tr")
        .find(|r| r.contains("<td>1</td><td>401</td>"))
        .unwrap_or_else(|| panic!("no row of sensor 1: {dom}"));
    assert_eq!(row.matches("<td>–</td>").count(), 4, "{row}");
    // The tool's count of the whole session: sensor 1's 401 records, 8
    // DISTURBED and its last flagged MODEL.
    assert!(
        row.contains("<td>97.8 %</td>") && row.contains("DISTURBED 8, MODEL 1"),
        "{row}"
    );
    let least = dom
        .split("id=\"least\"")
        .nth(1)
        .and_then(|t| t.split_once('>'))
        .and_then(|(_, t)| t.split('<').next());
    assert_eq!(least, Some("97.8 % (sensor 1)"), "{dom}");
    assert!(
        shot.is_file() && std::fs::metadata(&shot).unwrap().len() > 10_000,
        "no screenshot"
    );
}

#[test]
fn the_dashboard_serves_this_machine_only() {
    let out = Command::new(env!("CARGO_BIN_EXE_live"))
        .args(["--replay", "/dev/null", "--serve", "0.0.0.0:0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("serves this machine only"));
}

/// The live feed as an interface: the Python client
/// (`skinread.feed.records`) reads every record with all its fields
/// and its flags by name, as `live` was sent them.
#[test]
fn the_feed_gives_a_client_every_record_with_every_field() {
    let (_tmp, mut child, url) = serve_replay(100, 60);
    let client = r#"
import sys
from skinread import feed
recs = [r for r in feed.records(sys.argv[1] + "events") if "event" not in r]
disturbed = sum("DISTURBED" in r["flags"] for r in recs)
last = recs[-1]
print(len(recs), disturbed, sorted({r["sensor"] for r in recs}), recs[0]["f2_hz"], recs[0]["z1_im_ohm"], last["c_pf"], last["valid"], recs[0]["seq"])
"#;
    let py = common::python_with("numpy, pandas");
    let out = Command::new(py)
        .args(["-c", client])
        .arg(&url)
        .env(
            "PYTHONPATH",
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../python"),
        )
        .output()
        .unwrap();
    let _ = child.kill();
    let _ = child.wait();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // 201 records; every 50th block's two flagged DISTURBED; the last
    // has no values (null) and its MODEL flag; the first frame after the
    // start is number 1.
    assert_eq!(
        text.trim(),
        "201 4 [0, 1] 2000.0 -1600000.0 None False 1",
        "{text}"
    );
}

/// Chromium on a page through DevTools ([`live::devtools`]), a test's
/// failure where it fails.
struct Page(live::devtools::Browser);

impl Page {
    fn open(url: &str) -> Self {
        Self(live::devtools::Browser::open(url, &[]).unwrap())
    }

    fn eval(&mut self, expression: &str) -> serde_json::Value {
        self.0.page.eval(expression).unwrap()
    }

    fn until(&mut self, expression: &str) {
        self.0
            .page
            .until(expression, std::time::Duration::from_secs(20))
            .unwrap()
    }
}

/// The page's Record button and Mark field in a real browser, against a
/// running device: a recording started, a marker made, the recording
/// stopped, each as the page says and as the files hold.
#[test]
fn the_page_records_and_marks_what_it_is_asked_to() {
    use std::io::Write;
    let tmp = tempfile::tempdir().unwrap();
    let folder = tmp.path().join("trial");
    // The skin: sensor 0 drawn by its outline, sensor 1 at a point.
    let skin = tmp.path().join("skin.toml");
    std::fs::write(
        &skin,
        "[skin]\nname = \"hand\"\n[[sensor]]\nname = \"thumb\"\nindex = 0\ngroup = \"hand\"\nplace = [10, 10]\n\
         outline = [[5, 5], [15, 5], [15, 15], [5, 15]]\n[[sensor]]\nname = \"palm\"\nindex = 1\ngroup = \"hand\"\n\
         place = [40, 30]\n",
    )
    .unwrap();
    let live = common::serve_tcp(
        &[
            "--idle",
            "--skin",
            skin.to_str().unwrap(),
            "--dataset",
            folder.to_str().unwrap(),
        ],
        Stdio::null(),
    );
    let url = live.url();
    let mut sock = live.sock.try_clone().unwrap();
    let bytes = stream(300);
    let frames: Vec<&[u8]> = bytes.split_inclusive(|&b| b == 0).collect();
    // The device runs: its start and records, more as the page acts.
    for f in &frames[..100] {
        sock.write_all(f).unwrap();
    }
    let mut page = Page::open(&url);
    page.until("document.getElementById('state').textContent === 'open'");
    // Not recording, yet the records pass.
    page.until("document.getElementById('recording').textContent === '–' || document.getElementById('recording').textContent === 'no'");
    // The skin drawn: each sensor at its place, named, coloured by its
    // state; a click on one shows its charts.
    page.until("document.querySelectorAll('#skin [data-sensor]').length === 2");
    page.until("document.querySelector('#taxel-0 title').textContent === 'thumb (sensor 0)'");
    page.until("document.querySelector('#taxel-0 polygon') !== null && document.querySelector('#taxel-1 circle') !== null");
    // Nothing records, and the page opened after the first records: the
    // next ones reach it as they pass.
    page.until("document.getElementById('taxel-0').dataset.state === 'none'");
    for f in &frames[100..140] {
        sock.write_all(f).unwrap();
    }
    page.until("document.getElementById('taxel-0').dataset.state === 'valid'");
    // The layout against the records sent: 20 of each sensor, the last
    // of sensor 0 at 6.9 mm (the most: red), of sensor 1 at 6.8 mm.
    page.until("bySensor.get(0).n === 20 && bySensor.get(1).n === 20");
    page.until("document.getElementById('skin-max').textContent === '6.9'");
    page.until("document.querySelector('#taxel-0 polygon').getAttribute('fill') === 'hsl(0, 70%, 50%)'");
    let hue = page.eval("document.querySelector('#taxel-1 circle').getAttribute('fill')");
    let hue: f64 = hue.as_str().unwrap()[4..]
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((hue - 240.0 * (1.0 - 6.8 / 6.9)).abs() < 0.01, "{hue}");
    page.eval(
        "document.querySelector('#taxel-1 circle').dispatchEvent(new MouseEvent('click', {bubbles: true}))",
    );
    page.until("document.getElementById('sensor').value === '1' && document.querySelector('#charts').textContent.includes('sensor 1')");
    // The group's chart: both sensors' C overlaid, each all its records.
    page.until("document.querySelector('#group') !== null && groupChart.series.length === 3");
    page.until("groupChart.data[1][0].length === 20 && groupChart.data[2][0].length === 20");
    page.until("groupChart.data[2][1][19] === bySensor.get(1).last[2]");
    // Record: a recording into --dataset's folder, as the page says.
    page.eval("document.getElementById('record').click()");
    page.until("document.getElementById('recording').textContent.endsWith('trial')");
    for f in &frames[140..200] {
        sock.write_all(f).unwrap();
    }
    // A marker, from the field: the page shows it written.
    page.eval("document.getElementById('mark-text').value = 'grasp, firm'; document.getElementById('mark').requestSubmit()");
    page.until("document.getElementById('marked').textContent.startsWith('grasp, firm at ')");
    // Stop: the set written, and the page back to not recording.
    page.eval("document.getElementById('record').click()");
    page.until("document.getElementById('recording').textContent === 'no'");
    drop(page);
    for f in &frames[200..] {
        sock.write_all(f).unwrap();
    }
    drop(sock);
    let (status, _, err) = live.wait();
    assert!(status.success(), "{status}: {err}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(folder.join("session.json")).unwrap()).unwrap();
    assert_eq!(m["complete"], true, "{m}");
    assert_eq!(m["markers"], 1, "{m}");
    let markers = std::fs::read_to_string(folder.join("markers.csv")).unwrap();
    assert!(
        markers
            .lines()
            .nth(1)
            .is_some_and(|l| l.ends_with(",dashboard,\"grasp, firm\"")),
        "{markers}"
    );
    assert!(m["records"]["kept"].as_u64().unwrap() > 0, "{m}");
}
