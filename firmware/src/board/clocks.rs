//! Clocks: HSI16 → PLL (M = 4, N = 85, R = 2) = 170 MHz, voltage range 1
//! in boost mode (required above 150 MHz), 4 flash wait states, and the
//! peripheral clocks the front end uses.

use super::pac::{flash, pwr, rcc};

/// Range 1 boost mode: R1MODE = 0 (RM0440 6.1.5; reset value 1: normal).
pub fn boost(pwr: &pwr::RegisterBlock) {
    pwr.cr5().modify(|_, w| w.r1mode().clear_bit());
}

/// 4 wait states (170 MHz in range 1 boost, RM0440 table 9), prefetch,
/// instruction and data caches.
pub fn flash_wait_states(flash: &flash::RegisterBlock) {
    flash.acr().modify(|_, w| {
        w.latency()
            .wait4()
            .prften()
            .set_bit()
            .icen()
            .set_bit()
            .dcen()
            .set_bit()
    });
}

/// PLL from HSI16: 16 MHz / 4 · 85 / 2 = 170 MHz on R.
pub fn pll(rcc: &rcc::RegisterBlock) {
    rcc.pllcfgr().write(|w| {
        w.pllsrc()
            .hsi16()
            .pllm()
            .div4()
            .plln()
            .div85()
            .pllr()
            .div2()
            .pllren()
            .set_bit()
    });
}

/// AHB at SYSCLK/2: the step before switching to a clock above 80 MHz.
pub fn ahb_half(rcc: &rcc::RegisterBlock) {
    rcc.cfgr().modify(|_, w| w.hpre().div2());
}

/// SYSCLK from the PLL.
pub fn switch_to_pll(rcc: &rcc::RegisterBlock) {
    rcc.cfgr().modify(|_, w| w.sw().pll());
}

/// AHB at SYSCLK: ≥ 1 µs after the switch (RM0440 6.1.5).
pub fn ahb_full(rcc: &rcc::RegisterBlock) {
    rcc.cfgr().modify(|_, w| w.hpre().div1());
}

/// Clocks of DMA1, DMAMUX1, GPIOA, GPIOB, ADC12, DAC1, TIM6 and PWR.
pub fn peripherals(rcc: &rcc::RegisterBlock) {
    rcc.ahb1enr()
        .modify(|_, w| w.dma1en().set_bit().dmamux1en().set_bit());
    rcc.ahb2enr().modify(|_, w| {
        w.gpioaen()
            .set_bit()
            .gpioben()
            .set_bit()
            .adc12en()
            .set_bit()
            .dac1en()
            .set_bit()
    });
    rcc.apb1enr1()
        .modify(|_, w| w.tim6en().set_bit().pwren().set_bit());
}

/// The array's clocks: the single-tone board's ([`peripherals`]) and
/// GPIOC, ADC345, TIM7, SYSCFG (which clocks the op-amps' registers too).
pub fn array_peripherals(rcc: &rcc::RegisterBlock) {
    peripherals(rcc);
    rcc.ahb2enr()
        .modify(|_, w| w.gpiocen().set_bit().adc345en().set_bit());
    rcc.apb1enr1().modify(|_, w| w.tim7en().set_bit());
    rcc.apb2enr().modify(|_, w| w.syscfgen().set_bit());
}

/// The whole sequence (RM0440 6.1.5 and 6.2.7): PWR clock, boost, wait
/// states before the frequency rises, HSI16, PLL, AHB /2 through the
/// switch, ≥ 1 µs, AHB /1.
#[cfg(target_os = "none")]
pub fn system(dp: &super::pac::Peripherals) {
    dp.RCC.apb1enr1().modify(|_, w| w.pwren().set_bit());
    // A clock enable takes effect two cycles later: read it back before
    // touching PWR (RM0440: "delay after an RCC peripheral clock
    // enabling").
    let _ = dp.RCC.apb1enr1().read();
    boost(&dp.PWR);
    flash_wait_states(&dp.FLASH);
    while dp.FLASH.acr().read().latency().bits() != 4 {}
    dp.RCC.cr().modify(|_, w| w.hsion().set_bit());
    while dp.RCC.cr().read().hsirdy().bit_is_clear() {}
    pll(&dp.RCC);
    dp.RCC.cr().modify(|_, w| w.pllon().set_bit());
    while dp.RCC.cr().read().pllrdy().bit_is_clear() {}
    ahb_half(&dp.RCC);
    switch_to_pll(&dp.RCC);
    while !dp.RCC.cfgr().read().sws().is_pll() {}
    // ≥ 1 µs at the 85 MHz AHB: 200 cycles.
    cortex_m::asm::delay(200);
    ahb_full(&dp.RCC);
}
