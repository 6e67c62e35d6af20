//! Frames round-trip; the longest fits `MAX_FRAME`; a stream corrupted
//! in every way a serial line or a recording can corrupt it yields only
//! frames that were sent, and counts the rest.

use link::{
    decode, encode, Applied, Body, Decoder, Encoder, End, Error, Frame, Record, SelfTest, Start, Tone,
    Verdict, MAX_FRAME, VERSION,
};
use proptest::prelude::*;

fn tone() -> impl Strategy<Value = Tone> {
    (any::<f32>(), any::<f32>(), any::<f32>()).prop_map(|(f_hz, z_re_ohm, z_im_ohm)| Tone {
        f_hz,
        z_re_ohm,
        z_im_ohm,
    })
}

fn record() -> impl Strategy<Value = Record> {
    (
        any::<u64>(),
        any::<u8>(),
        [tone(), tone()],
        any::<[f32; 6]>(),
        any::<u16>(),
    )
        .prop_map(|(t_us, sensor, tones, v, flags)| Record {
            t_us,
            sensor,
            tones,
            c_farad: v[0],
            r_ohm: v[1],
            stretch_mm: v[2],
            chosen_hz: v[3],
            chi2: v[4],
            sigma_ln_c: v[5],
            flags,
        })
}

/// Any self-test result, every field to its extremes (the longest a
/// start frame can be).
fn self_test() -> impl Strategy<Value = SelfTest> {
    (
        prop_oneof![
            Just(Verdict::NotRun),
            Just(Verdict::Passed),
            Just(Verdict::Failed)
        ],
        any::<u32>(),
        any::<u32>(),
        any::<i32>(),
        any::<i32>(),
        any::<i32>(),
        any::<u16>(),
    )
        .prop_map(
            |(verdict, failed, noisy, gain_ppm, phase_urad, excitation_ppm, noise_permille)| SelfTest {
                verdict,
                failed,
                noisy,
                gain_ppm,
                phase_urad,
                excitation_ppm,
                noise_permille,
            },
        )
}

fn body() -> impl Strategy<Value = Body> {
    prop_oneof![
        record().prop_map(Body::Record),
        (
            any::<[u8; 24]>(),
            any::<u32>(),
            any::<u32>(),
            any::<u8>(),
            any::<u32>(),
            any::<u32>(),
            any::<u32>(),
            self_test()
        )
            .prop_map(|(fw, s, c, n, r, g, d, t)| {
                Body::Start(Start {
                    version: VERSION,
                    firmware: fw,
                    settings_digest: s,
                    calibration_digest: c,
                    sensors: n,
                    sample_rate_hz: r,
                    generation: g,
                    device_id: d,
                    self_test: t,
                })
            }),
        (any::<u32>(), any::<u32>()).prop_map(|(records, dropped)| Body::End(End { records, dropped })),
        (any::<u32>(), any::<u32>(), any::<u32>(), any::<u64>()).prop_map(|(g, s, c, t)| {
            Body::Applied(Applied {
                generation: g,
                settings_digest: s,
                calibration_digest: c,
                t_us: t,
            })
        }),
    ]
}

/// Equal bit for bit (NaNs included).
fn same(a: &Frame, b: &Frame) -> bool {
    let mut x = [0u8; MAX_FRAME];
    let mut y = [0u8; MAX_FRAME];
    encode(a, &mut x).ok() == encode(b, &mut y).ok()
}

proptest! {
    #[test]
    fn every_frame_round_trips_within_max_frame(seq in any::<u32>(), body in body()) {
        let frame = Frame { seq, body };
        let mut out = [0u8; MAX_FRAME];
        let bytes = encode(&frame, &mut out).unwrap();
        prop_assert!(bytes.len() <= MAX_FRAME);
        prop_assert_eq!(*bytes.last().unwrap(), 0);
        prop_assert!(!bytes[..bytes.len() - 1].contains(&0));
        let back = decode(&bytes[..bytes.len() - 1]).unwrap();
        prop_assert!(same(&back, &frame));
    }
}

#[test]
fn a_short_buffer_is_an_error_not_a_panic() {
    let frame = Frame {
        seq: 1,
        body: Body::Record(Record::default()),
    };
    for len in [0, 1, 5, 6, 8] {
        let mut out = vec![0u8; len];
        assert_eq!(
            encode(&frame, &mut out),
            Err(Error::BufferTooSmall),
            "{len} bytes"
        );
    }
}

/// A clean stream: a start frame, `n` records, an end frame.
fn stream(n: u32) -> (Vec<u8>, Vec<Frame>) {
    let mut enc = Encoder::new();
    let mut bytes = vec![];
    let mut frames = vec![];
    let mut out = [0u8; MAX_FRAME];
    let mut push = |body: Body, bytes: &mut Vec<u8>, frames: &mut Vec<Frame>| {
        let seq = frames.len() as u32;
        bytes.extend_from_slice(enc.frame(body, &mut out).unwrap());
        frames.push(Frame { seq, body });
    };
    push(
        Body::Start(Start {
            version: VERSION,
            firmware: Start::firmware_field("skin-array 0.1.0"),
            settings_digest: 0xDEAD_BEEF,
            calibration_digest: 0x0BAD_F00D,
            sensors: 16,
            sample_rate_hz: 25_000,
            generation: 3,
            device_id: 0xA1B2_C3D4,
            self_test: SelfTest::default(),
        }),
        &mut bytes,
        &mut frames,
    );
    for k in 0..n {
        let rec = Record {
            t_us: 2000 + 4000 * u64::from(k / 16),
            sensor: (k % 16) as u8,
            tones: [
                Tone {
                    f_hz: 500.0,
                    z_re_ohm: 4.1e5 + k as f32,
                    z_im_ohm: -1.6e6,
                },
                Tone {
                    f_hz: 2000.0,
                    z_re_ohm: 2.0e5,
                    z_im_ohm: -3.9e5 - k as f32,
                },
            ],
            c_farad: 205e-12 + k as f32 * 1e-15,
            r_ohm: 7.1e5,
            stretch_mm: 0.01 * k as f32,
            chosen_hz: 2000.0,
            chi2: 1.5,
            sigma_ln_c: 4e-4,
            flags: (k % 7 == 0) as u16 * 64,
        };
        push(Body::Record(rec), &mut bytes, &mut frames);
    }
    push(
        Body::End(End {
            records: n,
            dropped: 0,
        }),
        &mut bytes,
        &mut frames,
    );
    (bytes, frames)
}

fn replay(bytes: &[u8]) -> (Vec<Frame>, link::Stats) {
    let mut d = Decoder::new();
    let frames = bytes
        .iter()
        .filter_map(|&b| d.push(b))
        .filter_map(Result::ok)
        .collect();
    (frames, d.stats())
}

#[test]
fn a_clean_stream_replays_whole() {
    let (bytes, sent) = stream(64);
    let (got, stats) = replay(&bytes);
    assert_eq!(got, sent);
    assert_eq!((stats.bad, stats.lost, stats.repeated), (0, 0, 0));
    println!(
        "bytes per record frame: {:.1}",
        bytes.len() as f64 / sent.len() as f64
    );
}

/// Cases of corruption (the full pass runs this many, the test command
/// 1 000; the long fuzz
/// command more, through `LINK_CASES`).
fn cases() -> u64 {
    std::env::var("LINK_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000)
}

/// A small deterministic generator (xorshift64*), so that a failure
/// names its case.
struct Xs(u64);
impl Xs {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Corrupt `clean` one to four ways: bit flips, dropped, duplicated or
/// inserted bytes, junk between frames, a truncated end.
fn corrupt(clean: &[u8], rng: &mut Xs) -> Vec<u8> {
    let mut b = clean.to_vec();
    for _ in 0..1 + rng.below(4) {
        if b.is_empty() {
            break;
        }
        let at = rng.below(b.len());
        match rng.below(6) {
            0 => b[at] ^= 1 << rng.below(8),
            1 => {
                b.remove(at);
            }
            2 => {
                let n = 1 + rng.below(8).min(b.len() - at - 1);
                let run: Vec<u8> = b[at..at + n].to_vec();
                b.splice(at..at, run);
            }
            3 => b.insert(at, rng.next() as u8),
            4 => {
                let junk: Vec<u8> = (0..1 + rng.below(40)).map(|_| rng.next() as u8).collect();
                b.splice(at..at, junk);
            }
            _ => b.truncate(at),
        }
    }
    b
}

#[test]
fn a_corrupted_stream_yields_only_frames_that_were_sent() {
    let (clean, sent) = stream(40);
    let mut rng = Xs(0x9E37_79B9_7F4A_7C15);
    let (mut got, mut bad, mut lost) = (0u64, 0u64, 0u64);
    for case in 0..cases() {
        let bytes = corrupt(&clean, &mut rng);
        let (frames, stats) = replay(&bytes);
        for f in &frames {
            let original = sent.get(f.seq as usize);
            assert!(
                original.is_some_and(|o| same(o, f)),
                "case {case}: a frame that was never sent: {f:?}"
            );
        }
        got += frames.len() as u64;
        bad += stats.bad;
        lost += sent.len() as u64 - frames.len() as u64;
    }
    println!(
        "{} corrupted streams: {got} frames out, all as sent; {bad} refused, {lost} lost",
        cases()
    );
    assert!(got > 0 && bad > 0 && lost > 0);
}

/// `Decoder::next_frame` on a stream cut into pieces anywhere (as reads
/// from a port deliver it) gives the same frames, errors and counts as
/// `Decoder::push` byte by byte, on clean and corrupted streams (oversized
/// frames among them).
#[test]
fn the_bytes_at_once_are_the_bytes_one_by_one() {
    let (clean, _) = stream(40);
    let mut rng = Xs(0x2545_F491_4F6C_DD1D);
    for case in 0..cases() / 10 {
        let mut bytes = match case % 4 {
            0 => clean.clone(),
            _ => corrupt(&clean, &mut rng),
        };
        if case % 7 == 0 {
            // A run longer than any frame (a corruption may have left
            // nothing: then the run is all).
            let at = rng.below(bytes.len() + 1);
            bytes.splice(at..at, std::iter::repeat_n(0x55, MAX_FRAME + rng.below(40)));
        }
        let mut one = Decoder::new();
        let by_byte: Vec<_> = bytes.iter().filter_map(|&b| one.push(b)).collect();
        let mut many = Decoder::new();
        let mut at_once = vec![];
        let mut rest = &bytes[..];
        while !rest.is_empty() {
            let n = 1 + rng.below(200).min(rest.len() - 1);
            let mut piece = &rest[..n];
            while let Some(r) = many.next_frame(&mut piece) {
                at_once.push(r);
            }
            assert!(piece.is_empty());
            rest = &rest[n..];
        }
        assert_eq!(at_once, by_byte, "case {case}");
        assert_eq!(many.stats(), one.stats(), "case {case}");
    }
}

#[test]
fn a_repeated_frame_is_dropped_and_a_gap_counted() {
    let (clean, sent) = stream(4);
    // Frames end at zeros: duplicate frame 2, drop frame 4.
    let ends: Vec<usize> = clean
        .iter()
        .enumerate()
        .filter(|(_, &b)| b == 0)
        .map(|(i, _)| i + 1)
        .collect();
    let f = |k: usize| &clean[if k == 0 { 0 } else { ends[k - 1] }..ends[k]];
    let mut bytes = vec![];
    for k in [0, 1, 2, 2, 3, 5] {
        bytes.extend_from_slice(f(k));
    }
    let (got, stats) = replay(&bytes);
    assert_eq!(got.iter().map(|f| f.seq).collect::<Vec<_>>(), [0, 1, 2, 3, 5]);
    assert_eq!((stats.repeated, stats.lost), (1, 1));
    assert!(got.iter().all(|f| same(f, &sent[f.seq as usize])));
}

#[test]
fn sixteen_sensors_at_1000_records_a_second_take_at_most_80_percent_of_the_board_link() {
    let frame = link::longest_record_frame();
    let bits_per_s = u64::from(link::RECORDS_PER_S) * frame as u64 * u64::from(link::BITS_PER_BYTE);
    let load = bits_per_s as f64 / f64::from(link::BOARD_BAUD);
    let table = format!(
        "| | |\n|---|---:|\n\
         | the longest record frame (every varint at its longest) | {frame} B |\n\
         | bits on the wire per byte (8N1) | {} |\n\
         | records per second (16 sensors × 1000) | {} |\n\
         | the link's load | {:.2} Mbit/s |\n\
         | the board's baud rate | {:.0} MBd |\n\
         | share of it | {:.1} % (at most {} %) |\n",
        link::BITS_PER_BYTE,
        link::RECORDS_PER_S,
        bits_per_s as f64 / 1e6,
        f64::from(link::BOARD_BAUD) / 1e6,
        100.0 * load,
        link::LOAD_LIMIT,
    );
    print!("{table}");
    figures::check("docs/firmware.md", "link-budget", &table).unwrap();
    assert!(frame < link::MAX_FRAME, "{frame}");
    assert!(
        load <= f64::from(link::LOAD_LIMIT) / 100.0,
        "{:.1} %",
        100.0 * load
    );
    // The figure is not vacuous: a typical frame is within a few bytes.
    let mut out = [0u8; link::MAX_FRAME];
    let typical = link::Encoder::new()
        .frame(link::Body::Record(link::Record::default()), &mut out)
        .unwrap()
        .len();
    assert!(typical + 16 > frame && typical < frame, "{typical} vs {frame}");
}

/// A frame as a newer sender might send it: `tag` as the body's variant,
/// `payload` after it, sealed with a valid CRC and COBS.
fn sealed(seq: u8, tag: u8, payload: &[u8]) -> Vec<u8> {
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
    let mut raw = vec![seq, tag];
    raw.extend_from_slice(payload);
    raw.extend_from_slice(&crc.checksum(&raw).to_le_bytes());
    let mut out = vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
    let n = cobs::encode(&raw, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

#[test]
fn an_unknown_frame_type_is_refused_and_counted_and_the_stream_goes_on() {
    let (clean, sent) = stream(3);
    // Frame type 7 does not exist: its CRC holds, its body does not parse.
    let mut bytes = sealed(1, 7, &[1, 2, 3]);
    bytes.extend_from_slice(&clean);
    let mut d = Decoder::new();
    let mut got = vec![];
    let mut errors = vec![];
    for &b in &bytes {
        match d.push(b) {
            Some(Ok(f)) => got.push(f),
            Some(Err(e)) => errors.push(e),
            None => {}
        }
    }
    assert_eq!(errors, vec![Error::Body]);
    assert_eq!(errors[0].to_string(), "an unknown frame type or layout");
    assert_eq!(got.len(), sent.len());
    assert_eq!(d.stats().bad, 1);
}

#[test]
fn requests_and_replies_at_their_longest_fit_a_frame() {
    use link::{Chunk, Reason, Reply, Request, CHUNK};
    let chunk = Chunk {
        offset: u16::MAX,
        len: CHUNK as u8,
        bytes: [0xA5; CHUNK],
    };
    let bodies = [
        Body::Request(Request::WriteChunk(chunk)),
        Body::Request(Request::Commit {
            len: u16::MAX,
            crc: u32::MAX,
        }),
        Body::Reply(Reply::Chunk { to: u32::MAX, chunk }),
        Body::Reply(Reply::Refused {
            to: u32::MAX,
            reason: Reason::Setting {
                sensor: 255,
                rule: 255,
            },
        }),
        Body::Reply(Reply::Ack {
            to: u32::MAX,
            generation: u32::MAX,
        }),
    ];
    for body in bodies {
        let frame = Frame { seq: u32::MAX, body };
        let mut out = [0u8; MAX_FRAME];
        let bytes = encode(&frame, &mut out).unwrap();
        assert_eq!(decode(&bytes[..bytes.len() - 1]), Ok(frame));
    }
    assert_eq!(chunk.data().len(), CHUNK);
}

#[test]
fn the_devices_encoders_write_the_same_bytes_as_the_generic_one() {
    use link::{Reason, Reply};
    let rec = Record {
        t_us: 123_456_789,
        sensor: 9,
        c_farad: 2.1e-10,
        flags: 300,
        ..Record::default()
    };
    let start = Start {
        version: VERSION,
        sensors: 16,
        ..Start::default()
    };
    let end = End {
        records: 7,
        dropped: 1,
    };
    let reply = Reply::Refused {
        to: 40_000,
        reason: Reason::Setting { sensor: 3, rule: 9 },
    };
    let status = link::Status {
        t_us: u64::MAX,
        clock: link::Clock::Instructions,
        clock_hz: 170_000_000,
        period: 680_000,
        blocks: 250,
        mean: 150_000,
        max: u32::MAX,
        late: 1,
        missed: 2,
    };
    let (mut a, mut b) = (Encoder::new(), Encoder::new());
    for _ in 0..200 {
        let (mut x, mut y) = ([0u8; MAX_FRAME], [0u8; MAX_FRAME]);
        let bytes = a.status(&status, &mut x).unwrap();
        assert_eq!(bytes, b.frame(Body::Status(status), &mut y).unwrap());
        assert_eq!(
            decode(&bytes[..bytes.len() - 1]).map(|f| f.body),
            Ok(Body::Status(status))
        );
        let (mut x, mut y) = ([0u8; MAX_FRAME], [0u8; MAX_FRAME]);
        assert_eq!(
            a.start(&start, &mut x).unwrap(),
            b.frame(Body::Start(start), &mut y).unwrap()
        );
        assert_eq!(
            a.record(&rec, &mut x).unwrap(),
            b.frame(Body::Record(rec), &mut y).unwrap()
        );
        assert_eq!(
            a.end(&end, &mut x).unwrap(),
            b.frame(Body::End(end), &mut y).unwrap()
        );
        assert_eq!(
            a.reply(&reply, &mut x).unwrap(),
            b.frame(Body::Reply(reply), &mut y).unwrap()
        );
    }
    assert_eq!(a.next_seq(), 1000);
}

/// A device's decoder (`push_request`) hands back exactly the requests a
/// full decoder finds, with their sequence numbers, and counts every
/// other frame alike, on clean and corrupted streams.
#[test]
fn a_devices_decoder_finds_the_requests_a_full_one_does() {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut clean = vec![];
    for k in 0..60u32 {
        let body = match k % 4 {
            0 => Body::Request(link::Request::ReadSettings),
            1 => Body::Request(link::Request::Sweep {
                blocks_per_pair: k as u16,
            }),
            2 => Body::Record(Record::default()),
            _ => Body::End(End {
                records: k,
                dropped: 0,
            }),
        };
        clean.extend_from_slice(enc.frame(body, &mut out).unwrap());
    }
    let mut rng = Xs(0x5EED);
    for case in 0..200 {
        let bytes = if case == 0 {
            clean.clone()
        } else {
            corrupt(&clean, &mut rng)
        };
        let (mut full, mut device) = (Decoder::new(), Decoder::new());
        let want: Vec<_> = bytes
            .iter()
            .filter_map(|&b| full.push(b))
            .filter_map(|r| match r {
                Ok(Frame {
                    seq,
                    body: Body::Request(q),
                }) => Some(Ok((seq, q))),
                Ok(_) => None,
                Err(e) => Some(Err(e)),
            })
            .collect();
        let got: Vec<_> = bytes.iter().filter_map(|&b| device.push_request(b)).collect();
        assert_eq!(got, want, "case {case}");
        assert_eq!(device.stats(), full.stats(), "case {case}");
        if case == 0 {
            assert_eq!(got.len(), 30);
        }
    }
}
