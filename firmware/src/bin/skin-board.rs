//! The sensing-skin firmware on the STM32G474 (Nucleo-G474RE).
//!
//! Analog front end it expects (see the README and `instrument::design`):
//! * PA4 (DAC1_OUT1): excitation, 1 V amplitude around 1.65 V, through a
//!   buffer to the multiplexed sensors' top tab;
//! * PA0 (ADC1_IN1): the excitation as applied (voltage channel);
//! * PA1 (ADC2_IN2): the inverting transimpedance stage (100 kΩ) on the
//!   bottom tab, biased at 1.65 V (current channel);
//! * PB0, PB1, PB2: address lines A0..A2 of an 8-channel analog
//!   multiplexer (ADG708 or similar) on both tabs.
//!
//! Timing: TIM6 at 200 kHz triggers the DAC and both ADCs (dual regular
//! simultaneous mode); DMA1 channel 1 moves the packed ADC pairs into a
//! circular buffer of two slots (64 settling pairs + a 1024-pair block
//! each), DMA1 channel 2 feeds the DAC from a matching buffer. The half and
//! full transfer interrupts of channel 1 are the `dma_done` hardware task;
//! the sequencer (`instrument::sequencer`, the same as in QEMU) says which
//! slot completed, which channel to select and which frequency to write
//! into the DAC half just finished. The hardware lives in
//! `firmware::board` (one module per peripheral).
#![no_std]
#![no_main]

use dsp_core::osc::{Oscillator, OscillatorState};
use firmware::board::dma::Event;
use firmware::board::pins::AnyPin;
use firmware::board::{adc, clocks, dac, dma, pac, pins, timer, watchdog};
use instrument::calib::{CalTable, REFERENCE};
use instrument::channel::{Channel, Settings};
use instrument::config::{ftw, BLOCK, CHANNELS, DEMODULATORS, SETTLE_PAIRS, SLOT_PAIRS};
use instrument::design;
use instrument::faults::Thresholds;
use instrument::mux::Mux;
use instrument::policy::Policy;
use instrument::ranging::Ranging;
use instrument::sequencer::{Sequencer, Slot, Step};

/// Pairs per slot: settling, then the block.
const SLOT: usize = SLOT_PAIRS;

/// The multiplexer on PB0..PB2.
pub type BoardMux = Mux<AnyPin, 3>;
/// The transimpedance range switch on PB5, PB6.
pub type RangeSwitch = Mux<AnyPin, 2>;

/// The ADC DMA buffer, seen by the processing task only through the half
/// the DMA has finished.
pub struct DmaBuf(*const u32);

// SAFETY: the pointer is to a 'static buffer; the one task holding it reads
// only the half the DMA has finished (see `process`).
#[allow(unsafe_code)]
unsafe impl Send for DmaBuf {}

/// Write one slot of DAC codes for frequency index `fidx`: the settling
/// pairs lead into the block, which starts at phase 0.
fn fill_dac(buf: &mut [u16], fidx: usize) {
    let osc = Oscillator::from_ftw(ftw(fidx));
    let mut st = OscillatorState {
        phase: (ftw(fidx).wrapping_mul(SETTLE_PAIRS as u32) as i32).wrapping_neg(),
    };
    for b in buf.iter_mut() {
        *b = osc.next_dac(&mut st, design::DAC_BITS, design::DAC_AMPLITUDE_Q15);
    }
}

/// The slot after next reuses the DAC half of the slot just completed.
fn prepare(dac: &mut [u16; 2 * SLOT], st: &Step) {
    let h = (st.done.index % 2) as usize;
    fill_dac(&mut dac[h * SLOT..(h + 1) * SLOT], st.prepare.fidx);
}

/// Pins, DMA, DAC, ADCs, then the timer that starts them all.
fn front_end(dp: &pac::Peripherals, adc_buf: u32, dac_buf: u32) {
    pins::analog(&dp.GPIOA);
    pins::mux_outputs(&dp.GPIOB);
    dma::requests(&dp.DMAMUX);
    dma::adc_channel(
        &dp.DMA1,
        dp.ADC12_COMMON.cdr().as_ptr() as u32,
        adc_buf,
        (2 * SLOT) as u16,
    );
    dma::dac_channel(
        &dp.DMA1,
        dac_buf,
        dp.DAC1.dhr12r1().as_ptr() as u32,
        (2 * SLOT) as u16,
    );
    dac::configure(&dp.DAC1);
    adc::init(dp);
    timer::configure(&dp.TIM6);
    timer::start(&dp.TIM6);
}

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
        adc_buf: DmaBuf,
        dac_buf: &'static mut [u16; 2 * SLOT],
        mux: BoardMux,
        ranges: RangeSwitch,
        seq: Sequencer,
        settings: Settings<'static, 11>,
    }

    #[init(local = [adc: [u32; 2 * SLOT] = [0; 2 * SLOT], dac: [u16; 2 * SLOT] = [2048; 2 * SLOT]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let cause = watchdog::take_reset_cause(&dp.RCC);
        defmt::println!("reset cause: {=str}", cause.as_str());
        watchdog::start(&dp.IWDG);
        clocks::init(&dp);
        let cal: &'static CalTable<11> = &REFERENCE;
        let channels = [Channel::new(cal.rest_capacitance()); CHANNELS];
        // Slots 0 and 1 play their channels at their start frequencies.
        let (seq, slots) = Sequencer::start(|c| channels[c as usize].plan());
        let (first, second) = cx.local.dac.split_at_mut(SLOT);
        fill_dac(first, slots[0].fidx);
        fill_dac(second, slots[1].fidx);
        let mut mux = Mux::new(pins::mux_pins());
        let Ok(_) = mux.select(slots[0].channel);
        let mut ranges = Mux::new(pins::range_pins());
        let Ok(_) = ranges.select(slots[0].range);
        let adc_buf: *const u32 = cx.local.adc.as_ptr();
        let dac_buf: &'static mut [u16; 2 * SLOT] = cx.local.dac;
        front_end(&dp, adc_buf as u32, dac_buf.as_ptr() as u32);
        while !watchdog::ready(&dp.IWDG) {}
        watchdog::feed(&dp.IWDG);
        defmt::println!("start {=u8} channels", CHANNELS as u8);
        (
            Shared { slot: None, channels },
            Local {
                adc_buf: DmaBuf(adc_buf),
                dac_buf,
                mux,
                ranges,
                seq,
                settings: Settings {
                    policy: Policy::DEFAULT,
                    thresholds: Thresholds::DEFAULT,
                    front_ends: Ranging::DEFAULT.front_ends(design::V_GAIN as f32),
                    ranging: Ranging::DEFAULT,
                    calibration: cal,
                    tracker: instrument::channel::tracker(),
                    fixture: dsp_core::fixture::Fixture::NONE,
                },
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
    #[task(binds = DMA1_CH1, priority = 2, shared = [slot, channels], local = [dac_buf, mux, ranges, seq])]
    fn dma_done(mut cx: dma_done::Context) {
        // SAFETY: DMA1 is shared with nothing else after `init`; this task
        // alone reads and clears channel 1's flags.
        #[allow(unsafe_code)]
        let event = dma::take_event(unsafe { &*pac::DMA1::ptr() });
        let expected = (cx.local.seq.next_index() % 2) as usize;
        let (half, lost) = match event {
            Event::Error => {
                // Nothing is fed from here on: the watchdog restarts the
                // board within 100 ms.
                defmt::println!("dma transfer error: acquisition stopped, watchdog reset follows");
                return;
            }
            Event::None => return,
            // Both halves done, or not the half the sequence expects: the
            // interrupt came a slot late. The expected slot is lost (the
            // DMA is overwriting it); skip it in the sequence.
            Event::Overrun => (1 - expected, true),
            e => match e.half() {
                Some(h) => (h, h != expected),
                None => return,
            },
        };
        let seq = &mut *cx.local.seq;
        let dac = &mut *cx.local.dac_buf;
        if lost {
            let st = cx
                .shared
                .channels
                .lock(|c| seq.complete(|ch| c[ch as usize].plan()));
            prepare(dac, &st);
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
        prepare(dac, &st);
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", st.done.index);
        }
    }

    /// Demodulate, correct and log one block, straight from the DMA buffer.
    #[task(priority = 1, shared = [slot, channels], local = [adc_buf, settings])]
    async fn process(mut cx: process::Context) {
        let local = cx.local;
        let Some(Finished { half, slot }) = cx.shared.slot.lock(|s| s.take()) else {
            return;
        };
        let (ch, fidx) = (slot.channel, slot.fidx);
        // SAFETY: the DMA finished this half and writes the other one for
        // the next 5.44 ms; processing takes well under 0.1 ms.
        #[allow(unsafe_code)]
        let words: &[u32] =
            unsafe { core::slice::from_raw_parts(local.adc_buf.0.add(half * SLOT + SETTLE_PAIRS), BLOCK) };
        // Packed ADC1 (low) / ADC2 (high) 12-bit codes are [v, i] pairs;
        // their offset (the bias) is DC, which the demodulator rejects
        // exactly.
        let pairs: &[[i16; 2]; BLOCK] = match bytemuck::cast_slice::<u32, [i16; 2]>(words).try_into() {
            Ok(p) => p,
            Err(_) => return,
        };
        let clipped = pairs
            .iter()
            .any(|&[v, i]| design::on_rail(v as u16) || design::on_rail(i as u16));
        let ph = DEMODULATORS[fidx].block(pairs);
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
            Some(rec) => defmt::println!("{}", rec),
            None => defmt::println!("skip {=u64} {=u8}", slot.block_mid_us(), ch),
        }
        // A block went all the way through: the chain is alive.
        // SAFETY: IWDG_KR is write-only and written by this task alone
        // after `init`.
        #[allow(unsafe_code)]
        watchdog::feed(unsafe { &*pac::IWDG::ptr() });
    }
}
