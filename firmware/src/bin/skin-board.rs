//! The sensing-skin firmware on the STM32G474 (Nucleo-G474RE).
//!
//! Analog front end it expects (see the README):
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
//! full transfer interrupts of channel 1 are the `dma_done` hardware task:
//! it selects the multiplexer channel for the slot that just began, hands
//! the finished slot to the `process` software task, and writes the DAC
//! waveform for the slot after next.
#![no_std]
#![no_main]

use dsp_core::demod::FrontEnd;
use dsp_core::osc::{Oscillator, OscillatorState};
use instrument::calib::{CalTable, REFERENCE};
use instrument::channel::{Channel, Settings};
use instrument::config::{ftw, BLOCK, CHANNELS, DEMODULATORS, SETTLE_PAIRS, SLOT_PAIRS};
use instrument::faults::Thresholds;
use instrument::mux::Mux;
use instrument::policy::Policy;
use instrument::sequencer::{Sequencer, Slot};
use stm32g4::stm32g474 as pac;
// Logging, panics and faults: `firmware::board`, linked with the library.
use firmware as _;

/// Pairs per slot: settling, then the block.
const SLOT: usize = SLOT_PAIRS;
/// Excitation amplitude: 1 V of the DAC's ±1.65 V, Q15.
const AMPLITUDE: i16 = 19_859;

/// Multiplexer address line on GPIOB pin `N`.
pub struct PinB<const N: u8>;

impl<const N: u8> embedded_hal::digital::ErrorType for PinB<N> {
    type Error = core::convert::Infallible;
}

impl<const N: u8> embedded_hal::digital::OutputPin for PinB<N> {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        // SAFETY: BSRR is write-only and atomic per bit; this pin is owned
        // by the multiplexer alone.
        #[allow(unsafe_code)]
        unsafe {
            (*pac::GPIOB::ptr()).bsrr().write(|w| w.bits(1 << (N + 16)));
        }
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        #[allow(unsafe_code)]
        // SAFETY: as above.
        unsafe {
            (*pac::GPIOB::ptr()).bsrr().write(|w| w.bits(1 << N));
        }
        Ok(())
    }
}

/// The multiplexer on PB0..PB2.
pub type BoardMux = Mux<AnyPin, 3>;

/// One of the three address lines.
pub enum AnyPin {
    /// PB0
    A0(PinB<0>),
    /// PB1
    A1(PinB<1>),
    /// PB2
    A2(PinB<2>),
}

impl embedded_hal::digital::ErrorType for AnyPin {
    type Error = core::convert::Infallible;
}

impl embedded_hal::digital::OutputPin for AnyPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        match self {
            AnyPin::A0(p) => p.set_low(),
            AnyPin::A1(p) => p.set_low(),
            AnyPin::A2(p) => p.set_low(),
        }
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        match self {
            AnyPin::A0(p) => p.set_high(),
            AnyPin::A1(p) => p.set_high(),
            AnyPin::A2(p) => p.set_high(),
        }
    }
}

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
        *b = osc.next_dac(&mut st, 12, AMPLITUDE);
    }
}

/// Clocks: HSI16 → PLL (M = 4, N = 85, R = 2) = 170 MHz, range 1 boost,
/// 4 flash wait states; ADC12 on the system clock (divided by 4 in the ADC).
#[allow(unsafe_code)]
fn clocks(dp: &pac::Peripherals) {
    // SAFETY (all register writes below): values from RM0440 for the
    // documented configuration; each register is written once at start-up
    // before any peripheral uses it.
    unsafe {
        dp.RCC.apb1enr1().modify(|r, w| w.bits(r.bits() | 1 << 28)); // PWREN
        dp.PWR.cr5().modify(|r, w| w.bits(r.bits() & !1)); // R1MODE = 0: boost
        dp.FLASH
            .acr()
            .modify(|r, w| w.bits((r.bits() & !0xf) | 4 | 1 << 8 | 1 << 9 | 1 << 10));
        dp.RCC.cr().modify(|r, w| w.bits(r.bits() | 1 << 8)); // HSION
        while dp.RCC.cr().read().bits() & 1 << 10 == 0 {}
        // PLLSRC = HSI16 (2), PLLM = 4 − 1, PLLN = 85, PLLR = /2, PLLREN.
        dp.RCC.pllcfgr().write(|w| w.bits(2 | 3 << 4 | 85 << 8 | 1 << 24));
        dp.RCC.cr().modify(|r, w| w.bits(r.bits() | 1 << 24)); // PLLON
        while dp.RCC.cr().read().bits() & 1 << 25 == 0 {}
        // AHB /2 through the switch (RM0440 6.2.7), then /1.
        dp.RCC
            .cfgr()
            .modify(|r, w| w.bits((r.bits() & !(0xf << 4 | 3)) | 8 << 4 | 3));
        while (dp.RCC.cfgr().read().bits() >> 2) & 3 != 3 {}
        cortex_m::asm::delay(200);
        dp.RCC.cfgr().modify(|r, w| w.bits(r.bits() & !(0xf << 4)));
        // Clocks of GPIOA/B, ADC12, DAC1, DMA1, DMAMUX, TIM6.
        dp.RCC.ahb1enr().modify(|r, w| w.bits(r.bits() | 1 | 1 << 2)); // DMA1, DMAMUX1
        dp.RCC
            .ahb2enr()
            .modify(|r, w| w.bits(r.bits() | 1 | 1 << 1 | 1 << 13 | 1 << 16)); // GPIOA, GPIOB, ADC12, DAC1
        dp.RCC.apb1enr1().modify(|r, w| w.bits(r.bits() | 1 << 4)); // TIM6
        dp.RCC
            .ccipr()
            .modify(|r, w| w.bits((r.bits() & !(3 << 28)) | 2 << 28)); // ADC12SEL = SYSCLK
    }
}

/// Analog pins, multiplexer outputs, DAC, ADCs (dual mode), DMA, TIM6.
#[allow(unsafe_code)]
fn front_end(dp: &pac::Peripherals, adc_buf: u32, dac_buf: u32) {
    // SAFETY: start-up configuration per RM0440. The DMA buffers (at the
    // addresses given) are 'static; from here on the DMA writes the ADC
    // buffer and reads the DAC buffer, and the tasks only read the ADC half
    // the DMA has finished and write the DAC half it is not reading.
    unsafe {
        // PA0, PA1, PA4 analog; PB0..PB2 outputs.
        dp.GPIOA
            .moder()
            .modify(|r, w| w.bits(r.bits() | 3 | 3 << 2 | 3 << 8));
        dp.GPIOB.moder().modify(|r, w| w.bits((r.bits() & !0x3f) | 0x15));
        // DMAMUX: channel 0 (DMA1 ch1) ← ADC1 (5), channel 1 (DMA1 ch2) ← DAC1_CH1 (6).
        dp.DMAMUX.ccr(0).write(|w| w.bits(5));
        dp.DMAMUX.ccr(1).write(|w| w.bits(6));
        // DMA1 ch1: ADC12 common data (32-bit) → adc_buf, circular, HT + TC interrupts.
        let adc_cdr = dp.ADC12_COMMON.cdr().as_ptr() as u32;
        dp.DMA1.ch1().par().write(|w| w.bits(adc_cdr));
        dp.DMA1.ch1().mar().write(|w| w.bits(adc_buf));
        dp.DMA1.ch1().ndtr().write(|w| w.bits((2 * SLOT) as u32));
        dp.DMA1
            .ch1()
            .cr()
            .write(|w| w.bits(1 << 1 | 1 << 2 | 1 << 5 | 1 << 7 | 2 << 8 | 2 << 10 | 1));
        // DMA1 ch2: dac_buf → DAC1 DHR12R1 (16-bit), circular, memory to peripheral.
        dp.DMA1
            .ch2()
            .par()
            .write(|w| w.bits(dp.DAC1.dhr12r1().as_ptr() as u32));
        dp.DMA1.ch2().mar().write(|w| w.bits(dac_buf));
        dp.DMA1.ch2().ndtr().write(|w| w.bits((2 * SLOT) as u32));
        dp.DMA1
            .ch2()
            .cr()
            .write(|w| w.bits(1 << 4 | 1 << 5 | 1 << 7 | 1 << 8 | 1 << 10 | 1));
        // DAC1 ch1: high-frequency interface mode (> 160 MHz), trigger TIM6 TRGO (7), DMA.
        dp.DAC1
            .mcr()
            .modify(|r, w| w.bits((r.bits() & !(3 << 14)) | 2 << 14));
        dp.DAC1.cr().write(|w| w.bits(1 | 1 << 1 | 7 << 2 | 1 << 12));
        // ADC1 and ADC2: out of deep power-down, regulator on, calibrate, enable.
        for adc in [&*dp.ADC1, &*dp.ADC2] {
            adc.cr().write(|w| w.bits(0));
            adc.cr().write(|w| w.bits(1 << 28));
        }
        cortex_m::asm::delay(170 * 25); // t_ADCVREG_STUP = 20 µs
        for adc in [&*dp.ADC1, &*dp.ADC2] {
            adc.cr().modify(|r, w| w.bits(r.bits() | 1 << 31));
            while adc.cr().read().bits() & 1 << 31 != 0 {}
        }
        // Common: regular simultaneous (0b00110), 12-bit packed DMA (MDMA = 2),
        // circular DMA, clock HCLK/4 (42.5 MHz).
        dp.ADC12_COMMON
            .ccr()
            .write(|w| w.bits(0b00110 | 1 << 13 | 2 << 14 | 3 << 16));
        // Sequences: ADC1 IN1, ADC2 IN2, one conversion each, 24.5-cycle sampling.
        dp.ADC1.sqr1().write(|w| w.bits(1 << 6));
        dp.ADC2.sqr1().write(|w| w.bits(2 << 6));
        dp.ADC1.smpr1().write(|w| w.bits(3 << 3));
        dp.ADC2.smpr1().write(|w| w.bits(3 << 6));
        // Master ADC1: external trigger 13 (TIM6 TRGO), rising edge.
        dp.ADC1.cfgr().write(|w| w.bits(13 << 5 | 1 << 10));
        for adc in [&*dp.ADC1, &*dp.ADC2] {
            adc.isr().write(|w| w.bits(1));
            adc.cr().modify(|r, w| w.bits(r.bits() | 1));
            while adc.isr().read().bits() & 1 == 0 {}
        }
        dp.ADC1.cr().modify(|r, w| w.bits(r.bits() | 1 << 2)); // ADSTART (waits for triggers)
                                                               // TIM6: 170 MHz / 850 = 200 kHz, TRGO on update.
        dp.TIM6.psc().write(|w| w.bits(0));
        dp.TIM6.arr().write(|w| w.bits(849));
        dp.TIM6.cr2().write(|w| w.bits(2 << 4));
        dp.TIM6.cr1().write(|w| w.bits(1));
    }
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
        seq: Sequencer,
        settings: Settings<'static, 11>,
    }

    #[init(local = [adc: [u32; 2 * SLOT] = [0; 2 * SLOT], dac: [u16; 2 * SLOT] = [2048; 2 * SLOT]])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        clocks(&dp);
        let cal: &'static CalTable<11> = &REFERENCE;
        let channels = [Channel::new(cal.rest_capacitance()); CHANNELS];
        // Slots 0 and 1 play their channels at their start frequencies.
        let (seq, slots) = Sequencer::start(|c| channels[c as usize].freq_index());
        let (first, second) = cx.local.dac.split_at_mut(SLOT);
        // (reborrowed below as dac_buf once filled)
        fill_dac(first, slots[0].fidx);
        fill_dac(second, slots[1].fidx);
        let mut mux = Mux::new([AnyPin::A0(PinB), AnyPin::A1(PinB), AnyPin::A2(PinB)]);
        let Ok(_) = mux.select(slots[0].channel);
        let adc_buf: *const u32 = cx.local.adc.as_ptr();
        let dac_buf: &'static mut [u16; 2 * SLOT] = cx.local.dac;
        front_end(&dp, adc_buf as u32, dac_buf.as_ptr() as u32);
        defmt::println!("start {=u8} channels", CHANNELS as u8);
        (
            Shared { slot: None, channels },
            Local {
                adc_buf: DmaBuf(adc_buf),
                dac_buf,
                mux,
                seq,
                settings: Settings {
                    policy: Policy::DEFAULT,
                    thresholds: Thresholds::DEFAULT,
                    front_end: FrontEnd::transimpedance(100e3, true),
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

    /// DMA half/full transfer: slot `k` is complete and slot `k + 1` begins
    /// ([`instrument::sequencer`]).
    #[task(binds = DMA1_CH1, priority = 2, shared = [slot, channels], local = [dac_buf, mux, seq])]
    fn dma_done(mut cx: dma_done::Context) {
        // SAFETY: reading and clearing DMA1's channel-1 flags only.
        #[allow(unsafe_code)]
        let half = unsafe {
            let dma = &*pac::DMA1::ptr();
            let isr = dma.isr().read().bits();
            dma.ifcr().write(|w| w.bits(1));
            usize::from(isr & 1 << 1 != 0) // TCIF1: the second half is done
        };
        let seq = &mut *cx.local.seq;
        let step = cx
            .shared
            .channels
            .lock(|c| seq.complete(|ch| c[ch as usize].freq_index()));
        // The slot that begins now: select its channel (within its settling).
        let Ok(_) = cx.local.mux.select(step.select);
        // Hand the finished slot (in DMA half `half`) to the processing task.
        cx.shared.slot.lock(|s| {
            *s = Some(Finished {
                half,
                slot: step.done,
            })
        });
        // The slot after next reuses this half of the DAC buffer.
        fill_dac(
            &mut cx.local.dac_buf[half * SLOT..(half + 1) * SLOT],
            step.prepare.fidx,
        );
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", step.done.index);
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
        // their 2048 offset is DC, which the demodulator rejects exactly.
        let pairs: &[[i16; 2]; BLOCK] = match bytemuck::cast_slice::<u32, [i16; 2]>(words).try_into() {
            Ok(p) => p,
            Err(_) => return,
        };
        let clipped = pairs
            .iter()
            .any(|&[v, i]| v <= 0 || v >= 4095 || i <= 0 || i >= 4095);
        let ph = DEMODULATORS[fidx].block(pairs);
        let settings = &*local.settings;
        let rec = cx.shared.channels.lock(|c| {
            let channel = &mut c[ch as usize];
            if channel.freq_index() != fidx {
                // Played at another frequency than the policy now wants:
                // the policy switched since; skip, the next slot catches up.
                return None;
            }
            Some(channel.process(settings, ch, slot.block_mid_us(), &ph, clipped))
        });
        match rec {
            Some(rec) => defmt::println!("{}", rec),
            None => defmt::println!("skip {=u64} {=u8}", slot.block_mid_us(), ch),
        }
    }
}
