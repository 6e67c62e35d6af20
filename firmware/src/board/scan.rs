//! The array's five ADCs ([`instrument::array`]): each scans four inputs
//! per TIM6 trigger (25 kHz), every input 16× oversampled in hardware
//! (the sum of sixteen 12-bit conversions, 0 … 65 520), in independent
//! mode with its own DMA channel. Frame ADC `a` of the instrument is the
//! hardware ADC of [`SCAN_ADCS`]`[a]`.
//!
//! **The pin map** ([`INPUT_PINS`], Nucleo-G474RE, LQFP64). On this
//! package ADC3 reaches three pins, ADC4 three and ADC5 two, four short of
//! what 4 + 4 + 4 + 4 + 1 scan positions need. Three of the G474's
//! op-amps, as unity followers with their outputs routed inside the chip
//! to an ADC ([`super::opamp`]), bring three more pins in: PA1 to ADC3
//! (OPAMP3), PC3 and PB11 to ADC5 (OPAMP5, OPAMP4). The Nucleo's own pins
//! are left alone: PA2/PA3 (the ST-LINK's serial port), PA5 (LD2),
//! PA13/PA14 (SWD), PF0/PF1 (HSE), PC13 (B1), PC14/PC15 (LSE), PB8
//! (BOOT0); PA4 is the DAC's output.
//!
//! **Timing.** The ADC clock is HCLK/4 = 42.5 MHz, synchronous, so the
//! five start on the same clock edge after each trigger. A conversion is
//! 12.5 cycles of sampling and 12.5 of approximation, so one position's
//! sixteen take 9.41 µs ([`instrument::array::SCAN_STEP_S`]) and the
//! four 37.6 µs of the 40 µs instant. The sources are the transimpedance
//! stages' outputs and the followers, both low impedance (tens of Ω):
//! the sampling capacitor (C_ADC ≈ 5 pF) charges through the ADC's own
//! switch, R_ADC ≈ 470–680 Ω on these slow channels (the STM32G474
//! datasheet's ADC characteristics), τ ≤ 3.7 ns, so 12.5 cycles (294 ns)
//! are 80 τ, far beyond the 9 τ that 12 bits need (16 bits: 12 τ).
//!
//! Order (RM0440 21.4.6–21.4.9), as for the single-tone board: the common
//! clocks first, then for each ADC deep power-down off, the regulator
//! (20 µs), calibration, configuration, enable, and ADSTART (armed, it
//! waits for TIM6).

use super::pac::{adc1, adc12_common};
use instrument::array::{ADCS, INPUTS, SCAN};

/// A hardware ADC of the G474.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Adc {
    /// ADC1 (common block ADC12).
    Adc1,
    /// ADC2 (common block ADC12).
    Adc2,
    /// ADC3 (common block ADC345).
    Adc3,
    /// ADC4 (common block ADC345).
    Adc4,
    /// ADC5 (common block ADC345).
    Adc5,
}

impl Adc {
    /// Its DMAMUX request line (RM0440 table 91).
    pub const fn dma_request(self) -> u8 {
        match self {
            Adc::Adc1 => 5,
            Adc::Adc2 => 36,
            Adc::Adc3 => 37,
            Adc::Adc4 => 38,
            Adc::Adc5 => 39,
        }
    }
}

/// Where an input of the array comes in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputPin {
    /// GPIO port letter.
    pub port: char,
    /// Pin number in the port.
    pub pin: u8,
    /// The ADC that converts it.
    pub adc: Adc,
    /// The ADC channel (INx; an op-amp's internal output for a follower).
    pub channel: u8,
    /// The op-amp (3, 4 or 5) following the pin into the ADC, if any.
    pub follower: Option<u8>,
}

const fn direct(port: char, pin: u8, adc: Adc, channel: u8) -> InputPin {
    InputPin {
        port,
        pin,
        adc,
        channel,
        follower: None,
    }
}

const fn followed(port: char, pin: u8, adc: Adc, channel: u8, opamp: u8) -> InputPin {
    InputPin {
        port,
        pin,
        adc,
        channel,
        follower: Some(opamp),
    }
}

/// Every input of the array, by [`instrument::array`] input number (0 the
/// excitation, 1–16 sensors 0–15, 17–19 spare): its pin and converter.
/// Input 19 has no pin of its own (ADC4 reaches none more on the LQFP64)
/// and converts PB15 again.
pub const INPUT_PINS: [InputPin; INPUTS] = [
    // ADC1: the excitation, sensors 0–2.
    direct('A', 0, Adc::Adc1, 1),
    direct('C', 0, Adc::Adc1, 6),
    direct('C', 1, Adc::Adc1, 7),
    direct('C', 2, Adc::Adc1, 8),
    // ADC2: sensors 3–6.
    direct('A', 6, Adc::Adc2, 3),
    direct('A', 7, Adc::Adc2, 4),
    direct('C', 4, Adc::Adc2, 5),
    direct('C', 5, Adc::Adc2, 11),
    // ADC3: sensors 7–10 (PA1 through OPAMP3, VINP2, on ADC3 IN13).
    direct('B', 0, Adc::Adc3, 12),
    direct('B', 1, Adc::Adc3, 1),
    direct('B', 13, Adc::Adc3, 5),
    followed('A', 1, Adc::Adc3, 13, 3),
    // ADC5: sensors 11–14 (PC3 through OPAMP5 on IN3, PB11 through
    // OPAMP4 on IN5, both VINP2).
    direct('A', 8, Adc::Adc5, 1),
    direct('A', 9, Adc::Adc5, 2),
    followed('C', 3, Adc::Adc5, 3, 5),
    followed('B', 11, Adc::Adc5, 5, 4),
    // ADC4: sensor 15, spares 17 and 18, and 18 again.
    direct('B', 12, Adc::Adc4, 3),
    direct('B', 14, Adc::Adc4, 4),
    direct('B', 15, Adc::Adc4, 5),
    direct('B', 15, Adc::Adc4, 5),
];

/// The hardware ADC of each frame ADC, in DMA channel order (frame ADC a
/// on DMA1 channel a + 1).
pub const SCAN_ADCS: [Adc; ADCS] = [Adc::Adc1, Adc::Adc2, Adc::Adc3, Adc::Adc5, Adc::Adc4];

/// Frame ADC a's scan: the channel at each position.
pub const fn sequence(a: usize) -> [u8; SCAN] {
    let mut out = [0; SCAN];
    let mut j = 0;
    while j < SCAN {
        out[j] = INPUT_PINS[a * SCAN + j].channel;
        j += 1;
    }
    out
}

/// SMPR1 and SMPR2 words for 12.5 cycles (0b010) of sampling on each of
/// `channels` (three bits per channel: 0–9 in SMPR1, 10–18 in SMPR2).
pub const fn sample_times(channels: [u8; SCAN]) -> (u32, u32) {
    let (mut s1, mut s2) = (0u32, 0u32);
    let mut j = 0;
    while j < SCAN {
        let ch = channels[j] as u32;
        if ch < 10 {
            s1 |= 0b010 << (3 * ch);
        } else {
            s2 |= 0b010 << (3 * (ch - 10));
        }
        j += 1;
    }
    (s1, s2)
}

/// A common block (ADC12 or ADC345): independent mode, the synchronous
/// clock HCLK/4 (42.5 MHz).
pub fn common(c: &adc12_common::RegisterBlock) {
    c.ccr().write(|w| w.ckmode().sync_div4().dual().independent());
}

/// One ADC's scan of `channels`: four conversions per trigger (TIM6 TRGO,
/// EXTSEL 13 on ADC12 and ADC345 alike, rising edge), 12.5 cycles of
/// sampling each, each 16× oversampled with no shift (16-bit sums, all
/// sixteen after one trigger: TROVS = 0, ROVSM = 0), 12 bits, right
/// aligned, DMA in circular mode.
#[allow(unsafe_code)]
pub fn configure(adc: &adc1::RegisterBlock, channels: [u8; SCAN]) {
    // SAFETY: the channels of INPUT_PINS exist on their ADC (0..=18), and
    // EXTSEL 13 is TIM6_TRGO for every ADC of the G474 (RM0440 tables 163
    // and 164); the PAC gives these fields no range. SMPR words hold only
    // the 3-bit fields of channels 0..=18.
    adc.sqr1().write(|w| unsafe {
        w.l()
            .set(SCAN as u8 - 1)
            .sq1()
            .bits(channels[0])
            .sq2()
            .bits(channels[1])
            .sq3()
            .bits(channels[2])
            .sq4()
            .bits(channels[3])
    });
    let (s1, s2) = sample_times(channels);
    adc.smpr1().write(|w| unsafe { w.bits(s1) });
    adc.smpr2().write(|w| unsafe { w.bits(s2) });
    adc.cfgr().write(|w| unsafe {
        w.extsel()
            .bits(13)
            .exten()
            .rising_edge()
            .dmaen()
            .set_bit()
            .dmacfg()
            .set_bit()
    });
    adc.cfgr2().write(|w| {
        w.rovse()
            .enabled()
            .ovsr()
            .os16()
            .ovss()
            .no_shift()
            .trovs()
            .automatic()
            .rovsm()
            .continued()
    });
}

/// `[ADC1, …, ADC5]` in frame order ([`SCAN_ADCS`]).
fn frame_order(by_number: [&adc1::RegisterBlock; 5]) -> [&adc1::RegisterBlock; ADCS] {
    SCAN_ADCS.map(|adc| by_number[adc as usize])
}

/// The five ADCs' register blocks, in frame order.
#[cfg(target_os = "none")]
pub fn blocks(dp: &super::pac::Peripherals) -> [&adc1::RegisterBlock; ADCS] {
    frame_order([&dp.ADC1, &dp.ADC2, &dp.ADC3, &dp.ADC4, &dp.ADC5])
}

/// The five ADCs, owned by the task that reads their overrun flags.
pub struct Adcs {
    adc1: super::pac::ADC1,
    adc2: super::pac::ADC2,
    adc3: super::pac::ADC3,
    adc4: super::pac::ADC4,
    adc5: super::pac::ADC5,
}

impl Adcs {
    /// Take the five ADCs.
    pub fn new(
        adc1: super::pac::ADC1,
        adc2: super::pac::ADC2,
        adc3: super::pac::ADC3,
        adc4: super::pac::ADC4,
        adc5: super::pac::ADC5,
    ) -> Self {
        Self {
            adc1,
            adc2,
            adc3,
            adc4,
            adc5,
        }
    }

    /// Their register blocks, in frame order.
    pub fn blocks(&self) -> [&adc1::RegisterBlock; ADCS] {
        frame_order([&self.adc1, &self.adc2, &self.adc3, &self.adc4, &self.adc5])
    }
}

/// The whole sequence, ending with every ADC armed for TIM6.
#[cfg(target_os = "none")]
pub fn init(dp: &super::pac::Peripherals) {
    use super::adc::{regulator, wake};
    common(&dp.ADC12_COMMON);
    common(&dp.ADC345_COMMON);
    let adcs = blocks(dp);
    for adc in adcs {
        wake(adc);
        regulator(adc);
    }
    // t_ADCVREG_STUP = 20 µs: 25 µs at 170 MHz.
    cortex_m::asm::delay(instrument::design::SYSCLK_HZ / 40_000);
    for adc in adcs {
        adc.cr().modify(|_, w| w.adcal().set_bit());
        while adc.cr().read().adcal().bit_is_set() {}
    }
    for (a, adc) in adcs.iter().enumerate() {
        configure(adc, sequence(a));
        adc.isr().write(|w| w.adrdy().clear());
        adc.cr().modify(|_, w| w.aden().set_bit());
        while adc.isr().read().adrdy().bit_is_clear() {}
    }
    for adc in adcs {
        adc.cr().modify(|_, w| w.adstart().set_bit());
    }
}

/// Read and clear every ADC's overrun flag: true if one lost a result
/// (the DMA fell behind, and that ADC's stream is no longer aligned with
/// the others).
pub fn take_overrun(adcs: &Adcs) -> bool {
    let mut any = false;
    for adc in adcs.blocks() {
        if adc.isr().read().ovr().bit_is_set() {
            adc.isr().write(|w| w.ovr().clear());
            any = true;
        }
    }
    any
}
