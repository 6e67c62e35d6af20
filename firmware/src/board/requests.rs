//! The host's requests on the board: the bytes DMA2 channel 2 leaves
//! round the receive ring ([`super::link::receive`]), decoded into
//! requests and answered with the settings stored in flash
//! ([`instrument::commands`], [`super::flash`]). Each board application
//! with a settings store runs [`Requests::answer`] from its `idle`; the
//! host tests run it over a ring and a flash in RAM.

use super::link::{Receiver, RxRing, RX_BYTES};
use crate::link_out::FrameWriter;
use embedded_storage::nor_flash::NorFlash;
use instrument::commands::{Action, Commands};
use instrument::store::{Corruption, Store};

/// How many times a reply kicks the transmitter while it waits for room
/// (each a pend and a look at the queue, well under a microsecond: a
/// frame leaves in 64 µs at the link's 15 MBd).
pub const KICKS: u32 = 100_000;

/// The receive ring, read only behind the DMA's position.
struct Ring(*const u8);

// SAFETY: the pointer is to a 'static ring; only the bytes the DMA has
// written are read (`Receiver::take`), with volatile reads.
#[allow(unsafe_code)]
unsafe impl Send for Ring {}

/// The request side of the link: the ring's reader, the frame decoder,
/// the commands and the store they answer from (on the board over
/// [`super::flash::SettingsFlash`]).
pub struct Requests<F: NorFlash> {
    ring: Ring,
    rx: Receiver,
    decoder: ::link::Decoder,
    commands: Commands,
    store: Store<F>,
}

impl<F: NorFlash> Requests<F>
where
    F::Error: Corruption,
{
    /// Over `ring`, which DMA2 channel 2 fills from now on, answering
    /// with `commands` from `store`.
    pub fn new(ring: &'static mut RxRing, commands: Commands, store: Store<F>) -> Self {
        Self {
            ring: Ring(ring.as_ptr()),
            rx: Receiver::new(),
            decoder: ::link::Decoder::new(),
            commands,
            store,
        }
    }

    /// Take the set the store holds into `in_force` (after
    /// [`Action::Apply`]): [`crate::in_force::InForce::apply_stored`].
    pub fn apply<C, const S: usize>(
        &mut self,
        in_force: &mut crate::in_force::InForce<C, S>,
        t_us: u64,
    ) -> Result<::link::Applied, crate::in_force::NotApplied>
    where
        C: crate::in_force::Shared<S>,
    {
        in_force.apply_stored(&mut self.store, t_us)
    }

    /// The request the ring now holds whole, if one, answered through
    /// `writer`; then what the application must do. `remaining`: the
    /// receive channel's count
    /// ([`super::link::Transmitter::rx_remaining`]). The host sends one
    /// request and waits for its reply, so one a call is all there is.
    ///
    /// A read's reply is the set in pieces, some 2.5 KiB of frames, more
    /// than a board's queue holds: each reply waits for room, calling
    /// `kick` (which pends the transmitter) as the link drains the
    /// queue, so that no piece is lost. The wait is bounded
    /// ([`KICKS`] once a request): a link that does not drain loses the
    /// replies, as before, and the host asks again.
    pub fn answer<const N: usize>(
        &mut self,
        remaining: u16,
        writer: &mut FrameWriter<'_, N>,
        mut kick: impl FnMut(),
    ) -> Option<Action> {
        let ring = self.ring.0;
        // SAFETY: within the 'static ring of RX_BYTES; the DMA has
        // written these bytes and writes others.
        #[allow(unsafe_code)]
        let byte = |k: usize| unsafe { core::ptr::read_volatile(ring.add(k.min(RX_BYTES - 1))) };
        let decoder = &mut self.decoder;
        let mut request = None;
        self.rx.take(remaining, byte, |b| {
            if let Some(Ok(r)) = decoder.push_request(b) {
                request = Some(r);
            }
        });
        let (seq, req) = request?;
        // Once a reply has waited in vain, the rest of this request's
        // replies do not wait.
        let mut patient = true;
        Some(self.commands.handle(seq, &req, &mut self.store, |r| {
            let mut tries = 0;
            while patient && !writer.has_room() {
                kick();
                tries += 1;
                patient = tries < KICKS;
            }
            writer.reply(r);
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link_out::LinkQueue;
    use instrument::store::{RamFlash, SLOT_BYTES};
    use link::{Body, Frame, Reply, Request};
    use std::boxed::Box;
    use std::vec;
    use std::vec::Vec;

    /// A request's frame as the host sends it.
    fn frame(seq: u32, req: Request) -> Vec<u8> {
        let mut out = [0u8; link::MAX_FRAME];
        link::encode(
            &Frame {
                seq,
                body: Body::Request(req),
            },
            &mut out,
        )
        .unwrap()
        .to_vec()
    }

    /// The ring and what writes it, as DMA2 channel 2 does: round and
    /// round, its count (CNDTR) going down from the ring's length.
    struct Dma {
        ring: *mut u8,
        at: usize,
    }

    impl Dma {
        fn write(&mut self, bytes: &[u8]) {
            for &b in bytes {
                // SAFETY: within the leaked ring of RX_BYTES; the test is
                // the only writer, and reads happen between writes.
                #[allow(unsafe_code)]
                unsafe {
                    self.ring.add(self.at).write_volatile(b)
                };
                self.at = (self.at + 1) % RX_BYTES;
            }
        }

        fn remaining(&self) -> u16 {
            (RX_BYTES - self.at) as u16
        }
    }

    /// A receive ring and the DMA that writes it, from its start.
    fn ring() -> (&'static mut RxRing, Dma) {
        let ring: &'static mut RxRing = Box::leak(Box::new([0u8; RX_BYTES]));
        let dma = Dma {
            ring: ring.as_mut_ptr(),
            at: 0,
        };
        (ring, dma)
    }

    /// A store over two erased slots in RAM.
    fn store() -> Store<RamFlash<'static>> {
        let mem: &'static mut [u8] = Box::leak(vec![0xff; 2 * SLOT_BYTES as usize].into_boxed_slice());
        Store::new(RamFlash::new(mem), 0, SLOT_BYTES).unwrap()
    }

    /// A start frame for the writer.
    fn start() -> link::Start {
        link::Start {
            version: link::VERSION,
            firmware: link::Start::firmware_field("test"),
            settings_digest: 0,
            calibration_digest: 0,
            sensors: 8,
            sample_rate_hz: 200_000,
            generation: 0,
            device_id: 0,
            self_test: link::SelfTest::default(),
        }
    }

    /// The replies the writer queued (its start frame left out).
    fn replies<const N: usize>(queue: &LinkQueue<N>) -> Vec<(u32, Reply)> {
        let c = queue.stream_consumer();
        let mut bytes = Vec::new();
        while let Ok(g) = c.read() {
            bytes.extend_from_slice(&g);
            let n = g.len();
            g.release(n);
        }
        let mut d = link::Decoder::new();
        bytes
            .iter()
            .filter_map(|&b| d.push(b))
            .filter_map(|f| match f.unwrap() {
                Frame {
                    seq,
                    body: Body::Reply(r),
                } => Some((seq, r)),
                _ => None,
            })
            .collect()
    }

    /// A request split between two reads of the ring, and one that runs
    /// over the ring's end, are each answered once, in order; a request
    /// the store cannot serve is refused, not dropped; a set written in
    /// pieces and committed is stored and read back.
    #[test]
    fn requests_from_the_ring_are_answered_in_order() {
        let (ring, mut dma) = ring();
        let mut requests = Requests::new(ring, Commands::new(), store());
        let queue: &'static LinkQueue<4096> = Box::leak(Box::new(LinkQueue::new()));
        let mut writer = FrameWriter::start(queue, start());
        let mut answer =
            |dma: &Dma, w: &mut FrameWriter<'_, 4096>| requests.answer(dma.remaining(), w, || {});

        // Nothing yet; then half a request: still nothing.
        assert_eq!(answer(&dma, &mut writer), None);
        let stop = frame(1, Request::Stop);
        let (a, b) = stop.split_at(stop.len() / 2);
        dma.write(a);
        assert_eq!(answer(&dma, &mut writer), None);
        dma.write(b);
        assert_eq!(answer(&dma, &mut writer), Some(Action::Stop));
        // Nothing stored yet: refused.
        dma.write(&frame(2, Request::ReadSettings));
        assert_eq!(answer(&dma, &mut writer), Some(Action::None));

        // A set in pieces, the last ones running over the ring's end.
        let set = instrument::stored::Stored::uncalibrated();
        let mut buf = [0u8; instrument::stored::MAX_BYTES];
        let bytes: Vec<u8> = set.to_bytes(&mut buf).unwrap().to_vec();
        let n = bytes.len();
        let mut seq = 3;
        let mut actions = Vec::new();
        for (k, piece) in bytes.chunks(link::CHUNK).enumerate() {
            let mut chunk = link::Chunk {
                offset: (k * link::CHUNK) as u16,
                len: piece.len() as u8,
                bytes: [0; link::CHUNK],
            };
            chunk.bytes[..piece.len()].copy_from_slice(piece);
            dma.write(&frame(seq, Request::WriteChunk(chunk)));
            actions.push(answer(&dma, &mut writer));
            seq += 1;
        }
        // (The set's frames are many times the ring's length.)
        assert!(n > 2 * RX_BYTES, "{n} bytes");
        let crc = instrument::commands::crc(&bytes);
        dma.write(&frame(seq, Request::Commit { len: n as u16, crc }));
        actions.push(answer(&dma, &mut writer));
        assert!(
            actions[..actions.len() - 1]
                .iter()
                .all(|a| *a == Some(Action::None)),
            "{actions:?}"
        );
        assert_eq!(actions.last(), Some(&Some(Action::Apply)));
        dma.write(&frame(seq + 1, Request::Start));
        assert_eq!(answer(&dma, &mut writer), Some(Action::Start));

        let replies = replies(queue);
        let to: Vec<u32> = replies
            .iter()
            .map(|(_, r)| match r {
                Reply::Ack { to, .. } | Reply::Refused { to, .. } => *to,
                _ => u32::MAX,
            })
            .collect();
        let expected: Vec<u32> = (1..=seq + 1).collect();
        assert_eq!(to, expected, "{replies:?}");
        assert!(
            matches!(
                replies[1].1,
                Reply::Refused {
                    reason: link::Reason::NothingStored,
                    ..
                }
            ),
            "{replies:?}"
        );
        assert!(
            matches!(replies[replies.len() - 2].1, Reply::Ack { generation: g, .. } if g > 0),
            "{replies:?}"
        );
    }

    /// A stored set read back through the board's 512-byte queue: its
    /// pieces are several queues' worth, and each waits for the
    /// transmitter (here a kick drains a frame's worth) instead of being
    /// dropped. With no kick that drains, the reply is lost after
    /// [`KICKS`] tries, not waited for forever.
    #[test]
    fn a_read_longer_than_the_queue_waits_for_the_link() {
        let (ring, mut dma) = ring();
        let mut store = store();
        let set = instrument::stored::Stored::uncalibrated();
        assert_eq!(store.save(&set), Ok(1));
        let mut requests = Requests::new(ring, Commands::new(), store);
        let queue: &'static LinkQueue<512> = Box::leak(Box::new(LinkQueue::new()));
        let mut writer = FrameWriter::start(queue, start());
        let consumer = queue.stream_consumer();
        let mut sent = Vec::new();
        let mut kicks = 0;
        dma.write(&frame(1, Request::ReadSettings));
        let action = requests.answer(dma.remaining(), &mut writer, || {
            // The transmitter: a frame's worth of bytes leaves.
            kicks += 1;
            if let Ok(g) = consumer.read() {
                let n = g.len().min(link::MAX_FRAME);
                sent.extend_from_slice(&g[..n]);
                g.release(n);
            }
        });
        assert_eq!(action, Some(Action::None));
        while let Ok(g) = consumer.read() {
            sent.extend_from_slice(&g);
            let n = g.len();
            g.release(n);
        }
        let mut d = link::Decoder::new();
        let mut bytes = Vec::new();
        let mut acked = false;
        for f in sent.iter().filter_map(|&b| d.push(b)) {
            match f.unwrap().body {
                Body::Reply(Reply::Chunk { chunk, .. }) => {
                    assert_eq!(usize::from(chunk.offset), bytes.len(), "a piece lost");
                    bytes.extend_from_slice(chunk.data());
                }
                Body::Reply(Reply::Ack { generation, .. }) => acked = generation == 1,
                _ => {}
            }
        }
        assert!(acked && kicks > 0, "kicks {kicks}");
        assert!(bytes.len() > 512, "{} bytes", bytes.len());
        assert_eq!(instrument::stored::Stored::from_bytes(&bytes), Some(Ok(set)));

        // A link that never drains: the reply is given up, not waited for.
        let mut kicks = 0u32;
        dma.write(&frame(2, Request::ReadSettings));
        let action = requests.answer(dma.remaining(), &mut writer, || kicks += 1);
        assert_eq!(action, Some(Action::None));
        assert_eq!(kicks, KICKS, "one wait in vain, then none");
    }
}
