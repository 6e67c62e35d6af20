//! A set the device applies while it runs: `live` keeps each segment's
//! sets in force in the manifest (the start's, then each applied frame's
//! with the sequence number after which it holds), says so when it
//! finishes, and the Python reader gives each record the generation it
//! was measured with.

mod common;

use link::{Applied, Body, Encoder, End, Start, MAX_FRAME};

/// A device started with stored generation 1 that applies generation 2
/// after its fourth record, eight records in all.
fn stream() -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = vec![];
    let mut push = |body: Body| bytes.extend_from_slice(enc.frame(body, &mut out).unwrap());
    push(Body::Start(Start {
        version: link::VERSION,
        firmware: Start::firmware_field("test"),
        sensors: 2,
        sample_rate_hz: 200_000,
        settings_digest: 0x1111_1111,
        generation: 1,
        ..Start::default()
    }));
    let record = |k: u32| common::single_tone(4000 * u64::from(k / 2 + 1), (k % 2) as u8);
    for k in 0..4 {
        push(Body::Record(record(k)));
    }
    push(Body::Applied(Applied {
        generation: 2,
        settings_digest: 0x2222_2222,
        calibration_digest: 0x3333_3333,
        t_us: 8000,
    }));
    for k in 4..8 {
        push(Body::Record(record(k)));
    }
    push(Body::End(End {
        records: 8,
        dropped: 0,
    }));
    bytes
}

#[test]
fn the_sets_in_force_are_kept_and_each_record_has_its_generation() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("stream.bin");
    std::fs::write(&file, stream()).unwrap();
    let dir = tmp.path().join("set");
    let (code, out, err) = common::live(&[
        "--replay",
        file.to_str().unwrap(),
        "--dataset",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("segment 0: settings generation 2 applied at 0.008 s (frame 5)"),
        "{out}"
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("session.json")).unwrap()).unwrap();
    let g = &m["segments"][0];
    assert_eq!(g["generation"], 1, "{g}");
    let sets = g["settings_in_force"].as_array().unwrap();
    assert_eq!(sets.len(), 2, "{g}");
    assert_eq!(
        (sets[0]["generation"].as_u64(), sets[0]["from_seq"].as_u64()),
        (Some(1), Some(0))
    );
    assert_eq!(sets[0]["settings_digest"], "11111111");
    assert_eq!(
        (sets[1]["generation"].as_u64(), sets[1]["from_seq"].as_u64()),
        (Some(2), Some(5))
    );
    assert_eq!(sets[1]["calibration_digest"], "33333333");
    assert_eq!(sets[1]["t_us"], 8000);

    // The Python reader, from the manifest and from the stream alone.
    let said = common::python_says(
        "import sys; from skinread import dataset, stream\n\
         a = dataset.read_records(sys.argv[1])['generation'].tolist()\n\
         b = stream.read_stream(sys.argv[1] + '/stream.bin')[0]['generation'].tolist()\n\
         print(a, b)",
        &dir,
    );
    assert_eq!(said.trim(), "[1, 1, 1, 1, 2, 2, 2, 2] [1, 1, 1, 1, 2, 2, 2, 2]");
}
