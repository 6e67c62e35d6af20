//! DAC1 channel 1 (PA4): the excitation, one code per trigger (TIM6; the
//! array's TIM7), fed by DMA1.

use super::pac::dac1;

/// High-frequency interface mode for an AHB above 160 MHz (HFSEL,
/// RM0440 22.7), channel 1 triggered by TIM6 TRGO with DMA requests, enabled.
pub fn configure(dac: &dac1::RegisterBlock) {
    dac.cr().write(|w| w.tsel1().tim6trgo());
    enable(dac);
}

/// The array: as [`configure`], triggered by TIM7 TRGO (1 MSa/s).
pub fn configure_array(dac: &dac1::RegisterBlock) {
    dac.cr().write(|w| w.tsel1().tim7trgo());
    enable(dac);
}

/// HFSEL, then the trigger chosen (written while EN1 = 0), DMA requests
/// and the channel on.
fn enable(dac: &dac1::RegisterBlock) {
    dac.mcr().modify(|_, w| w.hfsel().more160mhz());
    dac.cr()
        .modify(|_, w| w.ten1().set_bit().dmaen1().set_bit().en1().set_bit());
}
