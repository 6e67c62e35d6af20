//! DAC1 channel 1 (PA4): the excitation, one code per trigger (TIM6; the
//! array's TIM7), fed by DMA1.

use super::pac::{dac1, dma1};

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

/// Has the excitation stopped since the last call? Either the DAC's DMA
/// underrun (DAC_SR.DMAUDR1, bit 13: a trigger came before its request
/// was served; the DAC then stops asking, RM0440 22.4.9) or a transfer
/// error of its DMA channel `c` (0-based; DMA_ISR.TEIF, bit 4c + 3: the
/// channel disabled itself). Both flags are cleared (DMAUDR1 by writing
/// 1, TEIF by CTEIF). Watched from the acquisition's interrupt: with the
/// excitation stopped every block would read OPEN, so the board stops
/// feeding its watchdog and restarts, as for an ADC transfer error.
#[allow(unsafe_code)]
pub fn excitation_stopped(dac: &dac1::RegisterBlock, dma: &dma1::RegisterBlock, c: usize) -> bool {
    let underrun = dac.sr().read().dmaudr1().bit_is_set();
    if underrun {
        dac.sr().write(|w| w.dmaudr1().set_bit());
    }
    let teif = 1u32 << (4 * c + 3);
    let error = dma.isr().read().bits() & teif != 0;
    if error {
        // SAFETY: CTEIFc is bit 4c + 3 of the write-only IFCR (c < 8).
        dma.ifcr().write(|w| unsafe { w.bits(teif) });
    }
    underrun || error
}
