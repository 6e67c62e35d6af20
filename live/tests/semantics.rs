//! A stream that decodes but breaks its own terms: records of sensors
//! the start frame does not count, time going backwards, a device that
//! restarts (with the same wire version, or another), an end frame whose
//! count cannot be what arrived. Each is named and counted, and what came
//! before is kept.

use link::{Body, Encoder, End, Record, Start, MAX_FRAME, VERSION};

/// A device's frames, encoded as it numbers them.
struct Device {
    enc: Encoder,
    bytes: Vec<u8>,
}

impl Device {
    fn new() -> Self {
        Self {
            enc: Encoder::new(),
            bytes: vec![],
        }
    }

    fn send(&mut self, body: Body) {
        let mut out = [0u8; MAX_FRAME];
        let frame = self.enc.frame(body, &mut out).unwrap().to_vec();
        self.bytes.extend_from_slice(&frame);
    }

    /// A start frame of `version` for `sensors`; the device's numbering
    /// starts over, as after a restart.
    fn start(&mut self, version: u16, sensors: u8) {
        self.enc = Encoder::new();
        self.send(Body::Start(Start {
            version,
            firmware: Start::firmware_field("test"),
            sensors,
            ..Start::default()
        }));
    }

    fn record(&mut self, sensor: u8, t_us: u64) {
        self.send(Body::Record(Record {
            t_us,
            sensor,
            c_farad: 205e-12,
            r_ohm: 7e5,
            ..Record::default()
        }));
    }

    /// `n` records of sensors 0 and 1 in turn, 1 ms apart from 0.5 ms.
    fn records(&mut self, n: u64) {
        for k in 0..n {
            self.record((k % 2) as u8, 1000 * k + 500);
        }
    }

    fn end(&mut self, records: u32) {
        self.send(Body::End(End { records, dropped: 0 }));
    }
}

fn replay(bytes: &[u8]) -> live::Finished {
    let tmp = tempfile::tempdir().unwrap();
    live::replay(bytes, &tmp.path().join("ds"), live::Earlier::Refuse).unwrap()
}

#[test]
fn records_beyond_the_sensors_or_not_later_are_set_aside_by_name() {
    let mut d = Device::new();
    d.start(VERSION, 2);
    d.records(10);
    d.record(200, 20_000);
    d.record(255, 20_000);
    // Time going backwards on sensor 0, and sensor 1's last record again.
    d.record(0, 3_500);
    d.record(1, 9_500);
    d.end(14);
    let done = replay(&d.bytes);
    let s = &done.summary;
    assert_eq!(s.records, 10, "{}", s.line());
    assert_eq!((s.set_aside.beyond_sensors, s.set_aside.not_later), (2, 2));
    assert_eq!(s.end_mismatch, None, "{}", s.line());
    assert_eq!(done.outcome, live::Outcome::Complete);
    let line = s.line();
    assert!(
        line.contains("2 records of sensors beyond the start frame's count"),
        "{line}"
    );
    assert!(
        line.contains("2 records not later than their sensor's last"),
        "{line}"
    );
}

#[test]
fn an_end_frame_that_cannot_be_what_arrived_is_named() {
    for said in [3u32, 40] {
        let mut d = Device::new();
        d.start(VERSION, 2);
        d.records(10);
        d.end(said);
        let s = replay(&d.bytes).summary;
        let m = s.end_mismatch.clone().unwrap_or_default();
        assert!(
            m.contains(&format!("says {said} records were sent, but 10 arrived")),
            "{}",
            s.line()
        );
    }
}

#[test]
fn a_restart_keeps_every_record_and_is_counted() {
    let mut d = Device::new();
    d.start(VERSION, 2);
    d.records(6);
    // The device restarts: its clock and numbering start over.
    d.start(VERSION, 2);
    d.records(4);
    d.end(4);
    let done = replay(&d.bytes);
    assert_eq!(done.summary.records, 10, "{}", done.summary.line());
    assert_eq!(done.summary.restarts, 1);
    assert_eq!(done.summary.set_aside.total(), 0);
    assert!(done.summary.line().contains("restarted 1 time"));
}

#[test]
fn another_wire_version_after_a_restart_stops_the_session_keeping_what_came() {
    let mut d = Device::new();
    d.start(VERSION, 2);
    d.records(6);
    d.start(VERSION + 1, 2);
    d.records(4);
    d.end(4);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let done = live::replay(&d.bytes, &dir, live::Earlier::Refuse).unwrap();
    assert_eq!(done.summary.records, 6);
    match &done.outcome {
        live::Outcome::Incomplete(why) => {
            assert!(why.contains(&format!("wire version {}", VERSION + 1)), "{why}")
        }
        other => panic!("{other:?}"),
    }
    let csv = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7, "{csv}");
    assert!(dir.join(live::INCOMPLETE).is_file());
}

/// A record of `sensor` at `t_us` with a capacitor's impedance at 2 kHz:
/// a row of its trace.
fn measured(d: &mut Device, sensor: u8, t_us: u64) {
    d.send(Body::Record(Record {
        t_us,
        sensor,
        tones: [
            link::Tone {
                f_hz: 2000.0,
                z_re_ohm: 2.3e5,
                z_im_ohm: -3.9e5,
            },
            link::Tone::default(),
        ],
        c_farad: 205e-12,
        r_ohm: 7e5,
        stretch_mm: 0.1 * t_us as f32 / 1000.0,
        ..Record::default()
    }));
}

#[test]
fn a_restart_is_a_segment_of_its_own_in_every_file() {
    let mut d = Device::new();
    d.start(VERSION, 1);
    for k in 0..20 {
        measured(&mut d, 0, 1000 * k + 500);
    }
    // The device restarts: its clock and numbering start over.
    d.start(VERSION, 1);
    for k in 0..12 {
        measured(&mut d, 0, 1000 * k + 500);
    }
    d.end(12);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let done = live::replay(&d.bytes, &dir, live::Earlier::Refuse).unwrap();
    assert_eq!(done.outcome, live::Outcome::Complete);
    assert_eq!(done.summary.end_mismatch, None, "{}", done.summary.line());
    let csv = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    let segs: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(segs, [vec!["1"; 20], vec!["2"; 12]].concat());
    // A trace per segment, each in its own time.
    for (name, rows) in [("trace_ch0_2000hz.csv", 20), ("trace_s2_ch0_2000hz.csv", 12)] {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        let t: Vec<f64> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').next().unwrap().parse().unwrap())
            .collect();
        assert_eq!(t.len(), rows, "{name}");
        assert!(t.windows(2).all(|w| w[1] > w[0]), "{name}: {t:?}");
    }
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join(live::MANIFEST)).unwrap()).unwrap();
    let kept: Vec<u64> = m["segments"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["records_kept"].as_u64().unwrap())
        .collect();
    assert_eq!(kept, [20, 12]);
    assert_eq!(m["segments"][1]["end"]["agrees"], true);
}

#[test]
fn frames_replayed_later_are_duplicates_not_records_nor_losses() {
    let mut d = Device::new();
    d.start(VERSION, 1);
    let mut at = vec![];
    for k in 0..10 {
        at.push(d.bytes.len());
        measured(&mut d, 0, 1000 * k + 500);
    }
    // Frames 3 to 6 again, as a link that replays what it buffered.
    let again = d.bytes[at[3]..at[7]].to_vec();
    d.bytes.extend_from_slice(&again);
    for k in 10..20 {
        measured(&mut d, 0, 1000 * k + 500);
    }
    d.end(20);
    let done = replay(&d.bytes);
    let s = &done.summary;
    assert_eq!(s.records, 20, "{}", s.line());
    assert_eq!((s.link.lost, s.link.repeated), (0, 4), "{}", s.line());
    assert_eq!(s.set_aside.total(), 0, "{}", s.line());
    assert_eq!(s.end_mismatch, None, "{}", s.line());
}

#[test]
fn a_killed_session_leaves_its_marker_no_manifest_and_whole_lines() {
    let mut d = Device::new();
    d.start(VERSION, 1);
    for k in 0..50 {
        measured(&mut d, 0, 1000 * k + 500);
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let mut s = live::Session::new(&dir, live::Earlier::Refuse).unwrap();
    s.push(&d.bytes).unwrap();
    s.flush().unwrap();
    // More arrives, then the process dies: nothing more is written.
    measured(&mut d, 0, 60_500);
    std::mem::forget(s);
    assert!(dir.join(live::INCOMPLETE).is_file());
    assert!(!dir.join(live::MANIFEST).exists());
    let csv = std::fs::read_to_string(dir.join("records.csv")).unwrap();
    assert_eq!(csv.lines().count(), 51);
    assert!(csv.ends_with('\n'));
    let trace = std::fs::read_to_string(dir.join("trace_ch0_2000hz.csv")).unwrap();
    assert_eq!(trace.lines().count(), 51);
}

mod common;

#[test]
fn each_sensors_share_of_valid_records_and_why_the_others_are_not() {
    // Record 3 (sensor 1's second) is flagged SETTLING: sensor 1 keeps 4
    // of its 5 valid, sensor 0 all 5.
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    let done = live::replay(&common::stream(10, true, VERSION), &ds, live::Earlier::Refuse).unwrap();
    let s = &done.summary;
    let a = |sensor: u8| s.availability.get(&sensor).copied().unwrap();
    assert_eq!((a(0).records, a(0).valid), (5, 5));
    assert_eq!((a(1).records, a(1).valid), (5, 4));
    assert_eq!(s.least_valid().map(|(k, _)| k), Some(1));
    assert!(
        s.line().contains("(the least valid: sensor 1, 80.0 %)"),
        "{}",
        s.line()
    );
    assert_eq!(
        s.availability_lines(),
        [
            "sensor 0: 100.0 % valid (5 of 5)",
            "sensor 1: 80.0 % valid (4 of 5); not: SETTLING 1; 1 of them interpolated"
        ]
    );
    // Sensor 1's second record, between two valid ones 21.8 ms apart, is
    // given their line at its time in interpolated.csv, with its flags;
    // records.csv keeps it as measured.
    let rows = std::fs::read_to_string(ds.join(live::INTERPOLATED_CSV)).unwrap();
    let rows: Vec<&str> = rows.lines().collect();
    assert_eq!(rows.len(), 2, "{rows:?}");
    assert_eq!(
        rows[0],
        "segment,seq,t_us,sensor,c_pf,r_ohm,stretch_mm,gap_us,flags"
    );
    assert_eq!(
        rows[1],
        format!("1,4,{},1,205.0000,700000,0.3000,21760,16", 2560 + 5440 * 3)
    );
    assert_eq!(s.interpolated.get(&1), Some(&1));
    assert!(s.line().contains(", 1 flagged (1 interpolated)"), "{}", s.line());
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ds.join("session.json")).unwrap()).unwrap();
    let per = &manifest["records"]["per_sensor"];
    assert_eq!(per[1]["valid"], 4);
    assert_eq!(per[1]["share_valid"], 0.8);
    assert_eq!(per[1]["not_valid_by_fault"]["SETTLING"], 1);
    assert_eq!(per[0]["not_valid_by_fault"], serde_json::json!({}));
    assert_eq!(per[1]["interpolated"], 1);
    assert_eq!(per[0]["interpolated"], 0);
}
