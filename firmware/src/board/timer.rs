//! TIM6: the sample clock, an update (TRGO) every 1/[`SAMPLE_RATE`].

use super::pac::tim6;
use instrument::design::{SAMPLE_RATE, SYSCLK_HZ};

/// Auto-reload value: SYSCLK / SAMPLE_RATE − 1 (849 for 170 MHz and
/// 200 kSa/s).
pub const ARR: u32 = SYSCLK_HZ / SAMPLE_RATE - 1;

/// Prescaler 1, auto-reload [`ARR`], TRGO on update.
pub fn configure(tim: &tim6::RegisterBlock) {
    tim.psc().write(|w| w.psc().set(0));
    tim.arr().write(|w| w.arr().set(ARR));
    tim.cr2().write(|w| w.mms().update());
}

/// Start counting.
pub fn start(tim: &tim6::RegisterBlock) {
    tim.cr1().modify(|_, w| w.cen().set_bit());
}
