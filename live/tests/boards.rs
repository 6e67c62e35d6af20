//! Several boards in one session: two boards on two sockets, one of
//! them lost halfway and back; the skin's records keyed by board and
//! sensor on one time axis, its manifest, each board's own recording.

mod common;

use common::single_tone;
use link::{Body, Encoder, End, Start, MAX_FRAME};
use std::io::Write;
use std::net::TcpListener;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Records each board sends: two sensors, one record each every 10 ms.
const N: u32 = 300;

const SKIN: &str = "[skin]\nname = \"pair\"\n\
    [[board]]\nname = \"A\"\ndevice = 0xA\n[[board]]\nname = \"B\"\ndevice = 0xB\n\
    [[sensor]]\nname = \"a0\"\nboard = \"A\"\nindex = 0\nplace = [0, 0]\n\
    [[sensor]]\nname = \"a1\"\nboard = \"A\"\nindex = 1\nplace = [0, 10]\n\
    [[sensor]]\nname = \"b0\"\nboard = \"B\"\nindex = 0\nplace = [20, 0]\n\
    [[sensor]]\nname = \"b1\"\nboard = \"B\"\nindex = 1\nplace = [20, 10]\n";

/// A board's frames: its start (device `id`), `N` records whose stamps
/// are its clock's (`offset_us` at true 0, true time k·5 ms), its end.
fn frames(id: u32, offset_us: u64) -> Vec<(Vec<u8>, u64)> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let start = Start {
        version: link::VERSION,
        firmware: Start::firmware_field("test"),
        sensors: 2,
        sample_rate_hz: 200_000,
        device_id: id,
        ..Start::default()
    };
    let mut f = vec![(enc.frame(Body::Start(start), &mut out).unwrap().to_vec(), 0)];
    for k in 0..u64::from(N) {
        let true_us = 5000 * k;
        let rec = single_tone(offset_us + true_us, (k % 2) as u8);
        f.push((enc.frame(Body::Record(rec), &mut out).unwrap().to_vec(), true_us));
    }
    let end = End {
        records: N,
        dropped: 0,
    };
    f.push((
        enc.frame(Body::End(end), &mut out).unwrap().to_vec(),
        5000 * u64::from(N),
    ));
    f
}

/// Serve `frames` on `listener` in real time from `t0`; with `drop_at`,
/// close the connection before that frame and send the rest to the
/// next client (the board unplugged and back).
fn serve(listener: TcpListener, frames: Vec<(Vec<u8>, u64)>, t0: Instant, drop_at: Option<usize>) {
    let (mut sock, _) = listener.accept().unwrap();
    for (k, (bytes, due)) in frames.iter().enumerate() {
        if Some(k) == drop_at {
            drop(sock);
            sock = listener.accept().unwrap().0;
        }
        if let Some(wait) = Duration::from_micros(*due).checked_sub(t0.elapsed()) {
            std::thread::sleep(wait);
        }
        sock.write_all(bytes).unwrap();
    }
}

/// `live` reading boards A and B of the pair's skin on `la` and `lb`
/// into `tmp`/session, with `extra` options; its stderr piped.
fn live_pair(
    tmp: &std::path::Path,
    la: &TcpListener,
    lb: &TcpListener,
    extra: &[&str],
) -> std::process::Child {
    let skin = tmp.join("pair.toml");
    std::fs::write(&skin, SKIN).unwrap();
    Command::new(env!("CARGO_BIN_EXE_live"))
        .arg("--skin")
        .arg(&skin)
        .args(extra)
        .arg("--source")
        .arg(format!("A=tcp:{}", la.local_addr().unwrap()))
        .arg("--source")
        .arg(format!("B=tcp:{}", lb.local_addr().unwrap()))
        .arg("--dataset")
        .arg(tmp.join("session"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Two free listeners, the boards' ends.
fn listeners() -> (TcpListener, TcpListener) {
    (
        TcpListener::bind("127.0.0.1:0").unwrap(),
        TcpListener::bind("127.0.0.1:0").unwrap(),
    )
}

#[test]
fn two_boards_one_lost_and_back_are_read_in_one_session_on_one_axis() {
    let tmp = tempfile::tempdir().unwrap();
    let (la, lb) = listeners();
    let dir = tmp.path().join("session");
    let child = live_pair(tmp.path(), &la, &lb, &[]);
    // B's clock started 7.3 s before A's.
    let (fa, fb) = (frames(0xA, 0), frames(0xB, 7_300_000));
    let t0 = Instant::now();
    let a = std::thread::spawn(move || serve(la, fa, t0, None));
    let b = std::thread::spawn(move || serve(lb, fb, t0, Some(N as usize / 2)));
    let out = child.wait_with_output().unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}\n{stderr}");
    a.join().unwrap();
    b.join().unwrap();
    assert!(stderr.contains("board B: lost"), "{stderr}");
    assert!(stdout.contains("board A: device 0x0000000a"), "{stdout}");
    // Each board's own recording, whole.
    for board in ["A", "B"] {
        let own = std::fs::read_to_string(dir.join(board).join("records.csv")).unwrap();
        assert_eq!(own.lines().count(), 1 + N as usize, "{board}");
    }
    // The skin's: every record, keyed and named, in order on the axis,
    // the same true instant of both boards at the same place.
    let text = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    let mut last = i64::MIN;
    let mut at: std::collections::HashMap<(String, String), i64> = Default::default();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let t: i64 = f[2].parse().unwrap();
        assert!(t >= last);
        last = t;
        let t_us: u64 = f[5].parse().unwrap();
        let true_us = if f[0] == "B" { t_us - 7_300_000 } else { t_us };
        assert_eq!(f[1], format!("{}{}", f[0].to_lowercase(), f[6]));
        at.insert((f[0].to_string(), true_us.to_string()), t);
    }
    assert_eq!(at.len(), 2 * N as usize);
    let worst = (0..N)
        .map(|k| {
            let key = |b: &str| at[&(b.to_string(), (5000 * u64::from(k)).to_string())];
            (key("A") - key("B")).abs()
        })
        .max()
        .unwrap();
    // Real sockets on a shared machine: a few ms of scheduling at worst
    // (the QEMU skin test holds four boards to 1 ms).
    assert!(worst < 5_000, "{worst} µs apart");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("skin.json")).unwrap()).unwrap();
    assert_eq!(manifest["boards"][1]["reconnects"], 1);
    assert_eq!(manifest["boards"][1]["devices"][0], "0x0000000b");
    python_reads_the_skin(&dir);
}

/// The Python reader takes the skin's records and its boards.
fn python_reads_the_skin(dir: &std::path::Path) {
    let said = common::python_says(
        "import sys, skinread\n\
         df = skinread.read_skin(sys.argv[1]); b = skinread.boards(sys.argv[1])\n\
         assert df['t_utc'].is_monotonic_increasing and df['t_utc'].notna().all()\n\
         print(len(df), sorted(set(df['board'])), sorted(set(df['name'])), b['reconnects'].tolist(), \
         b['device'].tolist(), int(df['valid'].sum()))",
        dir,
    );
    assert_eq!(
        said.trim(),
        format!(
            "{} ['A', 'B'] ['a0', 'a1', 'b0', 'b1'] [0, 1] ['0x0000000a', '0x0000000b'] {}",
            2 * N,
            2 * N
        )
    );
}

#[test]
fn a_source_for_a_board_the_skin_lacks_or_given_twice_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let skin = tmp.path().join("pair.toml");
    std::fs::write(&skin, SKIN).unwrap();
    let skin = skin.to_str().unwrap();
    let (code, _, err) = common::live(&["--skin", skin, "--source", "Z=tcp:127.0.0.1:9"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("has no board 'Z' (its boards: A, B)"), "{err}");
    let (code, _, err) = common::live(&[
        "--skin",
        skin,
        "--source",
        "A=tcp:127.0.0.1:9",
        "--source",
        "A=tcp:127.0.0.1:10",
    ]);
    assert_eq!(code, Some(1));
    assert!(err.contains("given twice"), "{err}");
    let (code, _, err) = common::live(&["--source", "A=usb:1"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("tcp, serial or replay"), "{err}");
}

/// The skin's dashboard in a real browser: both boards' sensors on the
/// layout, each coloured from its latest record, the boards' table with
/// their devices and B's reopened port, every record sent on the page,
/// the same true instant of both boards at the same place on the axis.
#[test]
fn the_dashboard_shows_every_board_of_the_skin() {
    use live::devtools::{Browser, Page};
    use std::io::BufRead;
    let tmp = tempfile::tempdir().unwrap();
    let (la, lb) = listeners();
    let mut child = live_pair(tmp.path(), &la, &lb, &["--serve", "127.0.0.1:0", "--linger", "3"]);
    let mut said = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    said.read_line(&mut first).unwrap();
    let url = first
        .trim()
        .strip_prefix("dashboard: ")
        .expect(&first)
        .to_string();
    let mut browser = Browser::open(&url, &[]).unwrap();
    let page = &mut browser.page;
    let until = |page: &mut Page, e: &str| page.until(e, Duration::from_secs(20)).unwrap();
    until(page, "document.getElementById('state').textContent === 'open'");
    until(
        page,
        "document.querySelectorAll('#skin [data-sensor]').length === 4",
    );
    until(
        page,
        "document.querySelector('#taxel-2 title').textContent === 'b0 (sensor 2)'",
    );
    // The boards send once the page is open: it sees every record.
    let (fa, fb) = (frames(0xA, 0), frames(0xB, 7_300_000));
    let t0 = Instant::now();
    let a = std::thread::spawn(move || serve(la, fa, t0, None));
    let b = std::thread::spawn(move || serve(lb, fb, t0, Some(N as usize / 2)));
    until(
        page,
        "[0, 1, 2, 3].every(i => document.getElementById('taxel-' + i).dataset.state === 'valid')",
    );
    until(page, "document.querySelectorAll('#boards tr').length === 2");
    a.join().unwrap();
    b.join().unwrap();
    assert!(child.wait().unwrap().success());
    until(page, "document.getElementById('state').textContent === 'ended'");
    until(page, "[0, 1, 2, 3].every(i => bySensor.get(i).n === 150)");
    until(
        page,
        "document.querySelector('#boards tr[data-board=B] td:nth-child(2)').textContent === '0000000b'",
    );
    // The boards' self-tests, from their start frames (these streams'
    // say none ran).
    until(
        page,
        "document.querySelector('#boards tr[data-board=B] td:nth-child(3)').textContent === 'not run'",
    );
    until(
        page,
        "document.querySelector('#boards tr[data-board=B] td:nth-child(10)').textContent === '1'",
    );
    until(
        page,
        "document.querySelector('#boards tr[data-board=A] td:nth-child(11)').textContent === 'ended'",
    );
    // a0's and b0's last records were taken at the same true instant.
    let apart = page
        .eval("Math.abs(bySensor.get(0).last[0] - bySensor.get(2).last[0])")
        .unwrap();
    assert!(apart.as_f64().unwrap() < 0.005, "{apart} s apart");
    until(
        page,
        "document.getElementById('latest').textContent.includes('b1 (3)')",
    );
    let shot = tmp.path().join("page.png");
    page.screenshot(&shot, 1200, 900).unwrap();
    assert!(std::fs::read(&shot).unwrap().starts_with(b"\x89PNG\r\n\x1a\n"));
    drop(browser);
    assert!(child.wait().unwrap().success());
}
