//! The requests against a store in RAM: a set uploaded and read back;
//! each refusal; and a fuzzed command stream (junk, bit flips, dropped
//! and repeated bytes, random requests, pieces of good and bad sets)
//! that changes the stored set only through a well-formed commit the
//! device acknowledged.

use super::*;
use crate::store::{RamFlash, REGION_BYTES, SLOT_BYTES};
use crate::stored::Rule;
use std::vec;
use std::vec::Vec;

fn set(k: u32) -> Stored {
    let mut s = Stored::uncalibrated();
    s.record_every = 1 + (k % 200) as u8;
    s.sensors[(k % 16) as usize].parasitic_farad = k as f32 * 1e-13;
    s
}

/// Requests of `set`'s upload.
fn requests(set: &Stored) -> Vec<Request> {
    let mut out = vec![];
    upload(set, |r| out.push(r));
    out
}

/// Handle `reqs` in order (sequence numbers from 1); every reply.
fn run<F: NorFlash>(c: &mut Commands, store: &mut Store<F>, reqs: &[Request]) -> Vec<Reply>
where
    F::Error: crate::store::Corruption,
{
    let mut replies = vec![];
    for (k, r) in reqs.iter().enumerate() {
        c.handle(k as u32 + 1, r, store, |rep| replies.push(rep));
    }
    replies
}

#[test]
fn a_set_uploaded_is_stored_acknowledged_and_read_back() {
    let mut mem = vec![0xFFu8; REGION_BYTES];
    let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
    let mut c = Commands::new();
    // A new device has nothing to send.
    let r = run(&mut c, &mut store, &[Request::ReadSettings]);
    assert_eq!(
        r,
        vec![Reply::Refused {
            to: 1,
            reason: Reason::NothingStored
        }]
    );
    let reqs = requests(&set(3));
    assert!(reqs.len() > 40, "{} pieces", reqs.len());
    let r = run(&mut c, &mut store, &reqs);
    assert!(r[..reqs.len() - 1]
        .iter()
        .all(|x| matches!(x, Reply::Ack { generation: 0, .. })));
    assert_eq!(
        r.last(),
        Some(&Reply::Ack {
            to: reqs.len() as u32,
            generation: 1
        })
    );
    assert_eq!(store.load().unwrap().map(|l| l.set), Some(set(3)));
    // Read back: the pieces make the same set.
    let r = run(&mut c, &mut store, &[Request::ReadSettings]);
    let mut bytes = vec![];
    for x in &r[..r.len() - 1] {
        match x {
            Reply::Chunk { chunk, .. } => {
                assert_eq!(usize::from(chunk.offset), bytes.len());
                bytes.extend_from_slice(chunk.data());
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(r.last(), Some(&Reply::Ack { to: 1, generation: 1 }));
    assert_eq!(Stored::from_bytes(&bytes), Some(Ok(set(3))));
    // Start and stop are acknowledged and passed on.
    let mut actions = vec![];
    for req in [Request::Start, Request::Stop] {
        actions.push(c.handle(9, &req, &mut store, |_| {}));
    }
    assert_eq!(actions, vec![Action::Start, Action::Stop]);
}

#[test]
fn each_refusal_keeps_the_set_in_force() {
    let mut mem = vec![0xFFu8; REGION_BYTES];
    let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
    let mut c = Commands::new();
    run(&mut c, &mut store, &requests(&set(1)));
    let in_force = store.load().unwrap().unwrap();
    let last = |r: Vec<Reply>| *r.last().unwrap();
    // A set that breaks a rule: sensor 7's table out of order.
    let mut bad = set(2);
    bad.sensors[7].table.swap(2, 3);
    let r = last(run(&mut c, &mut store, &requests(&bad)));
    let reason = Reason::Setting {
        sensor: 7,
        rule: Rule::TableOrder.code(),
    };
    assert!(
        matches!(r, Reply::Refused { reason: x, .. } if x == reason),
        "{r:?}"
    );
    // A commit whose CRC does not match the pieces.
    let mut reqs = requests(&set(2));
    if let Some(Request::Commit { crc, .. }) = reqs.last_mut() {
        *crc ^= 1;
    }
    let r = last(run(&mut c, &mut store, &reqs));
    assert!(
        matches!(
            r,
            Reply::Refused {
                reason: Reason::Mismatch,
                ..
            }
        ),
        "{r:?}"
    );
    // A piece missing: out of order, then the commit does not match.
    let mut reqs = requests(&set(2));
    reqs.remove(5);
    let r = run(&mut c, &mut store, &reqs);
    assert!(
        matches!(
            r[5],
            Reply::Refused {
                reason: Reason::OutOfOrder,
                ..
            }
        ),
        "{:?}",
        r[5]
    );
    assert!(matches!(
        r.last(),
        Some(Reply::Refused {
            reason: Reason::Mismatch,
            ..
        })
    ));
    // Bytes that are not a set, with a matching length and CRC.
    let junk = [0x55u8; 40];
    let mut reqs = vec![];
    pieces(&junk, |c| reqs.push(Request::WriteChunk(c)));
    reqs.push(Request::Commit {
        len: 40,
        crc: crc(&junk),
    });
    let r = last(run(&mut c, &mut store, &reqs));
    assert!(
        matches!(
            r,
            Reply::Refused {
                reason: Reason::Malformed,
                ..
            }
        ),
        "{r:?}"
    );
    // More bytes than a set can have.
    let mut reqs = vec![];
    for k in 0..(MAX_BYTES / CHUNK + 1) {
        reqs.push(Request::WriteChunk(Chunk {
            offset: (k * CHUNK) as u16,
            len: CHUNK as u8,
            bytes: [1; CHUNK],
        }));
    }
    let r = last(run(&mut c, &mut store, &reqs));
    assert!(
        matches!(
            r,
            Reply::Refused {
                reason: Reason::TooLong,
                ..
            }
        ),
        "{r:?}"
    );
    // A piece claiming more bytes than a piece holds.
    let r = last(run(
        &mut c,
        &mut store,
        &[Request::WriteChunk(Chunk {
            offset: 0,
            len: 200,
            bytes: [0; CHUNK],
        })],
    ));
    assert!(
        matches!(
            r,
            Reply::Refused {
                reason: Reason::OutOfOrder,
                ..
            }
        ),
        "{r:?}"
    );
    assert_eq!(store.load().unwrap(), Some(in_force), "nothing changed");
}

/// xorshift64*.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// Fuzz cases (`COMMAND_CASES` sets more; `cargo xtask fuzz` runs many).
fn cases() -> u64 {
    std::env::var("COMMAND_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000)
}

#[test]
fn a_fuzzed_command_stream_changes_the_set_only_through_an_acknowledged_commit() {
    let mut rng = Rng(0x5EED_2026_1125_0001);
    let mut stores_changed = 0;
    for case in 0..cases() {
        let mut mem = vec![0xFFu8; REGION_BYTES];
        let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
        let mut c = if case % 2 == 0 {
            Commands::new()
        } else {
            Commands::sweeping()
        };
        // The host's side: a stream of frames, some good uploads, some
        // broken ones, some random requests, then damage on the wire.
        let mut enc = link::Encoder::new();
        let mut wire = vec![];
        let mut out = [0u8; link::MAX_FRAME];
        for _ in 0..4 {
            let mut reqs = match rng.below(4) {
                0 => requests(&set(rng.below(1000) as u32)),
                1 => {
                    let mut bad = set(rng.below(1000) as u32);
                    bad.sensors[rng.below(16) as usize].nominal_c_farad = -1.0;
                    requests(&bad)
                }
                2 => (0..rng.below(8))
                    .map(|_| {
                        let mut chunk = Chunk {
                            offset: (rng.below(4) * CHUNK as u64) as u16,
                            len: rng.below(40) as u8,
                            bytes: [0; CHUNK],
                        };
                        chunk.bytes.iter_mut().for_each(|b| *b = rng.next() as u8);
                        match rng.below(3) {
                            0 => Request::WriteChunk(chunk),
                            1 => Request::Commit {
                                len: rng.below(2048) as u16,
                                crc: rng.next() as u32,
                            },
                            _ => Request::ReadSettings,
                        }
                    })
                    .collect(),
                _ => vec![
                    Request::Start,
                    Request::Stop,
                    Request::Sweep {
                        blocks_per_pair: rng.next() as u16,
                    },
                ],
            };
            if rng.below(3) == 0 && !reqs.is_empty() {
                let k = rng.below(reqs.len() as u64) as usize;
                reqs.remove(k);
            }
            for r in reqs {
                wire.extend_from_slice(enc.frame(link::Body::Request(r), &mut out).unwrap());
            }
        }
        for _ in 0..rng.below(6) {
            let at = rng.below(wire.len() as u64 + 1) as usize;
            match rng.below(4) {
                0 if at < wire.len() => wire[at] ^= 1 << rng.below(8),
                1 if at < wire.len() => {
                    wire.remove(at);
                }
                2 => wire.insert(at, rng.next() as u8),
                _ => {
                    let junk: Vec<u8> = (0..rng.below(20)).map(|_| rng.next() as u8).collect();
                    wire.splice(at..at, junk);
                }
            }
        }
        // The device's side.
        let mut dec = link::Decoder::new();
        for &b in &wire {
            let Some(Ok(frame)) = dec.push(b) else { continue };
            let link::Body::Request(req) = frame.body else {
                continue;
            };
            let before = store.load().unwrap();
            let mut replies = vec![];
            let action = c.handle(frame.seq, &req, &mut store, |r| replies.push(r));
            let after = store.load().unwrap();
            assert!(!replies.is_empty(), "case {case}: every request is answered");
            if after == before {
                continue;
            }
            // Changed: only by a commit, acknowledged, whose length and
            // CRC are those of the set now stored, and which keeps the rules.
            stores_changed += 1;
            let Request::Commit { len, crc: want } = req else {
                panic!("case {case}: {req:?} changed the stored set");
            };
            let now = after.expect("a set");
            assert_eq!(action, Action::Apply);
            assert!(matches!(replies[..], [Reply::Ack { generation, .. }] if generation == now.generation));
            let mut buf = [0u8; MAX_BYTES];
            let bytes = now.set.to_bytes(&mut buf).unwrap();
            assert_eq!((bytes.len(), crc(bytes)), (usize::from(len), want), "case {case}");
            assert_eq!(now.set.check(), Ok(()));
        }
    }
    // Not vacuous: good uploads got through in some cases.
    assert!(
        stores_changed > cases() / 10,
        "{stores_changed} changes in {} cases",
        cases()
    );
}

#[test]
fn a_sweep_is_a_step_the_array_takes_and_a_single_tone_device_refuses() {
    let mut mem = vec![0xFFu8; REGION_BYTES];
    let mut store = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
    let mut actions = vec![];
    let mut ask = |c: &mut Commands, store: &mut Store<RamFlash>, n: u16| {
        let mut replies = vec![];
        actions.push(c.handle(7, &Request::Sweep { blocks_per_pair: n }, store, |r| {
            replies.push(r)
        }));
        replies
    };
    let mut array = Commands::sweeping();
    assert_eq!(
        ask(&mut array, &mut store, 50),
        [Reply::Ack { to: 7, generation: 0 }]
    );
    assert_eq!(
        ask(&mut array, &mut store, 0),
        [Reply::Refused {
            to: 7,
            reason: Reason::OutOfRange
        }]
    );
    assert_eq!(
        ask(&mut array, &mut store, link::SWEEP_MAX_BLOCKS + 1),
        [Reply::Refused {
            to: 7,
            reason: Reason::OutOfRange
        }]
    );
    let mut mux = Commands::new();
    assert_eq!(
        ask(&mut mux, &mut store, 50),
        [Reply::Refused {
            to: 7,
            reason: Reason::Unsupported
        }]
    );
    assert_eq!(
        actions,
        [Action::Sweep(50), Action::None, Action::None, Action::None]
    );
    assert_eq!(store.load(), Ok(None), "nothing stored by a sweep");
}
