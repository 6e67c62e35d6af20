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
//!   DAC's first two slots, `board::front_end::multiplexed`, and
//!   `board::setup` ends, handing DMA1 and the IWDG to the tasks.
//! * `dma_done` (DMA1 channel 1's half and full transfer): the
//!   completion (`board::dma::Completion`), the sequencer's step (which
//!   slot completed, which channel and range to select, which frequency
//!   to write into the DAC half just finished), then `process`.
//! * `process`: the finished half demodulated in place, the channel's
//!   record queued on the record link ([`firmware::link_out`]), the
//!   watchdog fed.
//! * `link_tx` (DMA2 channel 1): the link's frames through LPUART1, the
//!   ST-LINK's virtual COM port ([`firmware::board::link`]). defmt over
//!   RTT carries log messages only, and never blocks.
//!
//! This image keeps no settings: every sensor is read with the line
//! model alone (no tab leads, no wiring) and its stretch is marked not
//! calibrated (`Flags::UNCALIBRATED`). `skin-array-board` keeps each
//! sensor's calibration in flash.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use firmware::board::dma::{self, Completion};
use firmware::board::front_end::{self, AdcSlots, DacSlots, SLOTS};
use firmware::board::link::Transmitter;
use firmware::board::pins::{self, AnyPin};
use firmware::board::setup::{self, Watchdog};
use firmware::board::{clocks, dac, pac};
use firmware::link_out::{FrameWriter, LinkQueue};
use instrument::calib::POINTS;
use instrument::channel::{Channel, Settings};
use instrument::config::{
    BLOCK_PAIRS, CHANNELS, MUX_ADDRESS_LINES, RANGE_ADDRESS_LINES, SETTLE_PAIRS, SLOT_PAIRS,
};
use instrument::design;
use instrument::frames;
use instrument::mux::Mux;
use instrument::ranging::Ranging;
use instrument::sensor::{Sensor, Sensors};
use instrument::sequencer::{Sequencer, Slot};

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

#[rtic::app(device = stm32g4::stm32g474, dispatchers = [SPI1])]
mod app {
    use super::*;

    /// A finished slot and the DMA half that holds it.
    #[derive(Clone, Copy)]
    pub struct Finished {
        pub half: usize,
        pub slot: Slot,
    }

    #[shared]
    struct Shared {
        slot: Option<Finished>,
        channels: [Channel; CHANNELS],
    }

    #[local]
    struct Local {
        dma: pac::DMA1,
        dac1: pac::DAC1,
        watchdog: Watchdog,
        adc_buf: DmaBuf,
        dac_buf: &'static mut DacSlots,
        mux: BoardMux,
        ranges: RangeSwitch,
        seq: Sequencer,
        settings: Settings<'static, POINTS, 1>,
        writer: FrameWriter<'static, LINK_BYTES>,
        tx: Transmitter<'static, LINK_BYTES>,
    }

    #[init(local = [
        adc: AdcSlots = [0; SLOTS * SLOT_PAIRS],
        // Zero, so that it lives in .bss and not as 4 KiB of initial
        // values in flash: both slots are written below before the DAC
        // starts.
        dac: DacSlots = [0; SLOTS * SLOT_PAIRS],
        link_queue: LinkQueue<LINK_BYTES> = LinkQueue::new(),
        sensors: MaybeUninit<Sensors<POINTS, 1>> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        setup::begin(&dp);
        clocks::peripherals(&dp.RCC);
        // This image keeps no settings (its 64 KiB leave no room for the
        // store): every sensor is read as one nothing was measured on.
        let settings = Settings::new(
            Ranging::DEFAULT.front_ends(design::V_GAIN as f32),
            Ranging::DEFAULT,
            cx.local.sensors.write(Sensors::all(Sensor::uncalibrated(
                design::SENSOR_C_REST_FARAD as f32,
            ))),
        );
        let channels = [Channel::new(settings.sensors.of(0).rest_farad); CHANNELS];
        // Slots 0 and 1 play their channels at their start frequencies.
        let (seq, slots) = Sequencer::start(|c| channels[c as usize].plan());
        let (first, second) = cx.local.dac.split_at_mut(SLOT_PAIRS);
        front_end::fill_slot(first, slots[0].fidx);
        front_end::fill_slot(second, slots[1].fidx);
        let mut mux = Mux::new(pins::mux_pins());
        let Ok(_) = mux.select(slots[0].channel);
        let mut ranges = Mux::new(pins::range_pins());
        let Ok(_) = ranges.select(slots[0].range);
        let adc_buf: &'static mut AdcSlots = cx.local.adc;
        let dac_buf: &'static mut DacSlots = cx.local.dac;
        front_end::multiplexed(&dp, adc_buf, dac_buf);
        let owned = setup::finish(dp);
        let queue: &'static LinkQueue<LINK_BYTES> = cx.local.link_queue;
        let writer = FrameWriter::start(
            queue,
            frames::start(
                concat!("skin-board ", env!("CARGO_PKG_VERSION")),
                &settings,
                &settings.sensors.calibration(),
                CHANNELS,
                design::SAMPLE_RATE,
            ),
        );
        let tx = Transmitter::new(owned.link.dma, queue.stream_consumer(), owned.link.tdr);
        rtic::pend(pac::Interrupt::DMA2_CH1);
        defmt::println!("start {=u8} channels", CHANNELS as u8);
        (
            Shared { slot: None, channels },
            Local {
                dma: owned.dma,
                dac1: owned.dac,
                watchdog: owned.watchdog,
                adc_buf: DmaBuf(adc_buf.as_ptr()),
                dac_buf,
                mux,
                ranges,
                seq,
                settings,
                writer,
                tx,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// DMA half/full transfer: slot `k` is complete and slot `k + 1` begins.
    #[task(binds = DMA1_CH1, priority = 2, shared = [slot, channels], local = [dma, dac1, dac_buf, mux, ranges, seq])]
    fn dma_done(mut cx: dma_done::Context) {
        if dac::excitation_stopped(cx.local.dac1, cx.local.dma, 1) {
            // The DAC's DMA (channel 2) underran or failed: nothing is fed
            // from here on, the watchdog restarts the board within 100 ms.
            defmt::println!("excitation stopped (DAC DMA underrun or error): watchdog reset follows");
            return;
        }
        let expected = (cx.local.seq.next_index() % 2) as usize;
        let (half, lost) = match dma::take_event(cx.local.dma).completion(expected) {
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
        let dac = &mut *cx.local.dac_buf;
        if lost {
            let st = cx
                .shared
                .channels
                .lock(|c| seq.complete(|ch| c[ch as usize].plan()));
            front_end::prepare(dac, &st);
            defmt::println!("lost {=u64} {=u8}", st.done.block_mid_us(), st.done.channel);
        }
        let st = cx
            .shared
            .channels
            .lock(|c| seq.complete(|ch| c[ch as usize].plan()));
        // The slot that begins now: select its channel (within its settling).
        let Ok(_) = cx.local.mux.select(st.select);
        let Ok(_) = cx.local.ranges.select(st.select_range);
        cx.shared
            .slot
            .lock(|s| *s = Some(Finished { half, slot: st.done }));
        front_end::prepare(dac, &st);
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", st.done.index);
        }
    }

    /// DMA2 channel 1 (or pended by the writer): the chunk sent released,
    /// the next one started.
    #[task(binds = DMA2_CH1, priority = 2, local = [tx])]
    fn link_tx(cx: link_tx::Context) {
        cx.local.tx.service();
    }

    /// Demodulate, correct and queue one block's record, straight from
    /// the DMA buffer.
    #[task(priority = 1, shared = [slot, channels], local = [adc_buf, settings, watchdog, writer])]
    async fn process(mut cx: process::Context) {
        let local = cx.local;
        let Some(Finished { half, slot }) = cx.shared.slot.lock(|s| s.take()) else {
            return;
        };
        let (ch, fidx) = (slot.channel, slot.fidx);
        // SAFETY: the DMA finished this half and writes the other one for
        // the next 5.44 ms; processing takes about 0.5 ms (`block_process`,
        // docs/benchmarks.md: 70 600 instructions).
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
        let clipped = pairs
            .iter()
            .any(|&[v, i]| design::on_rail(v as u16) || design::on_rail(i as u16));
        let ph = instrument::config::read(fidx, pairs);
        let settings = &*local.settings;
        let rec = cx.shared.channels.lock(|c| {
            let channel = &mut c[ch as usize];
            if channel.freq_index() != fidx {
                // Played at another frequency than the policy now wants:
                // the policy switched since; skip, the next slot catches up.
                return None;
            }
            Some(channel.process(settings, ch, slot.block_mid_us(), &ph, clipped, slot.range))
        });
        match rec {
            Some(rec) => {
                if local.writer.record(frames::from_record(&rec)) {
                    rtic::pend(pac::Interrupt::DMA2_CH1);
                }
            }
            None => defmt::println!("skip {=u64} {=u8}", slot.block_mid_us(), ch),
        }
        // A block went all the way through: the chain is alive.
        local.watchdog.feed();
    }
}
