//! The record link's port: DMA2 channel 1 moves the link's queued frames
//! ([`crate::link_out`]) into LPUART1's data register
//! ([`super::lpuart`]), one contiguous chunk at a time; DMA2 channel 2
//! moves what LPUART1 receives (the host's requests) round a ring
//! ([`RxRing`]), read by position ([`Receiver`]).
//!
//! DMA2 is the link's alone (DMA1 paces the measurement), so the
//! transmitter owns it outright. Its task runs on the channel's
//! transfer-complete interrupt, and the writer pends that interrupt after
//! queueing a frame: [`Transmitter::service`] releases the chunk that was
//! sent, if one was, and starts the next, if the channel is idle.

use super::pac::{self, dma1, dmamux};
use crate::link_out::LinkConsumer;

/// DMAMUX request of LPUART1_TX (RM0440 table 91).
pub const REQ_LPUART1_TX: u8 = 35;

/// The DMAMUX channel of DMA2 channel 1 (DMAMUX channels 8–15 serve DMA2).
pub const MUX_CHANNEL: usize = 8;

/// DMAMUX request of LPUART1_RX (RM0440 table 91).
pub const REQ_LPUART1_RX: u8 = 34;

/// The DMAMUX channel of DMA2 channel 2.
pub const RX_MUX_CHANNEL: usize = 9;

/// The receive ring, bytes: four of the longest request (the host sends
/// one and waits for its reply).
pub const RX_BYTES: usize = 256;

/// The receive ring's storage.
pub type RxRing = [u8; RX_BYTES];

/// The most bytes one transfer moves (CNDTR is 16 bits).
const MAX_CHUNK: usize = u16::MAX as usize;

/// DMAMUX channel 8 (DMA2 channel 1) ← LPUART1_TX, channel 9 (DMA2
/// channel 2) ← LPUART1_RX.
#[allow(unsafe_code)]
pub fn request(mux: &dmamux::RegisterBlock) {
    // SAFETY: request lines of the G474's DMAMUX (1..=115).
    mux.ccr(MUX_CHANNEL)
        .write(|w| unsafe { w.dmareq_id().bits(REQ_LPUART1_TX) });
    mux.ccr(RX_MUX_CHANNEL)
        .write(|w| unsafe { w.dmareq_id().bits(REQ_LPUART1_RX) });
}

/// Channel 2: from the receive data register `from` round the ring at
/// `to`, bytes, circular, no interrupts (the ring is read by position).
pub fn receive(dma: &dma1::RegisterBlock, from: u32, to: u32) {
    let ch = dma.ch(1);
    // LPUART1's RDR, and a 'static ring of RX_BYTES.
    super::dma::addresses(ch, from, to, RX_BYTES as u16);
    ch.cr().write(|w| {
        w.dir()
            .from_peripheral()
            .psize()
            .bits8()
            .msize()
            .bits8()
            .minc()
            .set_bit()
            .circ()
            .set_bit()
            .en()
            .set_bit()
    });
}

/// Where the host's bytes have been read up to in the ring.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Receiver {
    read: usize,
}

impl Receiver {
    /// Nothing read yet.
    pub const fn new() -> Self {
        Self { read: 0 }
    }

    /// The bytes the DMA has written since the last call, in order, given
    /// its remaining count (channel 2's CNDTR) and a way to read a byte of
    /// the ring (a volatile read on the device).
    pub fn take(&mut self, remaining: u16, byte: impl Fn(usize) -> u8, mut f: impl FnMut(u8)) {
        let write = (RX_BYTES - usize::from(remaining).min(RX_BYTES)) % RX_BYTES;
        while self.read != write {
            f(byte(self.read));
            self.read = (self.read + 1) % RX_BYTES;
        }
    }
}

/// DMA2's clock.
pub fn clocks(rcc: &pac::rcc::RegisterBlock) {
    rcc.ahb1enr().modify(|_, w| w.dma2en().set_bit());
}

/// Channel 1: `bytes` bytes from `from` to the data register `to`, once,
/// with transfer-complete and transfer-error interrupts. The channel is
/// disabled first: its count and addresses can only be written then.
pub fn transfer(dma: &dma1::RegisterBlock, from: u32, to: u32, bytes: u16) {
    let ch = dma.ch(0);
    ch.cr().write(|w| w.en().clear_bit());
    // LPUART1's TDR, and bytes that stay put until the transfer completes
    // (the queue's, not yet released).
    super::dma::addresses(ch, to, from, bytes);
    ch.cr().write(|w| {
        w.dir()
            .from_memory()
            .psize()
            .bits8()
            .msize()
            .bits8()
            .minc()
            .set_bit()
            .tcie()
            .set_bit()
            .teie()
            .set_bit()
            .en()
            .set_bit()
    });
}

/// What channel 1's flags say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// A transfer is under way.
    Busy,
    /// The last transfer completed (or none was started).
    Done,
    /// The last transfer stopped on a bus error.
    Error,
}

/// Read and clear channel 1's flags; `sending`: a transfer was started.
#[allow(unsafe_code)]
pub fn take_state(dma: &dma1::RegisterBlock, sending: bool) -> State {
    let isr = dma.isr().read().bits();
    let (tcif, teif) = (isr & 0b10 != 0, isr & 0b1000 != 0);
    if tcif || teif {
        // SAFETY: CGIF1 is bit 0 of the write-only IFCR.
        dma.ifcr().write(|w| unsafe { w.bits(1) });
    }
    match (sending, teif, tcif) {
        (false, _, _) => State::Done,
        (true, true, _) => State::Error,
        (true, false, true) => State::Done,
        (true, false, false) => State::Busy,
    }
}

/// The transmitter: DMA2, the queue's consumer, and the chunk under way.
pub struct Transmitter<'a, const N: usize> {
    dma: pac::DMA2,
    consumer: LinkConsumer<'a, N>,
    tdr: u32,
    sending: usize,
    errors: u32,
}

impl<'a, const N: usize> Transmitter<'a, N> {
    /// The transmitter into LPUART1's data register at `tdr`.
    pub fn new(dma: pac::DMA2, consumer: LinkConsumer<'a, N>, tdr: u32) -> Self {
        Self {
            dma,
            consumer,
            tdr,
            sending: 0,
            errors: 0,
        }
    }

    /// On the channel's interrupt, or pended by the writer: release what
    /// was sent, start the next chunk if the channel is idle.
    pub fn service(&mut self) {
        match take_state(&self.dma, self.sending > 0) {
            State::Busy => return,
            State::Done => {}
            // The chunk's bytes are gone, some of them perhaps garbled:
            // the host's CRC finds the frames they cut.
            State::Error => self.errors = self.errors.saturating_add(1),
        }
        if self.sending > 0 {
            if let Ok(grant) = self.consumer.read() {
                grant.release(self.sending);
            }
            self.sending = 0;
        }
        if let Ok(grant) = self.consumer.read() {
            let len = grant.len().min(MAX_CHUNK);
            transfer(&self.dma, grant.as_ptr() as u32, self.tdr, len as u16);
            self.sending = len;
            // Dropped without a release: the bytes stay the consumer's
            // until the transfer completes.
            drop(grant);
        }
    }

    /// Transfers that stopped on a bus error since the start.
    pub fn errors(&self) -> u32 {
        self.errors
    }

    /// The receive channel's remaining count (for [`Receiver::take`]).
    pub fn rx_remaining(&self) -> u16 {
        self.dma.ch(1).ndtr().read().ndt().bits()
    }
}
