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
