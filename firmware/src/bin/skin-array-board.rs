//! The array on the STM32G474 (Nucleo-G474RE): sixteen sensors read at
//! once through one comb excitation ([`instrument::array`]), the chain of
//! `skin-array` in QEMU ([`instrument::reader`]) on the real converters.
//!
//! Analog front end it expects (README, "Every sensor at once"):
//! * PA4 (DAC1_OUT1): the comb, five tones of 0.3 V around 1.65 V (0.87 V
//!   peak), through a 2-pole reconstruction filter and a buffer of gain 1
//!   to every sensor's top tab, and to PA0 (the excitation as applied);
//! * each sensor's bottom tab on an inverting transimpedance stage of
//!   330 kΩ biased at 1.65 V, its output on the pin of
//!   [`firmware::board::scan::INPUT_PINS`] (three of them through the
//!   G474's op-amps as followers).
//!
//! Timing: TIM6 at 25 kHz triggers all five ADCs at once; each scans its
//! four inputs, every one 16× oversampled, and its own DMA channel (DMA1
//! 1–5) fills a circular buffer of two blocks of 100 instants. TIM7 at
//! 1 MHz feeds the DAC the table of one block (4000 codes, DMA1 channel
//! 6), played round and round unchanged: the comb's tones make whole
//! periods in a block, so nothing is ever rewritten. 6800 = 40 · 170
//! cycles, so the table and the blocks stay in step.
//!
//! * `dma_done` (DMA1 channel 5's half and full transfer, the last ADC
//!   the DMA serves): a block is complete in every buffer.
//! * `process`: offset binary to two's complement in place, the rails,
//!   the comb on 17 inputs and 16 two-tone lines; the records go to a
//!   `heapless` SPSC queue (four blocks), a full queue counts a drop.
//! * `idle`: the logger, draining the queue to defmt over RTT.
//!
//! A DMA transfer error or an ADC overrun (one stream out of step with
//! the others) stops the feeding of the watchdog: the board restarts in
//! 100 ms and measures again, and the next boot logs the cause.
#![no_std]
#![no_main]

use dsp_core::demod::FrontEnd;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::track::Tracker;
use firmware::board::dma::Event;
use firmware::board::{clocks, dac, dma, opamp, pac, pins, scan, timer, watchdog};
use firmware::records::{RecordSink, QUEUE};
use heapless::spsc::{Consumer, Queue};
use instrument::array::{
    clipped, dac_table, from_offset_binary, Rows, ADCS, BLOCK, DAC_RATE_HZ, DAC_TABLE, RATE_HZ, RESIDUAL_DOF,
    SCAN, SENSORS, TIA_OHM,
};
use instrument::calib::{Calibrations, REFERENCE};
use instrument::faults::Thresholds;
use instrument::policy::Policy;
use instrument::reader::ArrayReader;
use instrument::tones::{ToneRecord, ToneSettings};

/// The block period, µs.
const BLOCK_US: u64 = BLOCK as u64 * 1_000_000 / RATE_HZ as u64;
/// Results per ADC buffer: two blocks of four positions.
const RESULTS: usize = 2 * BLOCK * SCAN;
/// DMA1 channel (0-based) whose interrupt paces the blocks: the last of
/// the five the DMA serves.
const PACER: usize = ADCS - 1;

/// Every ADC's circular buffer: two blocks.
pub type AdcBuffers = [[Rows; 2]; ADCS];

/// The ADC buffers, seen by the processing task only through the half
/// the DMA has finished.
pub struct DmaBufs(*mut AdcBuffers);

// SAFETY: the pointer is to a 'static buffer; the one task holding it
// touches only the half the DMA has finished (see `process`).
#[allow(unsafe_code)]
unsafe impl Send for DmaBufs {}

/// Pins, followers, DMA, DAC, ADCs, then the timers that start them.
fn front_end(dp: &pac::Peripherals, adc_bufs: &AdcBuffers, table: &[u16; DAC_TABLE]) {
    pins::array_analog(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
    opamp::followers(&dp.OPAMP);
    dma::array_requests(&dp.DMAMUX);
    for (a, adc) in scan::blocks(dp).iter().enumerate() {
        dma::scan_channel(
            &dp.DMA1,
            a,
            adc.dr().as_ptr() as u32,
            adc_bufs[a].as_ptr() as u32,
            RESULTS as u16,
            a == PACER,
        );
    }
    dma::table_channel(
        &dp.DMA1,
        table.as_ptr() as u32,
        dp.DAC1.dhr12r1().as_ptr() as u32,
        DAC_TABLE as u16,
    );
    dac::configure_array(&dp.DAC1);
    scan::init(dp);
    timer::configure_arr(&dp.TIM7, timer::arr_for(DAC_RATE_HZ));
    timer::configure_arr(&dp.TIM6, timer::arr_for(RATE_HZ));
    timer::start(&dp.TIM7);
    timer::start(&dp.TIM6);
}

#[rtic::app(device = stm32g4::stm32g474, dispatchers = [SPI1])]
mod app {
    use super::*;

    #[shared]
    struct Shared {
        /// The block just completed: its DMA half and its index.
        finished: Option<(usize, u64)>,
    }

    #[local]
    struct Local {
        bufs: DmaBufs,
        block: u64,
        reader: ArrayReader,
        settings: ToneSettings<'static, 11>,
        records: RecordSink<'static>,
        logger: Consumer<'static, ToneRecord, QUEUE>,
    }

    #[init(local = [
        queue: Queue<ToneRecord, QUEUE> = Queue::new(),
        adc: AdcBuffers = [[[[0; SCAN]; BLOCK]; 2]; ADCS],
        table: [u16; DAC_TABLE] = [0; DAC_TABLE],
        cals: Calibrations<'static, 11, SENSORS> = Calibrations::new(&REFERENCE),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let cause = watchdog::take_reset_cause(&dp.RCC);
        defmt::println!("reset cause: {=str}", cause.as_str());
        watchdog::start(&dp.IWDG);
        clocks::system(&dp);
        clocks::array_peripherals(&dp.RCC);
        let (records, logger) = cx.local.queue.split();
        // Every sensor on the reference table until a calibration run
        // gives it its own (`Calibrations::insert`).
        let cal: &'static Calibrations<'static, 11, SENSORS> = cx.local.cals;
        let Ok(reader) = ArrayReader::new(cal) else {
            defmt::println!("comb: bad tone set; watchdog reset follows");
            loop {
                cortex_m::asm::wfi();
            }
        };
        let Ok(inverter) = Inverter::with_x_max(LineModel::Continuous, Tracker::X_MAX) else {
            defmt::println!("inverter: bad bound; watchdog reset follows");
            loop {
                cortex_m::asm::wfi();
            }
        };
        let table: &'static mut [u16; DAC_TABLE] = cx.local.table;
        dac_table(table);
        let adc: &'static mut AdcBuffers = cx.local.adc;
        front_end(&dp, adc, table);
        while !watchdog::ready(&dp.IWDG) {}
        watchdog::feed(&dp.IWDG);
        defmt::println!(
            "start array {=u8} sensors, {=u32} records/s each",
            SENSORS as u8,
            RATE_HZ / BLOCK as u32
        );
        (
            Shared { finished: None },
            Local {
                bufs: DmaBufs(adc),
                block: 0,
                reader,
                settings: ToneSettings {
                    policy: Policy::DEFAULT,
                    thresholds: Thresholds::ARRAY,
                    front_end: FrontEnd::transimpedance(TIA_OHM as f32, true),
                    inverter,
                    calibration: cal,
                    fixture: dsp_core::fixture::Fixture::NONE,
                    chi2_flag: dsp_core::twotone::chi2_flag(1e-4, RESIDUAL_DOF),
                },
                records: RecordSink::new(records),
                logger,
            },
        )
    }

    /// The logger: the record queue to defmt.
    #[idle(local = [logger])]
    fn idle(cx: idle::Context) -> ! {
        loop {
            while let Some(rec) = cx.local.logger.dequeue() {
                defmt::println!("{}", rec);
            }
            cortex_m::asm::wfi();
        }
    }

    /// DMA1 channel 5, half or full: block `k` is in every ADC's buffer.
    #[task(binds = DMA1_CH5, priority = 2, shared = [finished], local = [block])]
    fn dma_done(mut cx: dma_done::Context) {
        // SAFETY: after `init` this task alone reads and clears channel
        // 5's flags and the ADCs' overrun flags.
        #[allow(unsafe_code)]
        let (event, overrun) = unsafe {
            let dp = pac::Peripherals::steal();
            (
                dma::take_event_of(&dp.DMA1, PACER),
                scan::take_overrun(scan::blocks(&dp)),
            )
        };
        let expected = (*cx.local.block % 2) as usize;
        let (half, lost) = match event {
            Event::Error => (0, true),
            Event::None => return,
            // Both halves done: the interrupt came a block late, and the
            // expected block is lost (the DMA is overwriting it).
            Event::Overrun => (1 - expected, true),
            e => match e.half() {
                Some(h) => (h, h != expected),
                None => return,
            },
        };
        if event == Event::Error || overrun {
            // Nothing is fed from here on: the watchdog restarts the
            // board within 100 ms.
            defmt::println!("dma error or adc overrun: acquisition stopped, watchdog reset follows");
            return;
        }
        if lost {
            defmt::println!("lost {=u64}", *cx.local.block * BLOCK_US + BLOCK_US / 2);
            *cx.local.block += 1;
        }
        let k = *cx.local.block;
        *cx.local.block += 1;
        cx.shared.finished.lock(|f| *f = Some((half, k)));
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", k);
        }
    }

    /// The block's records, straight from the DMA buffers.
    #[task(priority = 1, shared = [finished], local = [bufs, reader, settings, records])]
    async fn process(mut cx: process::Context) {
        let Some((half, k)) = cx.shared.finished.lock(|f| f.take()) else {
            return;
        };
        let bufs = cx.local.bufs.0;
        // SAFETY: the DMA finished this half of every buffer and writes
        // the other ones for the next 4 ms; this task takes 1.1 ms.
        #[allow(unsafe_code)]
        let rows: [&Rows; ADCS] = core::array::from_fn(|a| unsafe {
            let r = &mut (*bufs)[a][half];
            from_offset_binary(r);
            &*r
        });
        let rails = clipped(|a| rows[a]);
        let reader = &mut *cx.local.reader;
        let block = reader.demodulate(|a| rows[a]);
        let sink = &mut *cx.local.records;
        let before = sink.drops();
        let t_us = k * BLOCK_US + BLOCK_US / 2;
        reader.solve(
            &*cx.local.settings,
            t_us,
            &block,
            |input| rails[input],
            |rec| sink.push(rec),
        );
        if sink.drops() != before {
            defmt::println!("drops {=u32}", sink.drops());
        }
        // A block went all the way through: the chain is alive.
        // SAFETY: IWDG_KR is write-only and written by this task alone
        // after `init`.
        #[allow(unsafe_code)]
        watchdog::feed(unsafe { &*pac::IWDG::ptr() });
    }
}
