//! The record link's sending end on the board: frames numbered and
//! encoded ([`link::Encoder`]) into a byte queue that a DMA channel
//! drains (`board::link`).
//!
//! The queue is bbqueue's BipBuffer: every chunk the DMA is given is
//! contiguous, and the bytes it is sending stay the consumer's until the
//! transfer completes and they are released. The measuring side never
//! waits: a frame that finds no room is dropped and counted here, and its
//! sequence number is spent, so the host counts it lost too.

use bbqueue::nicknames::Churrasco;
use bbqueue::prod_cons::stream::{StreamConsumer, StreamProducer};

/// The byte queue between the frame writer and the DMA: `N` bytes.
pub type LinkQueue<const N: usize> = Churrasco<N>;

/// The DMA's end of a [`LinkQueue`].
pub type LinkConsumer<'a, const N: usize> = StreamConsumer<&'a LinkQueue<N>>;

/// The writing end: numbers, encodes and queues frames.
pub struct FrameWriter<'a, const N: usize> {
    producer: StreamProducer<&'a LinkQueue<N>>,
    encoder: link::Encoder,
    records: u32,
    dropped: u32,
    last_t_us: u64,
}

impl<'a, const N: usize> FrameWriter<'a, N> {
    /// The writer on `queue` (the consumer is [`LinkQueue::stream_consumer`]
    /// of the same queue), its start frame queued.
    pub fn start(queue: &'a LinkQueue<N>, start: link::Start) -> Self {
        let mut w = Self::new(queue);
        w.send_start(&start);
        w
    }

    /// The writer on `queue`, nothing queued yet: the start frame is
    /// [`FrameWriter::send_start`]'s, first (the array's, after its
    /// self-test).
    pub fn new(queue: &'a LinkQueue<N>) -> Self {
        Self {
            producer: queue.stream_producer(),
            encoder: link::Encoder::new(),
            records: 0,
            dropped: 0,
            last_t_us: 0,
        }
    }

    /// Queue the stream's start frame; false if there was no room.
    pub fn send_start(&mut self, start: &link::Start) -> bool {
        self.queue(|e, out| e.start(start, out))
    }

    /// Number, encode (with `encode`, one of [`link::Encoder`]'s
    /// per-body encoders: the image holds only the serialisers it uses)
    /// and queue one frame; false if it was dropped (no room, or it could
    /// not be encoded). Either way its sequence number is spent.
    fn queue(
        &mut self,
        encode: impl for<'b> FnOnce(&mut link::Encoder, &'b mut [u8]) -> Result<&'b [u8], link::Error>,
    ) -> bool {
        let mut out = [0u8; link::MAX_FRAME];
        let Ok(bytes) = encode(&mut self.encoder, &mut out) else {
            return false;
        };
        match self.producer.grant_exact(bytes.len()) {
            Ok(mut grant) => {
                grant.copy_from_slice(bytes);
                grant.commit(bytes.len());
                true
            }
            Err(_) => false,
        }
    }

    /// Room for the longest frame now (its number not spent).
    pub fn has_room(&mut self) -> bool {
        // A grant dropped uncommitted gives its bytes back.
        self.producer.grant_exact(link::MAX_FRAME).is_ok()
    }

    /// Queue one record; false (and counted) if there was no room. With
    /// the per-block code in CCM SRAM (`hot-ram.x`).
    #[allow(unsafe_code)]
    #[cfg_attr(target_os = "none", link_section = ".hot_ram")]
    #[inline(never)]
    pub fn record(&mut self, rec: link::Record) -> bool {
        let sent = self.queue(|e, out| e.record(&rec, out));
        self.last_t_us = rec.t_us;
        match sent {
            true => self.records = self.records.wrapping_add(1),
            false => self.dropped = self.dropped.saturating_add(1),
        }
        sent
    }

    /// Queue a status (how the CPU keeps up); false if there was no room
    /// (the next one counts on from it: nothing is lost but a report).
    pub fn status(&mut self, status: &link::Status) -> bool {
        self.queue(|e, out| e.status(status, out))
    }

    /// Queue the frame of a set applied, waiting for room (each time
    /// round calling `kick`, which pends the transmitter, at most `tries`
    /// times): the host cannot ask for it again, and without it would take
    /// the records after it for the old set's. False if it was dropped.
    pub fn applied(&mut self, applied: &link::Applied, mut kick: impl FnMut(), tries: u32) -> bool {
        let mut n = 0;
        while n < tries && !self.has_room() {
            kick();
            n += 1;
        }
        self.queue(|e, out| e.applied(applied, out))
    }

    /// Queue a reply to a request; false if there was no room (the host
    /// asks again after its timeout).
    pub fn reply(&mut self, reply: link::Reply) -> bool {
        self.queue(|e, out| e.reply(&reply, out))
    }

    /// Queue the end frame: `upstream` records were dropped before they
    /// reached the writer (a full record queue), besides its own.
    pub fn end(&mut self, upstream: u32) -> bool {
        let end = link::End {
            records: self.records,
            dropped: self.dropped.saturating_add(upstream),
        };
        self.queue(|e, out| e.end(&end, out))
    }

    /// The time of the last record given to the writer (queued or
    /// dropped), µs; 0 before the first.
    pub fn last_t_us(&self) -> u64 {
        self.last_t_us
    }

    /// Records queued since the start.
    pub fn records(&self) -> u32 {
        self.records
    }

    /// Records dropped for want of room since the start.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn start() -> link::Start {
        link::Start {
            version: link::VERSION,
            firmware: link::Start::firmware_field("test"),
            settings_digest: 1,
            calibration_digest: 2,
            sensors: 16,
            sample_rate_hz: 25_000,
            generation: 0,
            device_id: 0,
            self_test: link::SelfTest::default(),
        }
    }

    fn rec(k: u32) -> link::Record {
        link::Record {
            t_us: u64::from(k) * 4000,
            sensor: (k % 16) as u8,
            c_farad: 200e-12 + k as f32 * 1e-15,
            ..link::Record::default()
        }
    }

    /// Drain what the consumer can read, as a DMA would: chunk by chunk.
    fn drain<const N: usize>(c: &LinkConsumer<'_, N>, out: &mut Vec<u8>) {
        while let Ok(g) = c.read() {
            out.extend_from_slice(&g);
            let n = g.len();
            g.release(n);
        }
    }

    fn decode(bytes: &[u8]) -> (Vec<link::Frame>, link::Stats) {
        let mut d = link::Decoder::new();
        let frames = bytes
            .iter()
            .filter_map(|&b| d.push(b))
            .map(|f| f.unwrap())
            .collect();
        (frames, d.stats())
    }

    #[test]
    fn frames_drained_in_chunks_decode_whole_and_in_order() {
        let q: LinkQueue<512> = LinkQueue::new();
        let c = q.stream_consumer();
        let mut w = FrameWriter::start(&q, start());
        let mut wire = Vec::new();
        for k in 0..200 {
            assert!(w.record(rec(k)), "record {k}");
            // The DMA keeps up, in chunks that wrap round the buffer.
            if k % 3 == 2 {
                drain(&c, &mut wire);
            }
        }
        assert!(w.end(5));
        drain(&c, &mut wire);
        let (frames, stats) = decode(&wire);
        assert_eq!(frames.len(), 202);
        assert_eq!(stats.lost + stats.bad, 0);
        assert_eq!(frames[0].body, link::Body::Start(start()));
        for (k, f) in frames[1..201].iter().enumerate() {
            assert_eq!(f.body, link::Body::Record(rec(k as u32)), "{k}");
        }
        assert_eq!(
            frames[201].body,
            link::Body::End(link::End {
                records: 200,
                dropped: 5
            })
        );
    }

    #[test]
    fn a_full_queue_drops_whole_frames_and_the_host_counts_them_lost() {
        let q: LinkQueue<256> = LinkQueue::new();
        let c = q.stream_consumer();
        let mut w = FrameWriter::start(&q, start());
        // Nothing drained: the queue fills, then every record is dropped.
        let sent: Vec<bool> = (0..10).map(|k| w.record(rec(k))).collect();
        let kept = sent.iter().filter(|&&s| s).count() as u32;
        assert!((2..10).contains(&kept), "{sent:?}");
        assert!(
            sent.windows(2).all(|p| p[0] || !p[1]),
            "once full, full: {sent:?}"
        );
        assert_eq!((w.records(), w.dropped()), (kept, 10 - kept));
        // Room again: the link goes on, and the gap shows on the host.
        let mut wire = Vec::new();
        drain(&c, &mut wire);
        assert!(w.record(rec(10)));
        assert!(w.end(0));
        drain(&c, &mut wire);
        let (frames, stats) = decode(&wire);
        assert_eq!(stats.bad, 0, "no frame is cut");
        assert_eq!(stats.lost, u64::from(10 - kept));
        assert_eq!(frames.len() as u32, 1 + kept + 2);
        assert_eq!(
            frames.last().unwrap().body,
            link::Body::End(link::End {
                records: kept + 1,
                dropped: 10 - kept
            })
        );
    }
}
