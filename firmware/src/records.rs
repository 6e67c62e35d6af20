//! The array's record queue between acquisition and logger: a `heapless`
//! SPSC queue of four blocks' records. The acquisition's end never waits:
//! a record that finds the queue full is dropped and counted, and the
//! firmware reports the count (`drops n`).

use heapless::spsc::Producer;
use instrument::tones::ToneRecord;

/// The queue's size (it holds one fewer: four blocks of 16 records).
pub const QUEUE: usize = 65;

/// The acquisition's end of the record queue.
pub struct RecordSink<'a> {
    producer: Producer<'a, ToneRecord, QUEUE>,
    drops: u32,
}

impl<'a> RecordSink<'a> {
    /// The producer's end of a split queue.
    pub fn new(producer: Producer<'a, ToneRecord, QUEUE>) -> Self {
        Self { producer, drops: 0 }
    }

    /// Queue `rec`, or count it dropped if the queue is full.
    pub fn push(&mut self, rec: ToneRecord) {
        if self.producer.enqueue(rec).is_err() {
            self.drops = self.drops.saturating_add(1);
        }
    }

    /// Queue a block's records, each flagged
    /// [`LATE`](instrument::faults::Flags::LATE) if the block was late.
    pub fn push_block(&mut self, recs: &[ToneRecord], late: bool) {
        for &rec in recs {
            let mut rec = rec;
            if late {
                rec.flags.set(instrument::faults::Flags::LATE);
            }
            self.push(rec);
        }
    }

    /// Records dropped since start.
    pub fn drops(&self) -> u32 {
        self.drops
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heapless::spsc::Queue;
    use std::vec::Vec;

    #[test]
    fn a_full_queue_drops_and_counts() {
        let mut q: Queue<ToneRecord, QUEUE> = Queue::new();
        let (p, mut c) = q.split();
        let mut sink = RecordSink::new(p);
        for k in 0..QUEUE as u8 + 2 {
            sink.push(ToneRecord {
                sensor: k,
                ..ToneRecord::default()
            });
        }
        assert_eq!(sink.drops(), 3, "64 held, 3 dropped");
        assert_eq!(c.dequeue().map(|r| r.sensor), Some(0), "oldest first");
        sink.push(ToneRecord::default());
        assert_eq!(sink.drops(), 3, "room again");
    }

    #[test]
    fn a_late_blocks_records_are_flagged_late() {
        use instrument::faults::Flags;
        let mut q: Queue<ToneRecord, QUEUE> = Queue::new();
        let (p, mut c) = q.split();
        let mut sink = RecordSink::new(p);
        let recs = [ToneRecord::default(); 2];
        sink.push_block(&recs, false);
        sink.push_block(&recs, true);
        let flags: Vec<bool> = core::iter::from_fn(|| c.dequeue())
            .map(|r| r.flags.has(Flags::LATE) && !r.flags.valid())
            .collect();
        assert_eq!(flags, [false, false, true, true]);
    }
}
