//! Settings kept in flash survive a restart of QEMU: the firmware stores
//! the set it measures with in its flash file (`flash=PATH save`), the
//! host reads that file with the same store and finds the same set and
//! digest, changes one sensor and writes it back, and the next run of the
//! firmware loads the host's set. A flash file of the wrong size is
//! refused with exit code 2. Down the link (UART0's socket): a read of a
//! new device is refused as such, a set that breaks a rule is refused by
//! sensor and rule, a good one is stored and acknowledged with its
//! generation and in force from the next block (the applied frame
//! between the old set's records and the new one's), a stop ends the
//! stream with its end frame, and the next start runs with the set that
//! came down the link.

use instrument::digest::Digest;
use instrument::store::{RamFlash, Store, REGION_BYTES, SLOT_BYTES};
use instrument::stored::SENSORS_MAX;
use std::time::Duration;

/// Run `skin-qemu` with `args`; its exit code and its log's lines.
fn run(args: &[&str]) -> (Option<i32>, Vec<String>) {
    run_image("skin-qemu", args)
}

/// Run image `bin` with `args`; its exit code and its log's lines.
fn run_image(bin: &str, args: &[&str]) -> (Option<i32>, Vec<String>) {
    let elf = qemu_tests::build_firmware(bin, &["qemu"]).unwrap();
    let run = qemu_tests::run_qemu_args(&elf, args, Duration::from_secs(600)).unwrap();
    let log = host_sim::recording::decode_defmt(&elf, &run.raw)
        .unwrap()
        .into_iter()
        .map(|(_, l)| l)
        .collect();
    (run.code, log)
}

/// The digest a `settings…digest 0x…` line of the log names.
fn digest_in(log: &[String], prefix: &str) -> u32 {
    let line = log
        .iter()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no '{prefix}' in {log:?}"));
    let hex = line.rsplit("0x").next().unwrap();
    u32::from_str_radix(hex.trim(), 16).unwrap()
}

#[test]
fn settings_stored_by_the_firmware_come_back_after_a_restart_and_from_the_host() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("settings.bin");
    let flash = format!("flash={}", path.display());

    // A new device: nothing stored; it stores what it measures with.
    let (code, log) = run(&["faults", &flash, "save"]);
    assert_eq!(code, Some(0), "{log:?}");
    qemu_tests::assert_stack_margin("skin-qemu saving its settings", log.iter().map(String::as_str));
    assert!(log.iter().any(|l| l == "settings: none stored"), "{log:?}");
    let saved = digest_in(&log, "settings saved: generation 1");

    // The host reads the same file with the same store.
    let mut image = std::fs::read(&path).unwrap();
    assert_eq!(image.len(), REGION_BYTES);
    let mut store = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES).unwrap();
    let loaded = store.load().unwrap().expect("a set");
    assert_eq!((loaded.generation, Digest::of(&loaded.set)), (1, saved));
    let set = loaded.set;
    assert_eq!(set.check(), Ok(()));
    assert!(set.sensors[..8].iter().all(|s| s.in_use && s.calibrated));
    assert!(set.sensors[8..SENSORS_MAX].iter().all(|s| !s.in_use));
    assert!(
        (set.sensors[0].nominal_c_farad - 210e-12).abs() < 15e-12,
        "{:?}",
        set.sensors[0]
    );

    // The host changes sensor 3's parasitic capacitance and stores it.
    let mut mine = set;
    mine.sensors[3].parasitic_farad = 5e-12;
    assert_eq!(store.save(&mine), Ok(2));
    let _ = store.release();
    std::fs::write(&path, &image).unwrap();

    // The next run finds the host's set.
    let (code, log) = run(&["faults", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert_eq!(digest_in(&log, "settings: generation 2"), Digest::of(&mine));
    assert!(!log.iter().any(|l| l.starts_with("settings saved")), "{log:?}");
}

#[test]
fn a_flash_file_of_the_wrong_size_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("short.bin");
    std::fs::write(&path, [0xFFu8; 100]).unwrap();
    let (code, log) = run(&["faults", &format!("flash={}", path.display())]);
    assert_eq!(code, Some(2), "{log:?}");
    assert!(
        log.iter()
            .any(|l| l.contains("the flash file cannot be used (Length)")),
        "{log:?}"
    );
    assert!(!log.iter().any(|l| l.starts_with("start")), "{log:?}");
}

/// Frames from the device, decoded on a thread as they arrive.
fn frames(mut sock: std::net::TcpStream) -> std::sync::mpsc::Receiver<link::Frame> {
    use std::io::Read;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut dec = link::Decoder::new();
        let mut buf = [0u8; 4096];
        loop {
            match sock.read(&mut buf) {
                Ok(0) => return,
                Ok(n) => {
                    for &b in &buf[..n] {
                        if let Some(Ok(f)) = dec.push(b) {
                            if tx.send(f).is_err() {
                                return;
                            }
                        }
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(_) => return,
            }
        }
    });
    rx
}

/// The next reply from the device, passing over records.
fn reply(rx: &std::sync::mpsc::Receiver<link::Frame>) -> link::Reply {
    loop {
        let f = rx.recv_timeout(Duration::from_secs(120)).expect("a reply");
        if let link::Body::Reply(r) = f.body {
            return r;
        }
    }
}

/// The host's end of a device's link over QEMU's UART0 socket: its
/// frames as they arrive, requests sent down.
struct Host {
    rx: std::sync::mpsc::Receiver<link::Frame>,
    sock: std::net::TcpStream,
    enc: link::Encoder,
}

impl Host {
    /// Image `elf` started with `args`, its defmt log into `log`.
    fn start(elf: &std::path::Path, args: &[&str], log: &std::path::Path) -> (std::process::Child, Self) {
        let (qemu, sock) = qemu_tests::connect_qemu_tcp_logged(elf, args, log).unwrap();
        let rx = frames(sock.try_clone().unwrap());
        let enc = link::Encoder::new();
        (qemu, Self { rx, sock, enc })
    }

    fn send(&mut self, req: link::Request) {
        use std::io::Write;
        let mut out = [0u8; link::MAX_FRAME];
        let bytes = self.enc.frame(link::Body::Request(req), &mut out).unwrap();
        self.sock.write_all(bytes).unwrap();
    }

    /// `set` down the link, in its requests; how many.
    fn upload(&mut self, set: &instrument::stored::Stored) -> usize {
        let mut reqs = vec![];
        instrument::commands::upload(set, |r| reqs.push(r));
        for r in &reqs {
            self.send(*r);
        }
        reqs.len()
    }
}

/// The frames up to the applied frame: the records and the replies
/// before it, and it.
fn until_applied(
    rx: &std::sync::mpsc::Receiver<link::Frame>,
) -> (
    Vec<link::Record>,
    Vec<link::Reply>,
    link::Applied,
    Option<link::Start>,
) {
    let (mut records, mut replies, mut start) = (vec![], vec![], None);
    loop {
        let f = rx
            .recv_timeout(Duration::from_secs(120))
            .expect("the applied frame");
        match f.body {
            link::Body::Start(s) => start = Some(s),
            link::Body::Record(r) => records.push(r),
            link::Body::Reply(r) => replies.push(r),
            link::Body::Applied(a) => return (records, replies, a, start),
            _ => {}
        }
    }
}

/// The next `n` records.
fn records(rx: &std::sync::mpsc::Receiver<link::Frame>, n: usize) -> Vec<link::Record> {
    let mut out = vec![];
    while out.len() < n {
        let f = rx.recv_timeout(Duration::from_secs(120)).expect("records");
        if let link::Body::Record(r) = f.body {
            out.push(r);
        }
    }
    out
}

/// The time between the last two of `recs` of sensor `s`, µs.
fn step(recs: &[link::Record], s: u8) -> u64 {
    let t: Vec<u64> = recs.iter().filter(|r| r.sensor == s).map(|r| r.t_us).collect();
    t[t.len() - 1] - t[t.len() - 2]
}

/// The lines of image `elf`'s defmt log in file `log`.
fn log_lines(elf: &std::path::Path, log: &std::path::Path) -> Vec<String> {
    let raw = std::fs::read(log).unwrap();
    host_sim::recording::decode_defmt(elf, &raw)
        .unwrap()
        .into_iter()
        .map(|(_, l)| l)
        .collect()
}

#[test]
fn a_set_written_down_the_link_is_in_force_from_the_next_block_and_after_a_restart() {
    let elf = qemu_tests::build_firmware("skin-qemu", &["qemu"]).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("settings.bin");
    let flash = format!("flash={}", path.display());
    let log = tmp.path().join("paper.log");
    let (mut qemu, mut host) = Host::start(&elf, &["paper", &flash, "until-stop"], &log);
    // A new device: nothing to read.
    host.send(link::Request::ReadSettings);
    assert!(matches!(
        reply(&host.rx),
        link::Reply::Refused {
            reason: link::Reason::NothingStored,
            ..
        }
    ));
    // A set that breaks a rule is refused by name and code.
    let mut bad = instrument::stored::Stored::uncalibrated();
    bad.sensors[4].lead_ratio = 80.0;
    let n = host.upload(&bad);
    // Every piece answered; the last answer is the commit's.
    let last = (0..n).fold(None, |_, _| Some(reply(&host.rx))).unwrap();
    let want = link::Reason::Setting {
        sensor: 4,
        rule: instrument::stored::Rule::LeadRatio.code(),
    };
    assert!(
        matches!(last, link::Reply::Refused { reason, .. } if reason == want),
        "{last:?}"
    );
    // A good one is stored: generation 1, with each sensor's stretch
    // table and a record every other block.
    let mut good = instrument::stored::Stored::uncalibrated();
    good.sensors[2].parasitic_farad = 7e-12;
    good.record_every = 2;
    for s in good.sensors.iter_mut() {
        s.table =
            instrument::calib::CalTable::linear(200e-12, instrument::design::SENSOR_REST_LENGTH_MM).points;
        s.calibrated = true;
    }
    let n = host.upload(&good);
    let (before, replies, applied, _) = until_applied(&host.rx);
    assert_eq!(replies.len(), n, "{replies:?}");
    assert!(matches!(
        replies.last(),
        Some(link::Reply::Ack { generation: 1, .. })
    ));
    assert_eq!(applied.generation, 1);
    let uncalibrated = instrument::faults::Flags::UNCALIBRATED;
    assert!(!before.is_empty() && before.iter().all(|r| r.flags & uncalibrated != 0));
    assert!(before.iter().all(|r| r.t_us <= applied.t_us));
    // From the next block on: calibrated, every other block of each
    // channel, later than the frame.
    let after = records(&host.rx, 24);
    assert!(after
        .iter()
        .all(|r| r.t_us > applied.t_us && r.flags & uncalibrated == 0));
    assert_eq!(
        step(&after, after[0].sensor),
        2 * step(&before, after[0].sensor),
        "a record every other block"
    );
    // Stop: the stream ends with its end frame and the run with exit 0.
    host.send(link::Request::Stop);
    assert!(matches!(reply(&host.rx), link::Reply::Ack { .. }));
    let end = loop {
        let f = host
            .rx
            .recv_timeout(Duration::from_secs(120))
            .expect("the end frame");
        if let link::Body::End(e) = f.body {
            break e;
        }
    };
    assert!(end.records > 0, "{end:?}");
    let status = qemu.wait().unwrap();
    assert!(status.success(), "{status}");
    let lines = log_lines(&elf, &log);
    qemu_tests::assert_stack_margin("skin-qemu, a set applied", lines.iter().map(String::as_str));
    // The next start finds the set that came down the link.
    let (code, log) = run(&["faults", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert_eq!(digest_in(&log, "settings: generation 1"), Digest::of(&good));
}

#[test]
fn live_config_reads_and_writes_a_running_device() {
    use live::config::Device;
    let elf = qemu_tests::build_firmware("skin-qemu", &["qemu"]).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let flash = format!("flash={}", tmp.path().join("settings.bin").display());
    let (mut qemu, sock) = qemu_tests::connect_qemu_tcp(&elf, &["paper", &flash, "until-stop"]).unwrap();
    let mut dev = Device::new(sock, Duration::from_secs(60));
    // Requests only once it runs: one sent while it boots can be lost.
    dev.ready().unwrap();
    assert_eq!(dev.read().unwrap(), None, "a new device");
    let mut set = instrument::stored::Stored::uncalibrated();
    set.sensors[6].contact_ohm = 1500.0;
    assert_eq!(dev.write(&set).unwrap(), 1);
    set.policy.x_limit = 3.0;
    assert_eq!(dev.write(&set).unwrap(), 2);
    assert_eq!(dev.read().unwrap(), Some((set, 2)));
    dev.stop().unwrap();
    assert!(qemu.wait().unwrap().success());
}

/// The `rec` lines of a log and the truth beside each: (record, true
/// stretch mm).
fn records_with_truth(log: &[String]) -> Vec<(instrument::channel::Record, f32)> {
    use instrument::wire::{parse, Line};
    let mut truth = std::collections::HashMap::new();
    let mut recs = vec![];
    for l in log {
        match parse(l) {
            Ok(Line::Truth(t)) => {
                truth.insert((t.t_us, t.sensor), t.stretch_mm);
            }
            Ok(Line::Rec(r)) => recs.push(r),
            _ => {}
        }
    }
    recs.into_iter()
        .map(|r| {
            let s = truth[&(r.t_us, r.sensor)];
            (r, s)
        })
        .collect()
}

/// RMS of the stretch error of the valid records, mm, and how many.
fn stretch_rms(recs: &[(instrument::channel::Record, f32)]) -> (f64, usize) {
    let errs: Vec<f64> = recs
        .iter()
        .filter(|(r, _)| r.flags.valid())
        .map(|(r, s)| (r.stretch_mm - s) as f64)
        .collect();
    let n = errs.len();
    (
        (errs.iter().map(|e| e * e).sum::<f64>() / n.max(1) as f64).sqrt(),
        n,
    )
}

#[test]
fn a_new_device_reads_uncalibrated_and_a_stored_table_is_its_own_sensors() {
    use instrument::calib::CalTable;
    use instrument::design::SENSOR_REST_LENGTH_MM;
    use instrument::faults::Flags;
    use instrument::stored::Stored;
    // "eight": eight sensors of 150–290 pF (20 pF apart), no leads.
    let c_rest = |ch: usize| (150.0 + 20.0 * ch as f64) * 1e-12;
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("settings.bin");
    let flash = format!("flash={}", path.display());

    // Nothing stored: C and R from the line alone; stretch not claimed.
    let (code, log) = run(&["eight", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert!(
        log.iter()
            .any(|l| l.starts_with("settings: measuring uncalibrated")),
        "{log:?}"
    );
    let start = log.iter().find(|l| l.starts_with("start 8 channels")).unwrap();
    assert!(
        start.ends_with("tab-lead ratio 0.0, stretch calibrated false"),
        "{start}"
    );
    let recs = records_with_truth(&log);
    assert!(recs.len() > 100, "{}", recs.len());
    assert!(recs
        .iter()
        .all(|(r, _)| r.flags.has(Flags::UNCALIBRATED) && r.stretch_mm == 0.0));
    let valid = recs.iter().filter(|(r, _)| r.flags.valid()).count();
    assert!(
        valid * 10 > recs.len() * 8,
        "C stays valid: {valid} of {}",
        recs.len()
    );
    let every_block = recs.len();

    // The host stores each sensor's own table, and a record every other
    // block; the next start measures with them (as a running device
    // would from its next block: `a_set_written_down_the_link…`).
    let mut set = Stored::uncalibrated();
    set.record_every = 2;
    for (ch, s) in set.sensors.iter_mut().enumerate() {
        s.in_use = ch < 8;
        s.nominal_c_farad = c_rest(ch.min(7)) as f32;
        s.table = CalTable::linear(c_rest(ch.min(7)), SENSOR_REST_LENGTH_MM).points;
        s.calibrated = true;
    }
    assert_eq!(live::config::write_image(&path, &set).unwrap(), 1);
    let (code, log) = run(&["eight", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert_eq!(digest_in(&log, "settings: generation 1"), Digest::of(&set));
    let recs = records_with_truth(&log);
    assert!(recs.iter().all(|(r, _)| !r.flags.has(Flags::UNCALIBRATED)));
    assert!(
        recs.len().abs_diff(every_block / 2) <= 8,
        "every other block: {} records, {every_block} before",
        recs.len()
    );
    let (own, n) = stretch_rms(&recs);
    assert!(n * 10 > recs.len() * 8, "{n} of {}", recs.len());
    assert!(own < 0.05, "stretch RMS on each sensor's own table: {own:.3} mm");

    // The same skin on one table for all (the rig's, no flash): each
    // sensor's stretch is off by its difference from the reference.
    let (code, log) = run(&["eight"]);
    assert_eq!(code, Some(0), "{log:?}");
    let (shared, _) = stretch_rms(&records_with_truth(&log));
    assert!(shared > 10.0, "stretch RMS on one table: {shared:.1} mm");
    println!("stretch RMS: own tables {own:.3} mm, one table {shared:.1} mm");
}

/// The array keeps its settings too: with nothing stored it reads every
/// sensor uncalibrated; a set the host stores (sensor 5 an empty socket,
/// sensor 2 on a table, a record every other block) is the one it
/// measures with after a restart; `save` stores the rig's over it. Every
/// run keeps the stack's margin.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn the_array_measures_with_its_stored_set() {
    use instrument::faults::Flags;
    use instrument::stored::Stored;
    use instrument::tones::ToneRecord;
    use instrument::wire::{parse, Line};
    let tones = |log: &[String]| -> Vec<ToneRecord> {
        log.iter()
            .filter_map(|l| match parse(l) {
                Ok(Line::Tone(r)) => Some(r),
                _ => None,
            })
            .collect()
    };
    let per_sensor = |recs: &[ToneRecord], s: u8| recs.iter().filter(|r| r.sensor == s).count();
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("array.bin");
    let flash = format!("flash={}", path.display());
    let (code, log) = run_image("skin-array", &["check", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert!(log.iter().any(|l| l == "settings: none stored"), "{log:?}");
    qemu_tests::assert_stack_margin("skin-array, a new flash", log.iter().map(String::as_str));
    let first = tones(&log);
    assert!(first.len() > 16 * 500, "{}", first.len());
    assert!(first
        .iter()
        .all(|r| r.flags.has(Flags::UNCALIBRATED) && r.stretch_mm == 0.0));

    let mut set = Stored::uncalibrated();
    set.sensors[5].in_use = false;
    set.sensors[2].table = instrument::calib::REFERENCE.points;
    set.sensors[2].calibrated = true;
    set.record_every = 2;
    assert_eq!(live::config::write_image(&path, &set).unwrap(), 1);
    let (code, log) = run_image("skin-array", &["check", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert_eq!(digest_in(&log, "settings: generation 1"), Digest::of(&set));
    qemu_tests::assert_stack_margin("skin-array, a stored set", log.iter().map(String::as_str));
    let second = tones(&log);
    assert_eq!(per_sensor(&second, 5), 0, "an empty socket");
    assert!(second
        .iter()
        .all(|r| r.flags.has(Flags::UNCALIBRATED) == (r.sensor != 2)));
    assert!(per_sensor(&second, 0).abs_diff(per_sensor(&first, 0) / 2) <= 1);

    // `save`: the rig's set (every sensor on the paper's table) stored
    // over the host's and measured with.
    let (code, log) = run_image("skin-array", &["check", &flash, "save"]);
    assert_eq!(code, Some(0), "{log:?}");
    assert!(
        log.iter().any(|l| l.starts_with("settings saved: generation 2")),
        "{log:?}"
    );
    assert!(tones(&log).iter().all(|r| !r.flags.has(Flags::UNCALIBRATED)));
    qemu_tests::assert_stack_margin("skin-array saving its settings", log.iter().map(String::as_str));
}

/// The array takes a set stored down the link while it runs: the applied
/// frame falls between the records of the set it started with (every
/// sensor uncalibrated) and those of the new one (sensor 5 an empty
/// socket, sensor 2 on a table, a record every other block), and the
/// stack keeps its margin through it.
#[test]
fn the_array_applies_a_set_stored_while_it_runs() {
    let uncalibrated = instrument::faults::Flags::UNCALIBRATED;
    let elf = qemu_tests::build_firmware("skin-array", &["qemu"]).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let flash = format!("flash={}", tmp.path().join("array.bin").display());
    let log = tmp.path().join("array.log");
    let args = ["check", &flash, "until-stop", "device=0x1A2B3C4D"];
    let (mut qemu, mut host) = Host::start(&elf, &args, &log);
    let mut set = instrument::stored::Stored::uncalibrated();
    set.sensors[5].in_use = false;
    set.sensors[2].table = instrument::calib::REFERENCE.points;
    set.sensors[2].calibrated = true;
    set.record_every = 2;
    // A host speaks once the device has announced itself: the array
    // reads no request before its start frame, which follows its 100 ms
    // self-test.
    let start = loop {
        let f = host
            .rx
            .recv_timeout(Duration::from_secs(120))
            .expect("the start frame");
        if let link::Body::Start(s) = f.body {
            break s;
        }
    };
    host.upload(&set);
    let (before, _, applied, _) = until_applied(&host.rx);
    // The start frame: the device's id, nothing stored.
    assert_eq!((start.device_id, start.generation), (0x1A2B_3C4D, 0));
    assert_eq!(applied.generation, 1);
    assert!(before.iter().any(|r| r.sensor == 5));
    assert!(before
        .iter()
        .all(|r| r.flags & uncalibrated != 0 && r.t_us <= applied.t_us));
    let after = records(&host.rx, 15 * 6);
    assert!(after.iter().all(|r| r.t_us > applied.t_us && r.sensor != 5));
    assert!(after
        .iter()
        .all(|r| (r.flags & uncalibrated == 0) == (r.sensor == 2)));
    assert_eq!(
        step(&after, 0),
        2 * step(&before, 0),
        "a record every other block"
    );
    host.send(link::Request::Stop);
    let status = qemu.wait().unwrap();
    assert!(status.success(), "{status}");
    let lines = log_lines(&elf, &log);
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("settings: generation 1 digest")),
        "{lines:?}"
    );
    qemu_tests::assert_stack_margin("skin-array, a set applied", lines.iter().map(String::as_str));
}
