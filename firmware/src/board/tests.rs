//! The board's register writes on the host: each `firmware::board` write
//! is applied to a register block in RAM (set to the reset values RM0440
//! gives), and the words are checked against the values RM0440 asks for.
//! This is where the review's findings are held: R1MODE (bit 8, not the
//! reserved bit 0), the AHB /2 step apart from the PLL switch, a 32-bit
//! peripheral side for the DAC's DMA, the DMA error and overrun events.

use super::dma::Event;
use super::{adc, clocks, dac, dma, pac, pins, timer, watchdog};
use std::vec;
use std::vec::Vec;

/// A peripheral's register block in RAM.
struct Fake {
    words: Vec<u32>,
}

#[allow(unsafe_code)]
impl Fake {
    /// 4 KiB of registers, with `reset` (byte offset, value) set.
    fn new(reset: &[(usize, u32)]) -> Self {
        let mut words = vec![0u32; 1024];
        for &(off, v) in reset {
            words[off / 4] = v;
        }
        Self { words }
    }

    /// The block seen as the peripheral `T`.
    fn regs<T>(&mut self) -> &T {
        assert!(std::mem::size_of::<T>() <= 4096);
        // SAFETY: the PAC's register blocks are `repr(C)` arrays of
        // volatile cells over u32 words; the buffer is large enough,
        // aligned for u32 and lives as long as the borrow.
        unsafe { &*(self.words.as_mut_ptr() as *const T) }
    }

    /// The word at byte offset `off`.
    fn at(&self, off: usize) -> u32 {
        // SAFETY: in bounds; written through volatile cells.
        unsafe { self.words.as_ptr().add(off / 4).read_volatile() }
    }
}

#[test]
fn clocks_boost_wait_states_pll_and_the_ahb_step() {
    // PWR_CR5 resets with R1MODE = 1 (normal): boost clears bit 8 alone.
    let mut pwr = Fake::new(&[(0x80, 0x0000_0100)]);
    clocks::boost(pwr.regs::<pac::pwr::RegisterBlock>());
    assert_eq!(pwr.at(0x80), 0x0000_0000);
    // FLASH_ACR (reset 0x600: caches on): 4 wait states, prefetch.
    let mut flash = Fake::new(&[(0x00, 0x0000_0600)]);
    clocks::flash_wait_states(flash.regs::<pac::flash::RegisterBlock>());
    assert_eq!(flash.at(0x00), 4 | 1 << 8 | 1 << 9 | 1 << 10);
    // RCC_PLLCFGR: HSI16 (2), M = 4 (field 3), N = 85, R = 2 (field 0),
    // R output on.
    let mut rcc = Fake::new(&[(0x08, 0x0000_0005), (0x0C, 0x0000_1000)]);
    clocks::pll(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x0C), 2 | 3 << 4 | 85 << 8 | 1 << 24);
    // RCC_CFGR (reset 0x5: HSI selected and in use): /2 first, SW left
    // alone; then the switch with HPRE left alone; then /1.
    clocks::ahb_half(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x08), 0x5 | 0b1000 << 4);
    clocks::switch_to_pll(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x08) & 0xF3, 0b11 | 0b1000 << 4);
    clocks::ahb_full(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x08) & 0xF3, 0b11);
    // Peripheral clocks: DMA1 (0), DMAMUX1 (2); GPIOA (0), GPIOB (1),
    // ADC12 (13), DAC1 (16); TIM6 (4), PWR (28).
    clocks::peripherals(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x48), 1 | 1 << 2);
    assert_eq!(rcc.at(0x4C), 1 | 1 << 1 | 1 << 13 | 1 << 16);
    assert_eq!(rcc.at(0x58), 1 << 4 | 1 << 28);
}

#[test]
fn adcs_dual_simultaneous_on_a_synchronous_clock_triggered_by_tim6() {
    // ADC12_CCR: DUAL = 0b00110 (regular simultaneous), DMACFG circular,
    // MDMA = 0b10 (12-bit packed), CKMODE = 0b11 (HCLK/4 = 42.5 MHz).
    let mut common = Fake::new(&[]);
    adc::common(common.regs::<pac::adc12_common::RegisterBlock>());
    assert_eq!(common.at(0x08), 0b00110 | 1 << 13 | 0b10 << 14 | 0b11 << 16);
    // ADC_CR resets in deep power-down (0x2000_0000).
    let (mut a1, mut a2) = (
        Fake::new(&[(0x08, 0x2000_0000)]),
        Fake::new(&[(0x08, 0x2000_0000)]),
    );
    adc::wake(a1.regs::<pac::adc1::RegisterBlock>());
    assert_eq!(a1.at(0x08), 0);
    adc::regulator(a1.regs::<pac::adc1::RegisterBlock>());
    assert_eq!(a1.at(0x08), 1 << 28);
    adc::sequences(
        a1.regs::<pac::adc1::RegisterBlock>(),
        a2.regs::<pac::adc1::RegisterBlock>(),
    );
    // SQR1: one conversion (L = 0), SQ1 = IN1 / IN2 (bits 6..10).
    assert_eq!((a1.at(0x30), a2.at(0x30)), (1 << 6, 2 << 6));
    // SMPR1: 24.5 cycles (0b011) for IN1 (bits 3..5) / IN2 (bits 6..8).
    assert_eq!((a1.at(0x14), a2.at(0x14)), (0b011 << 3, 0b011 << 6));
    // CFGR: EXTSEL = 13 (TIM6_TRGO), EXTEN = rising; JQDIS at its reset 1.
    assert_eq!(a1.at(0x0C), 13 << 5 | 1 << 10 | 1 << 31);
}

#[test]
fn dma_channels_and_requests() {
    let mut mux = Fake::new(&[]);
    dma::requests(mux.regs::<pac::dmamux::RegisterBlock>());
    assert_eq!((mux.at(0x00), mux.at(0x04)), (5, 6));
    let mut d = Fake::new(&[]);
    let regs = d.regs::<pac::dma1::RegisterBlock>();
    dma::adc_channel(regs, 0x5000_030C, 0x2000_1000, 2176);
    dma::dac_channel(regs, 0x2000_3000, 0x5000_0808, 2176);
    // Channel 1 (CCR at 0x08): EN, TCIE, HTIE, TEIE, CIRC, MINC, 32-bit
    // both sides, peripheral → memory.
    assert_eq!(
        d.at(0x08),
        1 | 1 << 1 | 1 << 2 | 1 << 3 | 1 << 5 | 1 << 7 | 0b10 << 8 | 0b10 << 10
    );
    assert_eq!(
        (d.at(0x0C), d.at(0x10), d.at(0x14)),
        (2176, 0x5000_030C, 0x2000_1000)
    );
    // Channel 2 (CCR at 0x1C): memory → DAC, 16-bit codes written as
    // 32-bit words (PSIZE = 0b10), circular, no interrupts.
    assert_eq!(d.at(0x1C), 1 | 1 << 4 | 1 << 5 | 1 << 7 | 0b10 << 8 | 0b01 << 10);
    assert_eq!(
        (d.at(0x20), d.at(0x24), d.at(0x28)),
        (2176, 0x5000_0808, 0x2000_3000)
    );
    // The interrupt's events: an error first, both halves = a lost slot.
    assert_eq!(Event::from_flags(true, true, false), Event::Error);
    assert_eq!(Event::from_flags(false, true, true), Event::Overrun);
    assert_eq!(Event::from_flags(false, true, false).half(), Some(0));
    assert_eq!(Event::from_flags(false, false, true).half(), Some(1));
    assert_eq!(Event::from_flags(false, false, false), Event::None);
    assert_eq!(Event::Overrun.half(), None);
    // Reading the flags clears channel 1's (CGIF1, IFCR at 0x04).
    let mut d = Fake::new(&[(0x00, 0b1110)]);
    assert_eq!(
        dma::take_event(d.regs::<pac::dma1::RegisterBlock>()),
        Event::Error
    );
    assert_eq!(d.at(0x04), 1);
}

#[test]
fn dac_timer_and_pins() {
    // DAC_CR: EN1, TEN1, TSEL1 = 7 (TIM6_TRGO), DMAEN1; DAC_MCR: HFSEL =
    // 0b10 (AHB above 160 MHz).
    let mut d = Fake::new(&[]);
    dac::configure(d.regs::<pac::dac1::RegisterBlock>());
    assert_eq!(d.at(0x00), 1 | 1 << 1 | 7 << 2 | 1 << 12);
    assert_eq!(d.at(0x3C), 0b10 << 14);
    // TIM6: 170 MHz / (849 + 1) = 200 kHz, TRGO on update (MMS = 0b010).
    assert_eq!(timer::ARR, 849);
    let mut t = Fake::new(&[]);
    timer::configure(t.regs::<pac::tim6::RegisterBlock>());
    assert_eq!((t.at(0x28), t.at(0x2C), t.at(0x04)), (0, 849, 0b010 << 4));
    timer::start(t.regs::<pac::tim6::RegisterBlock>());
    assert_eq!(t.at(0x00), 1);
    // GPIOA (reset 0xABFF_FFFF: all analog but the debug pins): PA0, PA1,
    // PA4 analog, the debug pins untouched.
    let mut a = Fake::new(&[(0x00, 0xABFF_FFFF)]);
    pins::analog(a.regs::<pac::gpioa::RegisterBlock>());
    assert_eq!(a.at(0x00), 0xABFF_FFFF);
    let mut a = Fake::new(&[(0x00, 0)]);
    pins::analog(a.regs::<pac::gpioa::RegisterBlock>());
    assert_eq!(a.at(0x00), 0b11 | 0b11 << 2 | 0b11 << 8);
    // GPIOB (reset 0xFFFF_FEBF): PB0..PB2 and PB5, PB6 outputs (0b01),
    // the rest kept (PB3, PB4: the debug port's JTDO and NJTRST).
    let mut b = Fake::new(&[(0x00, 0xFFFF_FEBF)]);
    pins::mux_outputs(b.regs::<pac::gpiob::RegisterBlock>());
    assert_eq!(
        b.at(0x00),
        0xFFFF_FEBF & !(0x3F | 0x3C00) | 0b01_01_01 | 0b01_01 << 10
    );
}

#[test]
fn watchdog_100_ms_from_lsi_over_32_and_the_reset_cause() {
    let mut iwdg = Fake::new(&[(0x04, 0), (0x08, 0x0FFF)]);
    watchdog::start(iwdg.regs::<pac::iwdg::RegisterBlock>());
    // KR last written with the unlock key after the start key; PR = /32
    // (0b011), RLR = 99 (1 kHz ticks, 100 ms).
    assert_eq!(iwdg.at(0x00), 0x5555);
    assert_eq!(iwdg.at(0x04), 0b011);
    assert_eq!(iwdg.at(0x08), 99);
    watchdog::feed(iwdg.regs::<pac::iwdg::RegisterBlock>());
    assert_eq!(iwdg.at(0x00), 0xAAAA);
    use watchdog::ResetCause as C;
    // RCC_CSR flags (RM0440 §7.4.29): bits 25 OBL, 26 PIN, 27 BOR, 28 SFT,
    // 29 IWDG, 30 WWDG, 31 LPWR. NRST follows every internal reset.
    for (bits, cause) in [
        (1 << 29 | 1 << 26, C::Watchdog),
        (1 << 28 | 1 << 26, C::Software),
        (1 << 27 | 1 << 26, C::PowerOn),
        (1 << 26, C::Pin),
        (1 << 30 | 1 << 26, C::WindowWatchdog),
        (1 << 31 | 1 << 26, C::LowPower),
        (1 << 25 | 1 << 26, C::OptionBytes),
        (0, C::Unknown),
    ] {
        assert_eq!(C::from_csr(bits), cause, "{bits:#x}");
    }
    let mut rcc = Fake::new(&[(0x94, 1 << 29 | 1 << 26)]);
    assert_eq!(
        watchdog::take_reset_cause(rcc.regs::<pac::rcc::RegisterBlock>()),
        C::Watchdog
    );
    assert_ne!(rcc.at(0x94) & (1 << 23), 0, "RMVF set");
}
