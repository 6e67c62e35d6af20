//! DAC1 channel 1 (PA4): the excitation, one code per TIM6 trigger, fed by
//! DMA1 channel 2.

use super::pac::dac1;

/// High-frequency interface mode for an AHB above 160 MHz (HFSEL,
/// RM0440 22.7), channel 1 triggered by TIM6 TRGO with DMA requests, enabled.
pub fn configure(dac: &dac1::RegisterBlock) {
    dac.mcr().modify(|_, w| w.hfsel().more160mhz());
    dac.cr().write(|w| {
        w.tsel1()
            .tim6trgo()
            .ten1()
            .set_bit()
            .dmaen1()
            .set_bit()
            .en1()
            .set_bit()
    });
}

/// The array: as [`configure`], triggered by TIM7 TRGO (1 MSa/s).
pub fn configure_array(dac: &dac1::RegisterBlock) {
    dac.mcr().modify(|_, w| w.hfsel().more160mhz());
    dac.cr().write(|w| {
        w.tsel1()
            .tim7trgo()
            .ten1()
            .set_bit()
            .dmaen1()
            .set_bit()
            .en1()
            .set_bit()
    });
}
