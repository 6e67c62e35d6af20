//! LPUART1 on PA2 (TX) and PA3 (RX), alternate function 12: the
//! Nucleo-G474RE's STLINK-V3E virtual COM port, which carries the record
//! link's frames to the host over the ST-LINK's USB
//! ([`link::BOARD_BAUD`], 8N1). Its transmit data register is fed by DMA2
//! channel 1, and DMA2 channel 2 moves what it receives (the host's
//! requests) into a ring ([`super::link`]).
//!
//! Order (RM0440 37.5.2, "character transmission procedure"): the kernel
//! clock (PCLK1, 170 MHz: APB1 runs undivided), the pins, the baud rate,
//! DMA on transmit, the FIFO and UE, then TE.

use super::pac::{gpioa, lpuart1, rcc};

/// LPUART1's kernel clock, Hz: PCLK1 (CCIPR.LPUART1SEL = 0b00), the
/// 170 MHz system clock undivided.
pub const KERNEL_HZ: u32 = 170_000_000;

/// LPUART1_BRR for `baud`: 256 · f_ck / baud, rounded (RM0440 37.5.7);
/// the LPUART needs f_ck ≥ 3 · baud and BRR ≥ 0x300.
pub const fn brr(baud: u32) -> u32 {
    let b = baud as u64;
    ((256 * KERNEL_HZ as u64 + b / 2) / b) as u32
}

/// The baud rate `brr` gives, Hz.
pub fn actual_baud(brr: u32) -> f64 {
    256.0 * f64::from(KERNEL_HZ) / f64::from(brr)
}

/// LPUART1_TDR's address: where DMA2 channel 1 writes.
pub fn tdr_address(lpuart: &lpuart1::RegisterBlock) -> u32 {
    lpuart.tdr().as_ptr() as u32
}

/// LPUART1's clock, from PCLK1.
pub fn clocks(rcc: &rcc::RegisterBlock) {
    rcc.apb1enr2().modify(|_, w| w.lpuart1en().set_bit());
    rcc.ccipr().modify(|_, w| w.lpuart1sel().pclk());
}

/// PA2 (TX) and PA3 (RX) on alternate function 12; TX very fast (a bit
/// is 67 ns at 15 MBd), RX pulled up so that an unconnected line idles
/// high.
pub fn pins(gpioa: &gpioa::RegisterBlock) {
    gpioa.afrl().modify(|_, w| w.afrl2().af12().afrl3().af12());
    gpioa.ospeedr().modify(|_, w| w.ospeedr2().very_high_speed());
    gpioa.pupdr().modify(|_, w| w.pupdr3().pull_up());
    gpioa
        .moder()
        .modify(|_, w| w.moder2().alternate().moder3().alternate());
}

/// 8N1 at `baud`, both directions through the DMA, the FIFO on, the
/// LPUART enabled, then the transmitter and the receiver. A receive
/// overrun does not stop the DMA (OVRDIS): a lost byte is a frame the
/// host's CRC and sequence numbers account for.
#[allow(unsafe_code)]
pub fn enable(lpuart: &lpuart1::RegisterBlock, baud: u32) {
    // SAFETY: BRR is a 20-bit field; `brr` of a baud rate the kernel
    // clock can make is in 0x300..=0xFFFFF (asserted by the host tests).
    lpuart.brr().write(|w| unsafe { w.brr().bits(brr(baud)) });
    lpuart
        .cr3()
        .write(|w| w.dmat().enabled().dmar().enabled().ovrdis().set_bit());
    lpuart.cr1().write(|w| w.fifoen().set_bit().ue().enabled());
    lpuart.cr1().modify(|_, w| w.te().enabled().re().enabled());
}

/// LPUART1_RDR's address: where DMA2 channel 2 reads.
pub fn rdr_address(lpuart: &lpuart1::RegisterBlock) -> u32 {
    lpuart.rdr().as_ptr() as u32
}
