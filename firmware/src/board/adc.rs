//! ADC1 (PA0, IN1: the excitation) and ADC2 (PA1, IN2: the current) in dual
//! regular simultaneous mode, one conversion each per TIM6 trigger, packed
//! into one 32-bit word for DMA1 channel 1.
//!
//! Order (RM0440 21.4.6–21.4.9): the common clock (CKMODE) is chosen first,
//! while the ADCs are still disabled; then each leaves deep power-down,
//! its regulator starts (20 µs), it calibrates, and it is enabled.

use super::pac::{adc1, adc12_common};

/// Common: clock HCLK/4 (42.5 MHz, synchronous), dual regular
/// simultaneous mode, packed 12-bit data for DMA (MDMA = 0b10), circular
/// DMA.
#[allow(unsafe_code)]
pub fn common(c: &adc12_common::RegisterBlock) {
    // SAFETY: MDMA = 0b10 is the documented packing for 12- and 10-bit
    // data (RM0440 21.7.2); the PAC gives the 2-bit field no range.
    c.ccr().write(|w| unsafe {
        w.ckmode()
            .sync_div4()
            .dual()
            .dual_r()
            .mdma()
            .bits(0b10)
            .dmacfg()
            .set_bit()
    });
}

/// Out of deep power-down.
pub fn wake(adc: &adc1::RegisterBlock) {
    adc.cr().write(|w| w.deeppwd().clear_bit());
}

/// Start the voltage regulator (then wait t_ADCVREG_STUP = 20 µs),
/// staying out of deep power-down (a write starts from the reset value,
/// which has DEEPPWD set).
pub fn regulator(adc: &adc1::RegisterBlock) {
    adc.cr().write(|w| w.deeppwd().clear_bit().advregen().set_bit());
}

/// The regular sequences: one conversion of ADC1 IN1 and of ADC2 IN2,
/// 24.5 cycles of sampling; the master (ADC1) triggered by TIM6 TRGO
/// (EXTSEL 13) on the rising edge.
#[allow(unsafe_code)]
pub fn sequences(adc1: &adc1::RegisterBlock, adc2: &adc1::RegisterBlock) {
    // SAFETY: channels 1 and 2 exist on ADC1 and ADC2 (0..=18), and EXTSEL
    // 13 is TIM6_TRGO for ADC12 (RM0440 table 163); the PAC gives these
    // fields no range.
    adc1.sqr1().write(|w| unsafe { w.l().set(0).sq1().bits(1) });
    adc2.sqr1().write(|w| unsafe { w.l().set(0).sq1().bits(2) });
    adc1.cfgr()
        .write(|w| unsafe { w.extsel().bits(13).exten().rising_edge() });
    adc1.smpr1().write(|w| w.smp1().cycles24_5());
    adc2.smpr1().write(|w| w.smp2().cycles24_5());
}

/// The whole sequence, ending with ADC1 waiting for its triggers.
#[cfg(target_os = "none")]
pub fn init(dp: &super::pac::Peripherals) {
    let (a1, a2) = (&*dp.ADC1, &*dp.ADC2);
    common(&dp.ADC12_COMMON);
    for adc in [a1, a2] {
        wake(adc);
        regulator(adc);
    }
    // t_ADCVREG_STUP = 20 µs: 25 µs at 170 MHz.
    cortex_m::asm::delay(instrument::design::SYSCLK_HZ / 40_000);
    for adc in [a1, a2] {
        adc.cr().modify(|_, w| w.adcal().set_bit());
        while adc.cr().read().adcal().bit_is_set() {}
    }
    sequences(a1, a2);
    for adc in [a1, a2] {
        adc.isr().write(|w| w.adrdy().clear());
        adc.cr().modify(|_, w| w.aden().set_bit());
        while adc.isr().read().adrdy().bit_is_clear() {}
    }
    a1.cr().modify(|_, w| w.adstart().set_bit());
}
