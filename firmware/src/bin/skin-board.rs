//! The multiplexed sensing skin on the STM32G474 (Nucleo-G474RE): eight
//! sensors read one at a time, each at the frequency its policy picks,
//! through an auto-ranging transimpedance stage (`docs/firmware.md`).
//!
//! Analog front end it expects (`instrument::design`):
//! * PA4 (DAC1_OUT1): excitation, 1 V amplitude around 1.65 V, through a
//!   buffer to the selected sensor's top tab;
//! * PA0 (ADC1_IN1): the excitation as applied (voltage channel);
//! * PA1 (ADC2_IN2): the inverting transimpedance stage on the bottom tab,
//!   biased at 1.65 V (current channel), its feedback one of
//!   `design::TIA_RANGES_OHM` through a 4:1 switch;
//! * PB0, PB1, PB2: address lines A0..A2 of an 8-channel analog
//!   multiplexer (ADG708 or similar) on both tabs; PB5, PB6 the range
//!   switch's.
//!
//! * `init`: `board::setup` begins (reset cause, watchdog, clocks), the
//!   DAC ring's first two quarter slots (`board::excitation`),
//!   `board::front_end::multiplexed`, `board::setup` ends, handing DMA1
//!   and the IWDG to the tasks, the settings are read, and the sample
//!   clock (TIM6) starts last.
//! * `dma_done` (DMA1 channel 1's half and full transfer): the
//!   completion (`board::dma::Completion`), the sequencer's step (which
//!   slot completed, which channel and range to select, which frequency
//!   the slot after next plays), then `process`.
//! * `dac_refill` (DMA1 channel 2's half and full transfer): the quarter
//!   slot after next written into the half of the DAC's ring just played.
//! * `process`: the finished half demodulated in place, the channel's
//!   record queued on the record link ([`firmware::link_out`]), the
//!   watchdog fed.
//! * `link_tx` (DMA2 channel 1): the link's frames through LPUART1, the
//!   ST-LINK's virtual COM port ([`firmware::board::link`]). defmt over
//!   RTT carries log messages only, and never blocks.
//! * `idle`: with the settings store, the host's requests, which come
//!   back on the same port (DMA2 channel 2 round a ring), answered
//!   ([`firmware::board::requests`]): read and write the stored settings,
//!   start, stop.
//!
//! Settings: built as `cargo build-board-plain`, this image keeps none:
//! every sensor is read with the line model alone (no tab leads, no
//! wiring) and its stretch is marked not calibrated
//! (`Flags::UNCALIBRATED`). Built as `cargo build-board` (the `store`
//! feature), it measures with
//! the set stored in the last 8 KiB of flash at start, as
//! `skin-array-board` does: each sensor's tab leads, wiring and stretch
//! table; a set that comes down the link is in force from the next
//! start. Both keep to 64 KiB of flash and 16 KiB of RAM
//! (`docs/benchmarks.md`).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m::peripheral::DWT;
use firmware::board::dma::{self, Completion, DAC_CHANNEL};
use firmware::board::excitation::{DacRing, Feed, QUARTER};
use firmware::board::front_end::{self, AdcSlots, SLOTS};
use firmware::board::link::Transmitter;
use firmware::board::pins::{self, AnyPin};
use firmware::board::setup::{self, Watchdog};
use firmware::board::{clocks, dac, pac, timer, watchdog};
use firmware::link_out::{FrameWriter, LinkQueue};
use instrument::busy::Busy;
use instrument::calib::POINTS;
use instrument::channel::{Channel, Settings};
use instrument::commands::Action;
use instrument::config::{
    Readings, BLOCK_PAIRS, CHANNELS, MUX_ADDRESS_LINES, RANGE_ADDRESS_LINES, SETTLE_PAIRS, SLOT_PAIRS,
};
use instrument::design;
use instrument::frames;
use instrument::mux::Mux;
use instrument::reader::{MuxReader, Read};
use instrument::sensor::Sensors;
use instrument::sequencer::{Sequencer, Slot, SLOTS_PER_S, SLOT_US};

/// The multiplexer on PB0..PB2.
pub type BoardMux = Mux<AnyPin, MUX_ADDRESS_LINES>;
/// The transimpedance range switch on PB5, PB6.
pub type RangeSwitch = Mux<AnyPin, RANGE_ADDRESS_LINES>;

/// The link's byte queue: eight frames.
const LINK_BYTES: usize = 512;

/// The ADC DMA buffer, seen by the processing task only through the half
/// the DMA has finished.
pub struct DmaBuf(*const u32);

// SAFETY: the pointer is to a 'static buffer; the one task holding it reads
// only the half the DMA has finished (see `process`).
#[allow(unsafe_code)]
unsafe impl Send for DmaBuf {}

use firmware::board::settings::{self, Requests, RING, SENSORS};

#[rtic::app(device = stm32g4::stm32g474, dispatchers = [SPI1])]
mod app {
    use super::*;

    /// A finished slot, the DMA half that holds it, and the cycle
    /// counter at its completion.
    #[derive(Clone, Copy)]
    pub struct Finished {
        pub half: usize,
        pub slot: Slot,
        pub completed: u32,
    }

    #[shared]
    struct Shared {
        slot: Option<Finished>,
        /// DMA1: the acquisition's channel and the excitation's.
        dma: pac::DMA1,
        /// What the DAC plays: the slots' frequencies from `dma_done`,
        /// the ring's refills in `dac_refill`.
        feed: Feed,
        reader: MuxReader,
        /// The link's port: its transmit task, and `idle` for the receive
        /// position.
        tx: Transmitter<'static, LINK_BYTES>,
        /// The link's writer: records from `process`, replies from `idle`.
        writer: FrameWriter<'static, LINK_BYTES>,
        /// Records are sent (until the host asks to stop).
        sending: bool,
        /// How the CPU keeps up: slots' cycles, late and missed ones.
        busy: Busy,
    }

    #[local]
    struct Local {
        dac1: pac::DAC1,
        watchdog: Watchdog,
        adc_buf: DmaBuf,
        dac_ring: &'static mut DacRing,
        mux: BoardMux,
        ranges: RangeSwitch,
        seq: Sequencer,
        settings: Settings<'static, POINTS, SENSORS>,
        requests: Requests,
    }

    #[init(local = [
        adc: AdcSlots = [0; SLOTS * SLOT_PAIRS],
        // Zero, so that it lives in .bss and not as initial values in
        // flash: both halves are written below before the DAC starts.
        dac: DacRing = [0; 2 * QUARTER],
        link_queue: LinkQueue<LINK_BYTES> = LinkQueue::new(),
        sensors: MaybeUninit<Sensors<POINTS, SENSORS>> = MaybeUninit::uninit(),
        rx_ring: [u8; RING] = [0; RING],
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        // The cycle counter, for each slot's time (`busy`).
        let mut core = cx.core;
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        setup::begin(&dp);
        clocks::peripherals(&dp.RCC);
        // Slots 0 and 1 play their channels' start frequencies, which no
        // setting moves (a channel's plan starts at the policy's first
        // frequency and the lowest range), so the front end is set up
        // before the flash, which `setup::finish` hands over, is read; its
        // sample clock starts at the end.
        let (seq, slots) = Sequencer::start(|_| Channel::new(0.0).plan());
        let feed = Feed::start([slots[0].fidx, slots[1].fidx], cx.local.dac);
        let mut mux = Mux::new(pins::mux_pins());
        let Ok(_) = mux.select(slots[0].channel);
        let mut ranges = Mux::new(pins::range_pins());
        let Ok(_) = ranges.select(slots[0].range);
        let adc_buf: &'static mut AdcSlots = cx.local.adc;
        let dac_ring: &'static mut DacRing = cx.local.dac;
        front_end::multiplexed(&dp, adc_buf, dac_ring);
        let owned = setup::finish(dp);
        let Some((settings, generation, requests)) =
            settings::load(owned.flash, cx.local.sensors, cx.local.rx_ring, &owned.link)
        else {
            // Nothing is fed: the watchdog restarts the board in 100 ms.
            defmt::println!("settings: none usable; watchdog reset follows");
            watchdog::await_reset()
        };
        let reader = MuxReader::new(settings.sensors);
        let queue: &'static LinkQueue<LINK_BYTES> = cx.local.link_queue;
        let writer = FrameWriter::start(
            queue,
            frames::start(
                concat!("skin-board ", env!("CARGO_PKG_VERSION")),
                firmware::board::device_id::read(),
                generation,
                &settings,
                &settings.sensors.calibration(),
                CHANNELS,
                design::SAMPLE_RATE,
            ),
        );
        let tx = Transmitter::new(owned.link.dma, queue.stream_consumer(), owned.link.tdr);
        rtic::pend(pac::Interrupt::DMA2_CH1);
        // The sample clock last: the DAC's ring holds 2.7 ms, which
        // reading the settings and building eight sensors' trackers
        // could outlast with the interrupts still masked.
        timer::start(&owned.sample_clock);
        defmt::println!("start {=u8} channels", CHANNELS as u8);
        (
            Shared {
                slot: None,
                dma: owned.dma,
                feed,
                reader,
                tx,
                writer,
                sending: true,
                busy: Busy::new(::link::Clock::Cycles, design::SYSCLK_HZ, SLOT_US, SLOTS_PER_S),
            },
            Local {
                dac1: owned.dac,
                watchdog: owned.watchdog,
                adc_buf: DmaBuf(adc_buf.as_ptr()),
                dac_ring,
                mux,
                ranges,
                seq,
                settings,
                requests,
            },
        )
    }

    /// The host's requests answered (with the settings store), then the
    /// transmitter woken.
    #[idle(shared = [tx, writer, sending], local = [requests])]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            let remaining = cx.shared.tx.lock(|t| t.rx_remaining());
            let requests = &mut *cx.local.requests;
            let action = cx.shared.writer.lock(|w| {
                // A long reply waits for the transmitter, kicked.
                let action = requests.answer(remaining, w, || rtic::pend(pac::Interrupt::DMA2_CH1));
                if let Some(Action::Stop) = action {
                    w.end(0);
                }
                action
            });
            match action {
                Some(Action::Start) => cx.shared.sending.lock(|s| *s = true),
                Some(Action::Stop) => cx.shared.sending.lock(|s| *s = false),
                Some(Action::Apply) => {
                    defmt::println!("settings: a new set stored, in force from the next start")
                }
                Some(Action::Sweep(_) | Action::None) | None => {}
            }
            if action.is_some() {
                rtic::pend(pac::Interrupt::DMA2_CH1);
            }
            cortex_m::asm::wfi();
        }
    }

    /// DMA half/full transfer: slot `k` is complete and slot `k + 1` begins.
    #[task(binds = DMA1_CH1, priority = 2, shared = [slot, reader, dma, feed, busy], local = [dac1, mux, ranges, seq])]
    fn dma_done(mut cx: dma_done::Context) {
        let completed = DWT::cycle_count();
        let stopped = cx
            .shared
            .dma
            .lock(|dma| dac::excitation_stopped(cx.local.dac1, dma, DAC_CHANNEL));
        if stopped || cx.shared.feed.lock(|f| f.stopped()) {
            // The DAC's DMA underran or failed, or its ring lost step:
            // nothing is fed from here on, the watchdog restarts the
            // board within 100 ms.
            defmt::println!(
                "excitation stopped (DAC DMA underrun, error or late refill): watchdog reset follows"
            );
            return;
        }
        let expected = (cx.local.seq.next_index() % 2) as usize;
        let event = cx.shared.dma.lock(|dma| dma::take_event(dma));
        let (half, lost) = match event.completion(expected) {
            Completion::Done { half, lost } => (half, lost),
            Completion::Error => {
                // Nothing is fed from here on: the watchdog restarts the
                // board within 100 ms.
                defmt::println!("dma transfer error: acquisition stopped, watchdog reset follows");
                return;
            }
            Completion::Nothing => return,
        };
        let seq = &mut *cx.local.seq;
        let mut reader = cx.shared.reader;
        let mut complete = || reader.lock(|r| seq.complete(|ch| r.plan(ch)));
        if lost {
            let st = complete();
            cx.shared.feed.lock(|f| f.plan(st.prepare.index, st.prepare.fidx));
            defmt::println!("lost {=u64} {=u8}", st.done.block_mid_us(), st.done.channel);
        }
        let st = complete();
        // The slot that begins now: select its channel (within its settling).
        let Ok(_) = cx.local.mux.select(st.select);
        let Ok(_) = cx.local.ranges.select(st.select_range);
        let played = cx.shared.feed.lock(|f| {
            f.plan(st.prepare.index, st.prepare.fidx);
            f.played_as_planned(st.done.index)
        });
        if !played {
            // Its plan came too late for the DAC: played at another
            // frequency than the slot says.
            defmt::println!("skip {=u64} {=u8}", st.done.block_mid_us(), st.done.channel);
            return;
        }
        let finished = Finished {
            half,
            slot: st.done,
            completed,
        };
        cx.shared.slot.lock(|s| *s = Some(finished));
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", st.done.index);
            cx.shared.busy.lock(Busy::missed);
        }
    }

    /// DMA1 channel 2's half and full transfer: the DAC played half of
    /// its ring; the quarter slot after next is written there. A late or
    /// failed refill stops the feed (`dma_done` then lets the watchdog
    /// restart the board).
    #[task(binds = DMA1_CH2, priority = 2, shared = [dma, feed], local = [dac_ring])]
    fn dac_refill(mut cx: dac_refill::Context) {
        let event = cx.shared.dma.lock(|dma| dma::take_event_of(dma, DAC_CHANNEL));
        let ring = &mut *cx.local.dac_ring;
        cx.shared.feed.lock(|f| match event {
            dma::Event::None => {}
            e => match e.half() {
                Some(half) => {
                    f.refill(ring, half);
                }
                // Both halves played (a refill came too late) or a
                // transfer error.
                None => f.stop(),
            },
        });
    }

    /// DMA2 channel 1 (or pended by the writer): the chunk sent released,
    /// the next one started.
    #[task(binds = DMA2_CH1, priority = 2, shared = [tx])]
    fn link_tx(mut cx: link_tx::Context) {
        cx.shared.tx.lock(|t| t.service());
    }

    /// Demodulate, correct and queue one block's record, straight from
    /// the DMA buffer.
    #[task(priority = 1, shared = [slot, reader, writer, sending, busy], local = [adc_buf, settings, watchdog])]
    async fn process(mut cx: process::Context) {
        let local = cx.local;
        let Some(Finished {
            half,
            slot,
            completed,
        }) = cx.shared.slot.lock(|s| s.take())
        else {
            return;
        };
        // SAFETY: the DMA finished this half and writes the other one for
        // the next slot; processing takes a seventh of that
        // (`block_load_permille` in docs/benchmarks.md), and a slot that
        // takes longer is counted and its record flagged `LATE`.
        #[allow(unsafe_code)]
        let words: &[u32] = unsafe {
            core::slice::from_raw_parts(local.adc_buf.0.add(half * SLOT_PAIRS + SETTLE_PAIRS), BLOCK_PAIRS)
        };
        // Packed ADC1 (low) / ADC2 (high) 12-bit codes are [v, i] pairs;
        // their offset (the bias) is DC, which the demodulator rejects
        // exactly.
        let pairs: &[[i16; 2]; BLOCK_PAIRS] = match bytemuck::cast_slice::<u32, [i16; 2]>(words).try_into() {
            Ok(p) => p,
            Err(_) => return,
        };
        let (readings, clipped) = lock_ins(slot.fidx, pairs);
        let settings = &*local.settings;
        let read = cx
            .shared
            .reader
            .lock(|r| read_slot(r, settings, &slot, &readings, clipped));
        // From the slot's completion: a slot that took longer than its
        // period may have had its half overwritten by the DMA.
        let spent = DWT::cycle_count().wrapping_sub(completed);
        let (late, status) = cx
            .shared
            .busy
            .lock(|b| (b.block(spent), b.due(slot.block_mid_us())));
        if let Some(s) = status {
            if cx.shared.sending.lock(|s| *s) && cx.shared.writer.lock(|w| w.status(&s)) {
                rtic::pend(pac::Interrupt::DMA2_CH1);
            }
        }
        match read {
            Read::Report(mut rec) => {
                if late {
                    rec.flags.set(instrument::faults::Flags::LATE);
                }
                let sent = cx.shared.sending.lock(|s| *s)
                    && cx.shared.writer.lock(|w| w.record(frames::from_record(&rec)));
                if sent {
                    rtic::pend(pac::Interrupt::DMA2_CH1);
                }
            }
            Read::Quiet => {}
            Read::Skipped => defmt::println!("skip {=u64} {=u8}", slot.block_mid_us(), slot.channel),
        }
        // A block went all the way through: the chain is alive.
        local.watchdog.feed();
    }
}

/// A slot's two tones from its block of sample pairs (the lock-ins of
/// frequency `fidx`), and whether a sample hit a rail. The per-block
/// code, in CCM SRAM with what it calls (`firmware/hot-ram.x`).
#[inline(never)]
#[allow(unsafe_code)]
#[link_section = ".hot_ram"]
fn lock_ins(fidx: usize, pairs: &[[i16; 2]; BLOCK_PAIRS]) -> (Readings, bool) {
    let clipped = pairs
        .iter()
        .any(|&[v, i]| design::on_rail(v as u16) || design::on_rail(i as u16));
    (instrument::config::read(fidx, pairs), clipped)
}

/// The slot's record from its tones ([`MuxReader::read`]): its channel's
/// line, checks and policy. In CCM SRAM as [`lock_ins`].
#[inline(never)]
#[allow(unsafe_code)]
#[link_section = ".hot_ram"]
fn read_slot(
    reader: &mut MuxReader,
    settings: &Settings<'static, POINTS, SENSORS>,
    slot: &Slot,
    readings: &Readings,
    clipped: bool,
) -> Read {
    reader.read(settings, slot, readings, clipped)
}
