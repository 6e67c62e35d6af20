//! The array on the STM32G474 (Nucleo-G474RE): sixteen sensors read at
//! once through one comb excitation ([`instrument::array`]), the chain of
//! `skin-array` in QEMU ([`instrument::reader`]) on the real converters.
//!
//! Analog front end it expects (README, "Every sensor at once"):
//! * PA4 (DAC1_OUT1): the comb around 1.65 V, five tones from 0.83 V at
//!   250 Hz falling as 1/√f to 0.21 V at 4 kHz (1.32 V peak), through a 2-pole reconstruction filter and a buffer of gain 1
//!   to every sensor's top tab, and to PA0 (the excitation as applied);
//! * each sensor's bottom tab on an inverting transimpedance stage of
//!   330 kΩ biased at 1.65 V, its output on the pin of
//!   [`firmware::board::scan::INPUT_PINS`] (three of them through the
//!   G474's op-amps as followers).
//!
//! Blocks are of [`LAYOUT`]: 4 ms, 250 records/s
//! ([`Layout::BLOCK_4MS`]), or 1 ms, 1000 records/s, at twice the noise
//! ([`Layout::BLOCK_1MS`]; its comb 1 … 6 kHz).
//!
//! Timing: TIM6 at 25 kHz triggers all five ADCs at once; each scans its
//! four inputs, every one 16× oversampled, and its own DMA channel (DMA1
//! 1–5) fills a circular buffer of two blocks (of 100 instants, or 25).
//! TIM7 at 1 MHz feeds the DAC the table of one block (4000 codes, or
//! 1000; DMA1 channel 6), played round and round unchanged: the comb's
//! tones make whole periods in a block, so nothing is ever rewritten.
//! 6800 = 40 · 170 cycles, so the table and the blocks stay in step.
//!
//! * `dma_done` (DMA1 channel 5's half and full transfer, the last ADC
//!   the DMA serves): a block is complete in every buffer.
//! * `process`: offset binary to two's complement in place, the rails,
//!   the comb on 17 inputs and 16 two-tone lines; the records go to a
//!   `heapless` SPSC queue (four blocks), a full queue counts a drop.
//! * `idle`: the link's writer, draining the queue into frames
//!   ([`firmware::link_out`]); `link_tx` (DMA2 channel 1) sends them
//!   through LPUART1, the ST-LINK's virtual COM port
//!   ([`firmware::board::link`]). defmt over RTT carries log messages
//!   only, and never blocks. The host's requests come back on the same
//!   port (DMA2 channel 2 round a ring): `idle` answers them with the
//!   settings stored in the last 8 KiB of flash
//!   ([`firmware::board::flash`], [`instrument::store`]).
//!
//! The board measures with the set stored there at start: each sensor's
//! tab leads, wiring and stretch table ([`instrument::sensor`]). With
//! none stored it reads every sensor as one nothing was measured on: the
//! line alone, stretch marked not calibrated. A set that comes down the
//! link is in force from the next start.
//!
//! A DMA transfer error or an ADC overrun (one stream out of step with
//! the others) stops the feeding of the watchdog: the board restarts in
//! 100 ms and measures again, and the next boot logs the cause.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m::peripheral::DWT;
use dsp_core::demod::FrontEnd;
use firmware::board::dma::{self, Completion};
use firmware::board::flash::SettingsFlash;
use firmware::board::front_end::{self, array_half, AdcBlocks, ARRAY_PACER};
use firmware::board::link::{self, RxRing, Transmitter, RX_BYTES};
use firmware::board::requests::{Requests, KICKS};
use firmware::board::scan::{self, Adcs};
use firmware::board::setup::{self, Watchdog};
use firmware::board::{clocks, dac, pac, watchdog};
use firmware::in_force::InForce;
use firmware::link_out::{FrameWriter, LinkQueue};
use firmware::power_up::PowerUp;
use firmware::records::{RecordSink, QUEUE};
use heapless::spsc::{Consumer, Queue};
use heapless::Vec;
use instrument::array::{
    to_signed_all, Layout, ADCS, BLOCK_INSTANTS, DAC_TABLE, RATE_HZ, SCAN, SENSORS, SENSOR_TIA_OHM,
};
use instrument::busy::Busy;
use instrument::calib::POINTS;
use instrument::commands::{Action, Commands};
use instrument::frames;
use instrument::reader::{ArrayReader, Demodulated};
use instrument::sensor::Sensors;
use instrument::store::{Store, SLOT_BYTES};
use instrument::sweep::Sweep;
use instrument::tones::{ToneCommon, ToneRecord, ToneSettings};

/// The link's byte queue: two blocks of frames.
const LINK_BYTES: usize = 2048;

/// The blocks' layout: [`Layout::BLOCK_4MS`] (250 records/s), or with
/// the feature `array-1ms` [`Layout::BLOCK_1MS`] (1000 records/s;
/// `cargo flash-array-board-1ms`).
#[cfg(not(feature = "array-1ms"))]
const LAYOUT: Layout = Layout::BLOCK_4MS;
/// The blocks' layout: [`Layout::BLOCK_1MS`] (1000 records/s; the
/// feature `array-1ms`).
#[cfg(feature = "array-1ms")]
const LAYOUT: Layout = Layout::BLOCK_1MS;
/// The block period, µs.
const BLOCK_US: u64 = LAYOUT.block_us();

/// The ADC buffers, seen by the processing task only through the half
/// the DMA has finished.
pub struct DmaBufs(*mut AdcBlocks);

// SAFETY: the pointer is to a 'static buffer; the one task holding it
// touches only the half the DMA has finished (see `process`).
#[allow(unsafe_code)]
unsafe impl Send for DmaBufs {}

/// The set in force at start: the one `store` holds (with none, sensors
/// nothing was measured on), its sensors built into `slot`; a set whose
/// lead ratio is beyond the line model waits for the watchdog's reset.
fn in_force_at_start(
    store: &mut Store<SettingsFlash>,
    slot: &'static mut MaybeUninit<Sensors<POINTS, SENSORS>>,
) -> InForce<ToneCommon, SENSORS> {
    let (generation, set) = firmware::settings_log::in_force(store);
    let Ok(sensors) = firmware::settings_log::sensors_in(slot, &set) else {
        defmt::println!("settings: a tab-lead ratio beyond the line model; watchdog reset follows");
        watchdog::await_reset()
    };
    let common = ToneCommon {
        policy: set.policy,
        record_every: set.record_every,
        ..ToneSettings::new(
            LAYOUT,
            FrontEnd::transimpedance(SENSOR_TIA_OHM as f32, true),
            &*sensors,
        )
        .common()
    };
    InForce::new(common, sensors, generation)
}

/// The set the host stored, applied (after the records of the old one),
/// its frame queued. Not inlined: once per set stored.
#[inline(never)]
fn apply_new_set(
    in_force: &mut InForce<ToneCommon, SENSORS>,
    logger: &mut Consumer<'static, ToneRecord, QUEUE>,
    writer: &mut FrameWriter<'static, LINK_BYTES>,
    requests: &mut Requests<SettingsFlash>,
    sending: bool,
) {
    send_records(logger, writer, sending);
    let applied = requests.apply(in_force, writer.last_t_us());
    firmware::settings_log::applied(&applied);
    if let Ok(a) = applied {
        writer.applied(&a, || rtic::pend(pac::Interrupt::DMA2_CH1), KICKS);
    }
}

/// Each record the queue holds into frames (dropped while the host has
/// asked not to send); whether any was queued. Not inlined: `idle` calls
/// it twice.
#[inline(never)]
fn send_records(
    logger: &mut Consumer<'static, ToneRecord, QUEUE>,
    writer: &mut FrameWriter<'static, LINK_BYTES>,
    sending: bool,
) -> bool {
    let mut queued = false;
    while let Some(rec) = logger.dequeue() {
        if sending {
            queued |= writer.record(frames::from_tone_record(&rec));
        }
    }
    queued
}

#[rtic::app(device = stm32g4::stm32g474, dispatchers = [SPI1])]
mod app {
    use super::*;

    #[shared]
    struct Shared {
        /// The block just completed: its DMA half, its index, and the
        /// cycle counter at its completion.
        finished: Option<(usize, u64, u32)>,
        /// The link's port: its transmit task, and `idle` for the receive
        /// position.
        tx: Transmitter<'static, LINK_BYTES>,
        /// A calibration step's sweep of the tone pairs, if one is under
        /// way.
        sweep: Sweep,
        /// How the CPU keeps up: blocks' cycles, late and missed ones.
        busy: Busy,
        /// The status due on the link, if one is.
        status: Option<::link::Status>,
        /// The settings and sensors measured with, replaced by `idle`
        /// when the host stores a new set.
        in_force: InForce<ToneCommon, SENSORS>,
        /// The self-test's result, for the start frame, once it is done.
        self_test: Option<::link::SelfTest>,
    }

    #[local]
    struct Local {
        dma: pac::DMA1,
        dac1: pac::DAC1,
        adcs: Adcs,
        watchdog: Watchdog,
        bufs: DmaBufs,
        block: u64,
        reader: ArrayReader,
        records: RecordSink<'static>,
        logger: Consumer<'static, ToneRecord, QUEUE>,
        writer: FrameWriter<'static, LINK_BYTES>,
        /// The start frame, queued when the self-test is done (`None`
        /// once queued).
        start: Option<::link::Start>,
        requests: Requests<SettingsFlash>,
        sending: bool,
        /// The power-up self-test, in the first blocks.
        power_up: PowerUp,
    }

    #[init(local = [
        queue: Queue<ToneRecord, QUEUE> = Queue::new(),
        // Sixteen sensors' lines and tables (10 KiB), built in place.
        sensors: MaybeUninit<Sensors<POINTS, SENSORS>> = MaybeUninit::uninit(),
        adc: AdcBlocks = [[[[0; SCAN]; BLOCK_INSTANTS]; 2]; ADCS],
        table: [u16; DAC_TABLE] = [0; DAC_TABLE],
        link_queue: LinkQueue<LINK_BYTES> = LinkQueue::new(),
        rx_ring: RxRing = [0; RX_BYTES],
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        // The cycle counter, for each block's time (`busy`).
        let mut core = cx.core;
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        setup::begin(&dp);
        clocks::array_peripherals(&dp.RCC);
        let (records, logger) = cx.local.queue.split();
        let table: &'static mut [u16; DAC_TABLE] = cx.local.table;
        let table = LAYOUT.dac_table(table);
        let adc: &'static mut AdcBlocks = cx.local.adc;
        front_end::array(&dp, &LAYOUT, adc, table);
        let owned = setup::finish(dp);
        let Ok(mut store) = Store::new(SettingsFlash::new(owned.flash), 0, SLOT_BYTES) else {
            defmt::println!("settings: the slots do not fit the flash; watchdog reset follows");
            watchdog::await_reset()
        };
        let in_force = in_force_at_start(&mut store, cx.local.sensors);
        let Ok(reader) = ArrayReader::for_mains(LAYOUT, in_force.sensors(), firmware::MAINS_HZ) else {
            defmt::println!("comb: bad tone set; watchdog reset follows");
            watchdog::await_reset()
        };
        let queue: &'static LinkQueue<LINK_BYTES> = cx.local.link_queue;
        let writer = FrameWriter::new(queue);
        let start = in_force.start_frame(
            concat!("skin-array-board ", env!("CARGO_PKG_VERSION")),
            firmware::board::device_id::read(),
            SENSORS,
            RATE_HZ,
        );
        let ring: &'static mut RxRing = cx.local.rx_ring;
        link::receive(&owned.link.dma, owned.link.rdr, ring.as_ptr() as u32);
        let tx = Transmitter::new(owned.link.dma, queue.stream_consumer(), owned.link.tdr);
        rtic::pend(pac::Interrupt::DMA2_CH1);
        defmt::println!(
            "start array {=u8} sensors, {=u32} records/s each",
            SENSORS as u8,
            LAYOUT.records_per_s()
        );
        (
            Shared {
                finished: None,
                tx,
                sweep: Sweep::new(),
                busy: Busy::new(
                    ::link::Clock::Cycles,
                    instrument::design::SYSCLK_HZ,
                    BLOCK_US as u32,
                    LAYOUT.records_per_s(),
                ),
                status: None,
                in_force,
                self_test: None,
            },
            Local {
                dma: owned.dma,
                dac1: owned.dac,
                adcs: owned.adcs,
                watchdog: owned.watchdog,
                bufs: DmaBufs(adc),
                block: 0,
                reader,
                records: RecordSink::new(records),
                logger,
                writer,
                start: Some(start),
                requests: Requests::new(ring, Commands::sweeping(), store),
                sending: true,
                power_up: PowerUp::new(LAYOUT),
            },
        )
    }

    /// The link's writer: the record queue into frames; the host's
    /// requests from the receive ring, answered
    /// ([`instrument::commands`]: the stored settings, start, stop, a
    /// calibration step's sweep); then
    /// the transmitter woken.
    #[idle(
        shared = [tx, sweep, status, in_force, self_test],
        local = [logger, writer, start, requests, sending]
    )]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            let l = &mut cx.local;
            if let Some(start) = l.start.as_mut() {
                // Nothing on the link before the start frame, which waits
                // for the self-test (the host's requests wait in the ring).
                match cx.shared.self_test.lock(Option::take) {
                    Some(result) => {
                        start.self_test = result;
                        l.writer.send_start(start);
                        *l.start = None;
                        rtic::pend(pac::Interrupt::DMA2_CH1);
                    }
                    None => {
                        cortex_m::asm::wfi();
                        continue;
                    }
                }
            }
            let mut queued = send_records(l.logger, l.writer, *l.sending);
            if let Some(status) = cx.shared.status.lock(Option::take) {
                if *l.sending {
                    queued |= l.writer.status(&status);
                }
            }
            let remaining = cx.shared.tx.lock(|t| t.rx_remaining());
            let writer = &mut *l.writer;
            // A long reply waits for the transmitter, kicked.
            let kick = || rtic::pend(pac::Interrupt::DMA2_CH1);
            if let Some(action) = l.requests.answer(remaining, writer, kick) {
                match action {
                    Action::Start => *l.sending = true,
                    Action::Stop => {
                        *l.sending = false;
                        writer.end(0);
                    }
                    Action::Apply => {
                        let (logger, requests, sending) = (&mut *l.logger, &mut *l.requests, *l.sending);
                        // With `process` held off: the records of the old
                        // set first, then the frame, then the new set's.
                        cx.shared
                            .in_force
                            .lock(|f| apply_new_set(f, logger, writer, requests, sending));
                    }
                    Action::Sweep(n) => cx.shared.sweep.lock(|s| s.start(n)),
                    Action::None => {}
                }
                queued = true;
            }
            if queued {
                rtic::pend(pac::Interrupt::DMA2_CH1);
            }
            cortex_m::asm::wfi();
        }
    }

    /// DMA2 channel 1 (or pended by the writer): the chunk sent released,
    /// the next one started.
    #[task(binds = DMA2_CH1, priority = 2, shared = [tx])]
    fn link_tx(mut cx: link_tx::Context) {
        cx.shared.tx.lock(|t| t.service());
    }

    /// DMA1 channel 5, half or full: block `k` is in every ADC's buffer.
    #[task(binds = DMA1_CH5, priority = 2, shared = [finished, busy], local = [dma, dac1, adcs, block])]
    fn dma_done(mut cx: dma_done::Context) {
        let completed = DWT::cycle_count();
        let event = dma::take_event_of(cx.local.dma, ARRAY_PACER);
        // An ADC out of step, or the comb stopped (its DAC's DMA
        // underran or failed): either way no block is whole.
        let overrun = scan::take_overrun(cx.local.adcs)
            | dac::excitation_stopped(cx.local.dac1, cx.local.dma, dma::ARRAY_DAC_CHANNEL);
        let expected = (*cx.local.block % 2) as usize;
        let (half, lost) = match event.completion(expected) {
            Completion::Done { half, lost } if !overrun => (half, lost),
            Completion::Nothing if !overrun => return,
            _ => {
                // A transfer error, an ADC whose stream is out of step
                // with the others, or the excitation stopped. Nothing is
                // fed from here on: the watchdog restarts the board within
                // 100 ms.
                defmt::println!("dma error, adc overrun or excitation stopped: acquisition stopped, watchdog reset follows");
                return;
            }
        };
        if lost {
            defmt::println!("lost {=u64}", *cx.local.block * BLOCK_US + BLOCK_US / 2);
            cx.shared.busy.lock(Busy::missed);
            *cx.local.block += 1;
        }
        let k = *cx.local.block;
        *cx.local.block += 1;
        cx.shared.finished.lock(|f| *f = Some((half, k, completed)));
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", k);
            cx.shared.busy.lock(Busy::missed);
        }
    }

    /// The block's records, straight from the DMA buffers.
    #[task(
        priority = 1,
        shared = [finished, sweep, busy, status, in_force, self_test],
        local = [bufs, reader, records, watchdog, power_up]
    )]
    async fn process(mut cx: process::Context) {
        let Some((half, k, completed)) = cx.shared.finished.lock(|f| f.take()) else {
            return;
        };
        let sweep = cx.shared.sweep.lock(|s| s.next_block());
        let bufs = cx.local.bufs.0;
        // SAFETY: the DMA finished this half of every buffer and writes
        // the other ones for the next block, which this task finishes
        // before (`array_latency_us` in docs/benchmarks.md; an overrun is
        // reported).
        #[allow(unsafe_code)]
        let rows: [&mut [[i16; SCAN]]; ADCS] =
            core::array::from_fn(|a| unsafe { array_half(&mut (*bufs)[a], &LAYOUT, half) });
        let t_us = k * BLOCK_US + BLOCK_US / 2;
        let reader = &mut *cx.local.reader;
        if cx.local.power_up.testing() {
            let k = cx.shared.in_force.lock(|f| f.settings().front_end);
            if let Some(r) = self_test_block(cx.local.power_up, reader, rows, &k) {
                cx.shared.self_test.lock(|s| *s = Some(r));
            }
            cx.local.watchdog.feed();
            return;
        }
        let recs = cx.shared.in_force.lock(|f| {
            let settings = ToneSettings {
                sweep,
                ..f.settings()
            };
            read_block(reader, &settings, rows, t_us)
        });
        // From the block's completion: a block that took longer than its
        // period may have had its half overwritten by the DMA.
        let spent = DWT::cycle_count().wrapping_sub(completed);
        let (late, status) = cx.shared.busy.lock(|b| (b.block(spent), b.due(t_us)));
        if let Some(s) = status {
            cx.shared.status.lock(|x| *x = Some(s));
        }
        let sink = &mut *cx.local.records;
        let before = sink.drops();
        sink.push_block(&recs, late);
        if sink.drops() != before {
            defmt::println!("drops {=u32}", sink.drops());
        }
        // A block went all the way through: the chain is alive.
        cx.local.watchdog.feed();
    }
}

/// A block of the power-up self-test ([`PowerUp::block`]) from the ADCs'
/// rows of it: the rows to two's complement in place, the comb on every
/// input ([`demodulate`], the records' own) and on the reference's.
/// Not in CCM SRAM: it runs for the first 100 ms only.
fn self_test_block(
    power_up: &mut PowerUp,
    reader: &mut ArrayReader,
    rows: [&mut [[i16; SCAN]]; ADCS],
    k: &FrontEnd,
) -> Option<::link::SelfTest> {
    let mut block = Demodulated::EMPTY;
    let (rows, rails) = demodulate(reader, rows, &mut block);
    let reference = reader.reference(|a| rows[a]);
    power_up.block(reader, &block, &reference, |i| rails[i], k)
}

/// A block's rows to two's complement in place, noting the inputs on a
/// rail, and the comb on every input into `block`: the one instance of
/// it in the image, which the self-test shares. In CCM SRAM.
#[inline(never)]
#[allow(unsafe_code)]
#[link_section = ".hot_ram"]
fn demodulate<'a>(
    reader: &ArrayReader,
    mut rows: [&'a mut [[i16; SCAN]]; ADCS],
    block: &mut Demodulated,
) -> ([&'a [[i16; SCAN]]; ADCS], [bool; instrument::array::INPUTS]) {
    let rails = to_signed_all(&mut rows);
    let rows: [&[[i16; SCAN]]; ADCS] = rows.map(|r| &*r);
    reader.demodulate_into(|a| rows[a], block);
    (rows, rails)
}

/// A block's records from the ADCs' rows of it (the half the DMA
/// finished), whose middle is at `t_us`: the rows to two's complement in
/// place, noting the inputs on a rail; the comb on every input
/// (demodulated in place: 1.7 KiB, returned it would be copied); each
/// sensor's two-tone line and record. The per-block code, in CCM SRAM
/// with what it calls (`firmware/hot-ram.x`).
#[inline(never)]
#[allow(unsafe_code)]
#[link_section = ".hot_ram"]
fn read_block(
    reader: &mut ArrayReader,
    settings: &ToneSettings<'_, POINTS>,
    rows: [&mut [[i16; SCAN]]; ADCS],
    t_us: u64,
) -> Vec<ToneRecord, SENSORS> {
    let mut demodulated = Demodulated::EMPTY;
    let block = &mut demodulated;
    let (_, rails) = demodulate(reader, rows, block);
    let mut recs = Vec::new();
    reader.solve(
        settings,
        t_us,
        block,
        |input| rails[input],
        |rec| {
            // One a sensor: never more than it holds.
            let _ = recs.push(rec);
        },
    );
    recs
}
