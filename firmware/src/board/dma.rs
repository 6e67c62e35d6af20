//! DMA1: channel 1 moves the packed ADC pairs into a circular buffer of
//! two slots; channel 2 feeds the DAC from a ring of two quarter slots.
//! Channel 1's half- and full-transfer interrupts pace the firmware;
//! channel 2's refill the ring.

use super::pac::{dma1, dmamux};

/// DMAMUX request of ADC1 (RM0440 table 91).
pub const REQ_ADC1: u8 = 5;
/// DMAMUX request of DAC1 channel 1.
pub const REQ_DAC1_CH1: u8 = 6;

/// DMAMUX channel 0 (DMA1 channel 1) ← ADC1, channel 1 (DMA1 channel 2)
/// ← DAC1 channel 1.
#[allow(unsafe_code)]
pub fn requests(mux: &dmamux::RegisterBlock) {
    // SAFETY: both are request lines of the G474's DMAMUX (1..=115); the
    // PAC gives the field no range.
    mux.ccr(0).write(|w| unsafe { w.dmareq_id().bits(REQ_ADC1) });
    mux.ccr(1).write(|w| unsafe { w.dmareq_id().bits(REQ_DAC1_CH1) });
}

/// A channel's peripheral and memory addresses and its transfer count
/// (DMA1's here, DMA2's for the link).
#[allow(unsafe_code)]
pub(super) fn addresses(ch: &dma1::CH, peripheral: u32, memory: u32, count: u16) {
    // SAFETY: any address is a valid value of these registers; the callers
    // give a data register and a 'static buffer.
    ch.par().write(|w| unsafe { w.pa().bits(peripheral) });
    ch.mar().write(|w| unsafe { w.ma().bits(memory) });
    ch.ndtr().write(|w| w.ndt().set(count));
}

/// The rest of a circular channel's CCR: memory increment, circular,
/// half-transfer, transfer-complete and transfer-error interrupts if
/// `interrupts`, enabled.
fn circular(w: &mut dma1::ch::cr::W, interrupts: bool) -> &mut dma1::ch::cr::W {
    w.minc()
        .set_bit()
        .circ()
        .set_bit()
        .htie()
        .bit(interrupts)
        .tcie()
        .bit(interrupts)
        .teie()
        .bit(interrupts)
        .en()
        .set_bit()
}

/// Channel 1: `words` 32-bit words from the ADC common data register
/// `from` to `to`, circular, with half-transfer, transfer-complete and
/// transfer-error interrupts.
pub fn adc_channel(dma: &dma1::RegisterBlock, from: u32, to: u32, words: u16) {
    let ch = dma.ch(0);
    addresses(ch, from, to, words);
    ch.cr().write(|w| {
        let w = w.dir().from_peripheral().psize().bits32().msize().bits32();
        circular(w, true)
    });
}

/// DMA1 channel 2 (0-based), which feeds the multiplexed board's DAC.
pub const DAC_CHANNEL: usize = 1;

/// Channel 2: `codes` 16-bit DAC codes from the ring `from` to the DAC's
/// 12-bit right-aligned holding register `to`, circular; the peripheral
/// side is written as 32-bit words (a 16-bit write to a DAC register is
/// not supported, RM0440 22.7). Half-transfer, transfer-complete and
/// transfer-error interrupts: the half just played is refilled
/// ([`super::excitation::Feed`]).
pub fn dac_channel(dma: &dma1::RegisterBlock, from: u32, to: u32, codes: u16) {
    to_dac(dma.ch(DAC_CHANNEL), from, to, codes, true);
}

/// A channel from memory to a DAC's holding register, circular; with
/// half-transfer, transfer-complete and transfer-error interrupts if
/// `interrupts`.
fn to_dac(ch: &dma1::CH, from: u32, to: u32, codes: u16, interrupts: bool) {
    addresses(ch, to, from, codes);
    ch.cr().write(|w| {
        let w = w.dir().from_memory().psize().bits32().msize().bits16();
        circular(w, interrupts)
    });
}

/// DMAMUX request of the array: DMA1 channels 1–5 ← the five scanning
/// ADCs in frame order, channel 6 ← DAC1 channel 1.
#[allow(unsafe_code)]
pub fn array_requests(mux: &dmamux::RegisterBlock) {
    for (c, adc) in super::scan::SCAN_ADCS.iter().enumerate() {
        // SAFETY: request lines of the G474's DMAMUX (1..=115).
        mux.ccr(c)
            .write(|w| unsafe { w.dmareq_id().bits(adc.dma_request()) });
    }
    mux.ccr(ARRAY_DAC_CHANNEL)
        .write(|w| unsafe { w.dmareq_id().bits(REQ_DAC1_CH1) });
}

/// The array's DAC channel (0-based: DMA1 channel 6).
pub const ARRAY_DAC_CHANNEL: usize = 5;

/// The array's ADC channel `c` (0-based, frame ADC c): `results` 16-bit
/// results from the ADC's data register `from` to `to`, circular; with
/// half-transfer, transfer-complete and transfer-error interrupts if
/// `interrupts`.
pub fn scan_channel(dma: &dma1::RegisterBlock, c: usize, from: u32, to: u32, results: u16, interrupts: bool) {
    let ch = dma.ch(c);
    addresses(ch, from, to, results);
    ch.cr().write(|w| {
        let w = w.dir().from_peripheral().psize().bits16().msize().bits16();
        circular(w, interrupts)
    });
}

/// The array's DAC channel: the table of `codes` 16-bit codes at `from`
/// to the DAC's holding register `to`, circular, as [`dac_channel`] does
/// for the single-tone board.
pub fn table_channel(dma: &dma1::RegisterBlock, from: u32, to: u32, codes: u16) {
    to_dac(dma.ch(ARRAY_DAC_CHANNEL), from, to, codes, false);
}

/// What channel 1's interrupt found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// The first half (slot) is complete.
    FirstHalf,
    /// The second half is complete.
    SecondHalf,
    /// Both halves completed since the last interrupt was served: a slot
    /// was lost (the interrupt came too late).
    Overrun,
    /// A transfer error: the channel stopped.
    Error,
    /// No event (a spurious interrupt).
    None,
}

impl Event {
    /// From channel 1's flags: transfer error, half transfer, transfer
    /// complete.
    pub fn from_flags(teif: bool, htif: bool, tcif: bool) -> Self {
        match (teif, htif, tcif) {
            (true, _, _) => Event::Error,
            (false, true, true) => Event::Overrun,
            (false, true, false) => Event::FirstHalf,
            (false, false, true) => Event::SecondHalf,
            (false, false, false) => Event::None,
        }
    }

    /// The DMA half that completed, if one did unambiguously.
    pub fn half(self) -> Option<usize> {
        match self {
            Event::FirstHalf => Some(0),
            Event::SecondHalf => Some(1),
            _ => None,
        }
    }
}

/// What an interrupt of a circular buffer of two halves means for the
/// application, given the half it expects next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Completion {
    /// Half `half` holds a complete slot or block. `lost`: the expected
    /// half was overwritten before its interrupt was served (the interrupt
    /// came a slot late); the application skips one slot in its sequence.
    Done {
        /// The half that is complete and not being written (0 or 1).
        half: usize,
        /// The expected half was lost.
        lost: bool,
    },
    /// A transfer error: the channel stopped.
    Error,
    /// Nothing completed (a spurious interrupt).
    Nothing,
}

impl Event {
    /// The event for an application that expects half `expected` (0 or 1)
    /// to complete next.
    pub fn completion(self, expected: usize) -> Completion {
        match self {
            Event::Error => Completion::Error,
            Event::None => Completion::Nothing,
            // Both halves done: the DMA is overwriting the expected one,
            // and the other is the one complete now.
            Event::Overrun => Completion::Done {
                half: 1 - expected,
                lost: true,
            },
            Event::FirstHalf => Completion::Done {
                half: 0,
                lost: expected != 0,
            },
            Event::SecondHalf => Completion::Done {
                half: 1,
                lost: expected != 1,
            },
        }
    }
}

/// Read and clear channel 1's flags.
pub fn take_event(dma: &dma1::RegisterBlock) -> Event {
    take_event_of(dma, 0)
}

/// Read and clear channel `c`'s flags (0-based: four bits each in ISR,
/// GIF, TCIF, HTIF, TEIF; writing CGIF clears them all).
#[allow(unsafe_code)]
pub fn take_event_of(dma: &dma1::RegisterBlock, c: usize) -> Event {
    let flags = dma.isr().read().bits() >> (4 * c);
    // SAFETY: CGIFc is bit 4c of the write-only IFCR (c < 8).
    dma.ifcr().write(|w| unsafe { w.bits(1 << (4 * c)) });
    Event::from_flags(flags & 0b1000 != 0, flags & 0b100 != 0, flags & 0b10 != 0)
}
