//! TIM6: the sample clock, an update (TRGO) every 1/[`SAMPLE_RATE`]
//! (the array: TIM6 at 25 kHz for the ADCs, TIM7 at 1 MHz for the DAC).

use super::pac::tim6;
use instrument::design::{SAMPLE_RATE, SYSCLK_HZ};

/// Auto-reload value: SYSCLK / SAMPLE_RATE − 1 (849 for 170 MHz and
/// 200 kSa/s).
pub const ARR: u32 = SYSCLK_HZ / SAMPLE_RATE - 1;

/// Auto-reload value for an update every 1/`rate_hz` at SYSCLK.
pub const fn arr_for(rate_hz: u32) -> u32 {
    SYSCLK_HZ / rate_hz - 1
}

/// Prescaler 1, auto-reload [`ARR`], TRGO on update.
pub fn configure(tim: &tim6::RegisterBlock) {
    configure_arr(tim, ARR);
}

/// Prescaler 1, auto-reload `arr`, TRGO on update (TIM6 or TIM7).
pub fn configure_arr(tim: &tim6::RegisterBlock, arr: u32) {
    tim.psc().write(|w| w.psc().set(0));
    tim.arr().write(|w| w.arr().set(arr));
    tim.cr2().write(|w| w.mms().update());
}

/// Start counting.
pub fn start(tim: &tim6::RegisterBlock) {
    tim.cr1().modify(|_, w| w.cen().set_bit());
}
