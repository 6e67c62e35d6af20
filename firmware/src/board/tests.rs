//! The board's register writes on the host: each `firmware::board` write
//! is applied to a register block in RAM (set to the reset values RM0440
//! gives), and the words are checked against the values RM0440 asks for.
//! This is where the review's findings are held: R1MODE (bit 8, not the
//! reserved bit 0), the AHB /2 step apart from the PLL switch, a 32-bit
//! peripheral side for the DAC's DMA, the DMA error and overrun events.

use super::dma::Event;
use super::scan::{Adc, INPUT_PINS, SCAN_ADCS};
use super::{adc, clocks, dac, dma, flash, link, lpuart, opamp, pac, pins, scan, timer, watchdog};
use std::format;
use std::string::String;
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
    dma::dac_channel(regs, 0x2000_3000, 0x5000_0808, 544);
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
    // 32-bit words (PSIZE = 0b10), circular, with TCIE, HTIE, TEIE (the
    // ring's refills).
    assert_eq!(
        d.at(0x1C),
        1 | 1 << 1 | 1 << 2 | 1 << 3 | 1 << 4 | 1 << 5 | 1 << 7 | 0b10 << 8 | 0b01 << 10
    );
    assert_eq!(
        (d.at(0x20), d.at(0x24), d.at(0x28)),
        (544, 0x5000_0808, 0x2000_3000)
    );
    // The interrupt's events: an error first, both halves = a lost slot.
    assert_eq!(Event::from_flags(true, true, false), Event::Error);
    assert_eq!(Event::from_flags(false, true, true), Event::Overrun);
    assert_eq!(Event::from_flags(false, true, false).half(), Some(0));
    assert_eq!(Event::from_flags(false, false, true).half(), Some(1));
    assert_eq!(Event::from_flags(false, false, false), Event::None);
    assert_eq!(Event::Overrun.half(), None);
}

#[test]
fn a_completion_names_the_finished_half_and_a_lost_one() {
    use super::dma::Completion::{self, Done};
    for expected in [0, 1] {
        let other = 1 - expected;
        let events = [Event::FirstHalf, Event::SecondHalf];
        assert_eq!(
            events[expected].completion(expected),
            Done {
                half: expected,
                lost: false
            }
        );
        // The other half's interrupt: the expected one was skipped.
        assert_eq!(
            events[other].completion(expected),
            Done {
                half: other,
                lost: true
            }
        );
        // Both flags set: the expected half is being overwritten.
        assert_eq!(
            Event::Overrun.completion(expected),
            Done {
                half: other,
                lost: true
            }
        );
        assert_eq!(Event::Error.completion(expected), Completion::Error);
        assert_eq!(Event::None.completion(expected), Completion::Nothing);
    }
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

#[test]
fn the_arrays_pin_map_is_realisable_on_the_nucleo() {
    use instrument::array::{adc_position, input_of, INPUTS, SENSORS, VOLTAGE_INPUT};
    // Each frame ADC's four positions are one hardware ADC, the one
    // SCAN_ADCS names; the five are distinct.
    for (i, p) in INPUT_PINS.iter().enumerate() {
        assert_eq!(p.adc, SCAN_ADCS[adc_position(i).0], "input {i}");
    }
    for (a, adc) in SCAN_ADCS.iter().enumerate() {
        assert!(!SCAN_ADCS[..a].contains(adc), "{adc:?} twice");
    }
    // The excitation and the sixteen sensors on distinct pins; the
    // spares too, but for input 19, which repeats 18.
    let used: Vec<_> = (0..INPUTS - 1)
        .map(|i| (INPUT_PINS[i].port, INPUT_PINS[i].pin))
        .collect();
    for (i, p) in used.iter().enumerate() {
        assert!(!used[..i].contains(p), "input {i} shares {p:?}");
    }
    assert_eq!(INPUT_PINS[19], INPUT_PINS[18]);
    // None of the Nucleo's own pins, nor the DAC's output.
    let taken = [
        ('A', 2),
        ('A', 3),
        ('A', 4),
        ('A', 5),
        ('A', 13),
        ('A', 14),
        ('A', 15),
        ('B', 3),
        ('B', 4),
        ('B', 8),
        ('C', 13),
        ('C', 14),
        ('C', 15),
        ('F', 0),
        ('F', 1),
    ];
    for p in &used {
        assert!(!taken.contains(p), "{p:?} is the Nucleo's");
    }
    // Each pin reaches its channel on this package (embassy's
    // stm32-data for STM32G474RE; the followers: RM0440's OPAMP
    // connections, VINP2 and the internal output to the ADC).
    let adc_pins: &[(Adc, char, u8, u8)] = &[
        (Adc::Adc1, 'A', 0, 1),
        (Adc::Adc1, 'C', 0, 6),
        (Adc::Adc1, 'C', 1, 7),
        (Adc::Adc1, 'C', 2, 8),
        (Adc::Adc2, 'A', 6, 3),
        (Adc::Adc2, 'A', 7, 4),
        (Adc::Adc2, 'C', 4, 5),
        (Adc::Adc2, 'C', 5, 11),
        (Adc::Adc3, 'B', 0, 12),
        (Adc::Adc3, 'B', 1, 1),
        (Adc::Adc3, 'B', 13, 5),
        (Adc::Adc4, 'B', 12, 3),
        (Adc::Adc4, 'B', 14, 4),
        (Adc::Adc4, 'B', 15, 5),
        (Adc::Adc5, 'A', 8, 1),
        (Adc::Adc5, 'A', 9, 2),
    ];
    // (op-amp, its VINP2 pin, ADC, the internal channel).
    let followers: &[(u8, char, u8, Adc, u8)] = &[
        (3, 'A', 1, Adc::Adc3, 13),
        (4, 'B', 11, Adc::Adc5, 5),
        (5, 'C', 3, Adc::Adc5, 3),
    ];
    for p in INPUT_PINS {
        match p.follower {
            None => assert!(adc_pins.contains(&(p.adc, p.port, p.pin, p.channel)), "{p:?}"),
            Some(n) => assert!(followers.contains(&(n, p.port, p.pin, p.adc, p.channel)), "{p:?}"),
        }
    }
    assert_eq!(INPUT_PINS[VOLTAGE_INPUT], INPUT_PINS[0]);
    assert_eq!(
        (INPUT_PINS[input_of(0)].port, INPUT_PINS[input_of(0)].pin),
        ('C', 0)
    );
    assert_eq!(input_of(SENSORS - 1), 16);
    // Analog mode on exactly those pins and PA4.
    let (a, b, c) = pins::array_analog_masks();
    assert_eq!(
        a,
        0b11 | 0b11 << 2 | 0b11 << 8 | 0b11 << 12 | 0b11 << 14 | 0b11 << 16 | 0b11 << 18
    );
    assert_eq!(
        b,
        [0u32, 1, 11, 12, 13, 14, 15]
            .iter()
            .map(|p| 0b11 << (2 * p))
            .sum::<u32>()
    );
    assert_eq!(
        c,
        [0u32, 1, 2, 3, 4, 5].iter().map(|p| 0b11 << (2 * p)).sum::<u32>()
    );
    let mut gb = Fake::new(&[(0x00, 0xFFFF_FEBF)]);
    let (mut ga, mut gc) = (Fake::new(&[(0x00, 0)]), Fake::new(&[(0x00, 0)]));
    pins::array_analog(
        ga.regs::<pac::gpioa::RegisterBlock>(),
        gb.regs::<pac::gpiob::RegisterBlock>(),
        gc.regs::<pac::gpioc::RegisterBlock>(),
    );
    assert_eq!((ga.at(0), gb.at(0), gc.at(0)), (a, 0xFFFF_FEBF | b, c));
}

#[test]
fn the_arrays_adcs_scan_four_inputs_sixteen_times_oversampled_on_tim6() {
    // Common blocks: independent (DUAL = 0), CKMODE = 0b11 (HCLK/4).
    let mut common = Fake::new(&[]);
    scan::common(common.regs::<pac::adc12_common::RegisterBlock>());
    assert_eq!(common.at(0x08), 0b11 << 16);
    // ADC3's scan: PB0 (IN12), PB1 (IN1), PB13 (IN5), OPAMP3 (IN13).
    assert_eq!(scan::sequence(2), [12, 1, 5, 13]);
    let mut a = Fake::new(&[(0x0C, 0x8000_0000), (0x08, 0x2000_0000)]);
    scan::configure(a.regs::<pac::adc1::RegisterBlock>(), scan::sequence(2));
    // SQR1: L = 3, SQ1..SQ4 at bits 6, 12, 18, 24.
    assert_eq!(a.at(0x30), 3 | 12 << 6 | 1 << 12 | 5 << 18 | 13 << 24);
    // SMPR1 (0x14): IN1 and IN5 at 12.5 cycles (0b010); SMPR2 (0x18):
    // IN12 and IN13 (fields 2 and 3).
    assert_eq!(a.at(0x14), 0b010 << 3 | 0b010 << 15);
    assert_eq!(a.at(0x18), 0b010 << 6 | 0b010 << 9);
    // CFGR: DMAEN (0), DMACFG (1), EXTSEL 13 (bits 5..9), EXTEN rising
    // (10), JQDIS kept; CONT, OVRMOD, RES (12 bits), ALIGN 0.
    assert_eq!(a.at(0x0C), 1 | 1 << 1 | 13 << 5 | 1 << 10 | 1 << 31);
    // CFGR2 (0x10): ROVSE (0), OVSR = 0b011 (16×, bits 2..4), OVSS = 0,
    // TROVS = 0, ROVSM = 0.
    assert_eq!(a.at(0x10), 1 | 0b011 << 2);
    // Every frame ADC's sample times cover exactly its channels.
    for f in 0..5 {
        let seq = scan::sequence(f);
        let (s1, s2) = scan::sample_times(seq);
        for ch in 0..19u32 {
            let bits = if ch < 10 {
                s1 >> (3 * ch)
            } else {
                s2 >> (3 * (ch - 10))
            } & 0b111;
            assert_eq!(
                bits,
                if seq.contains(&(ch as u8)) { 0b010 } else { 0 },
                "ADC {f} IN{ch}"
            );
        }
    }
    // The scan fits the instant: 4 × 16 conversions of 25 cycles at
    // 42.5 MHz (HCLK/4) within 1/25 kHz.
    let scan_s = 4.0 * 16.0 * 25.0 / (instrument::design::SYSCLK_HZ as f64 / 4.0);
    assert!(scan_s < 1.0 / instrument::array::RATE_HZ as f64, "{scan_s}");
    let step = instrument::array::SCAN_STEP_S as f64;
    assert!(
        (scan_s / 4.0 / step - 1.0).abs() < 1e-6,
        "the skew the channels take out is the board's: {step}"
    );
}

#[test]
fn the_arrays_followers_dma_dac_and_timers() {
    // OPAMP3..5 CSR (0x08, 0x0C, 0x10): OPAEN, VP_SEL = 2 (bits 2..3),
    // VM_SEL = 3 (follower, bits 5..6), OPAINTOEN (bit 8).
    let mut op = Fake::new(&[]);
    opamp::followers(op.regs::<pac::opamp::RegisterBlock>());
    let csr = 1 | 2 << 2 | 3 << 5 | 1 << 8;
    assert_eq!((op.at(0x00), op.at(0x04)), (0, 0), "OPAMP1, 2 untouched");
    assert_eq!(
        (op.at(0x08), op.at(0x0C), op.at(0x10), op.at(0x14)),
        (csr, csr, csr, 0)
    );
    // DMAMUX: channels 0..4 ← ADC1, ADC2, ADC3, ADC5, ADC4; 5 ← DAC1 CH1.
    let mut mux = Fake::new(&[]);
    dma::array_requests(mux.regs::<pac::dmamux::RegisterBlock>());
    let reqs: Vec<u32> = (0..6).map(|c| mux.at(4 * c)).collect();
    assert_eq!(reqs, [5, 36, 37, 39, 38, 6]);
    // DMA1: channel 5 (CCR5 at 0x08 + 20·4) with interrupts, channel 1
    // without; 16-bit both sides, circular, peripheral → memory.
    let mut d = Fake::new(&[]);
    let regs = d.regs::<pac::dma1::RegisterBlock>();
    dma::scan_channel(regs, 4, 0x5000_0540, 0x2000_2000, 800, true);
    dma::scan_channel(regs, 0, 0x5000_0040, 0x2000_1000, 800, false);
    let base = 1 | 1 << 5 | 1 << 7 | 0b01 << 8 | 0b01 << 10;
    assert_eq!(d.at(0x08 + 20 * 4), base | 1 << 1 | 1 << 2 | 1 << 3);
    assert_eq!(d.at(0x08), base);
    assert_eq!(
        (d.at(0x0C + 80), d.at(0x10 + 80), d.at(0x14 + 80)),
        (800, 0x5000_0540, 0x2000_2000)
    );
    // Channel 6: the DAC's table, memory → DAC, 16-bit codes as 32-bit
    // writes, circular, no interrupts.
    dma::table_channel(
        d.regs::<pac::dma1::RegisterBlock>(),
        0x2000_4000,
        0x5000_0808,
        4000,
    );
    assert_eq!(
        d.at(0x08 + 100),
        1 | 1 << 4 | 1 << 5 | 1 << 7 | 0b10 << 8 | 0b01 << 10
    );
    assert_eq!(
        (d.at(0x0C + 100), d.at(0x10 + 100), d.at(0x14 + 100)),
        (4000, 0x5000_0808, 0x2000_4000)
    );
    // Channel 5's events (ISR bits 16..19) and its clear (CGIF5, bit 16).
    let mut d = Fake::new(&[(0x00, 0b0100 << 16 | 0b1110)]);
    let regs = d.regs::<pac::dma1::RegisterBlock>();
    assert_eq!(dma::take_event_of(regs, 4), Event::FirstHalf);
    assert_eq!(d.at(0x04), 1 << 16);
    let mut d = Fake::new(&[(0x00, 0b0110 << 16)]);
    assert_eq!(
        dma::take_event_of(d.regs::<pac::dma1::RegisterBlock>(), 4),
        Event::Overrun
    );
    let mut d = Fake::new(&[(0x00, 0b1000 << 16)]);
    assert_eq!(
        dma::take_event_of(d.regs::<pac::dma1::RegisterBlock>(), 4),
        Event::Error
    );
    // DAC: TSEL1 = 2 (TIM7_TRGO).
    let mut dac_regs = Fake::new(&[]);
    dac::configure_array(dac_regs.regs::<pac::dac1::RegisterBlock>());
    assert_eq!(dac_regs.at(0x00), 1 | 1 << 1 | 2 << 2 | 1 << 12);
    // TIM6 at 25 kHz (6799), TIM7 at 1 MHz (169): one block is 680 000
    // cycles of each, so the table and the block stay in step.
    let (a6, a7) = (timer::arr_for(25_000), timer::arr_for(1_000_000));
    assert_eq!((a6, a7), (6799, 169));
    assert_eq!((a6 + 1) * 100, (a7 + 1) * 4000);
    let mut t = Fake::new(&[]);
    timer::configure_arr(t.regs::<pac::tim6::RegisterBlock>(), a7);
    assert_eq!((t.at(0x28), t.at(0x2C), t.at(0x04)), (0, 169, 0b010 << 4));
    // Clocks: GPIOC (2), ADC345 (14), TIM7 (5), SYSCFG (APB2 bit 0).
    let mut rcc = Fake::new(&[]);
    clocks::array_peripherals(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x48), 1 | 1 << 2);
    assert_eq!(rcc.at(0x4C), 1 | 1 << 1 | 1 << 2 | 1 << 13 | 1 << 14 | 1 << 16);
    assert_eq!(rcc.at(0x58), 1 << 4 | 1 << 5 | 1 << 28);
    assert_eq!(rcc.at(0x60), 1);
}

#[test]
fn a_stopped_excitation_is_seen_and_its_flags_cleared() {
    // DAC_SR (offset 0x34, reset 0): DMAUDR1 bit 13, cleared by writing 1.
    // DMA_ISR (0x00): TEIF of channel c (0-based) at bit 4c + 3; DMA_IFCR
    // (0x04): CTEIF at the same bit (RM0440 22.7.19, 12.6.1–12.6.2).
    for c in [1usize, dma::ARRAY_DAC_CHANNEL] {
        let teif = 1u32 << (4 * c + 3);
        // Nothing wrong, and another channel's error is not this one's.
        let mut d = Fake::new(&[]);
        let mut m = Fake::new(&[(0x00, 1 << 3)]);
        assert!(!dac::excitation_stopped(
            d.regs::<pac::dac1::RegisterBlock>(),
            m.regs::<pac::dma1::RegisterBlock>(),
            c
        ));
        assert_eq!((d.at(0x34), m.at(0x04)), (0, 0));
        // An underrun: seen, cleared by its own bit alone.
        let mut d = Fake::new(&[(0x34, 1 << 13)]);
        let mut m = Fake::new(&[]);
        assert!(dac::excitation_stopped(
            d.regs::<pac::dac1::RegisterBlock>(),
            m.regs::<pac::dma1::RegisterBlock>(),
            c
        ));
        assert_eq!((d.at(0x34), m.at(0x04)), (1 << 13, 0));
        // A transfer error of the DAC's channel: seen, CTEIF written.
        let mut d = Fake::new(&[]);
        let mut m = Fake::new(&[(0x00, teif | 1 << 1)]);
        assert!(dac::excitation_stopped(
            d.regs::<pac::dac1::RegisterBlock>(),
            m.regs::<pac::dma1::RegisterBlock>(),
            c
        ));
        assert_eq!((d.at(0x34), m.at(0x04)), (0, teif));
    }
}

#[test]
fn a_debugger_halt_freezes_the_watchdog_and_the_sample_timers() {
    // DBGMCU_APB1FZR1 (offset 0x08, reset 0): DBG_TIM6_STOP bit 4,
    // DBG_TIM7_STOP bit 5, DBG_IWDG_STOP bit 12 (RM0440, DBGMCU); the
    // other bits as they were.
    let mut dbg = Fake::new(&[(0x08, 1 << 21)]);
    watchdog::freeze_in_debug(dbg.regs::<pac::dbgmcu::RegisterBlock>());
    assert_eq!(dbg.at(0x08), 1 << 4 | 1 << 5 | 1 << 12 | 1 << 21);
}

#[test]
fn lpuart1_at_15_mbd_8n1_on_pa2_pa3_fed_by_dma() {
    // The divider: 256 · 170 MHz / 15 MBd = 2901.33 → 2901, within
    // 0.02 % of the baud rate, and inside the LPUART's range.
    let brr = lpuart::brr(::link::BOARD_BAUD);
    assert_eq!(brr, 2901);
    assert!((0x300..=0xF_FFFF).contains(&brr));
    let err = lpuart::actual_baud(brr) / f64::from(::link::BOARD_BAUD) - 1.0;
    assert!(err.abs() < 2e-4, "{err}");
    const { assert!(lpuart::KERNEL_HZ >= 3 * ::link::BOARD_BAUD) };
    // RCC: LPUART1EN (APB1ENR2 bit 0), LPUART1SEL = PCLK (CCIPR 11:10 =
    // 0b00, set from a non-reset value), DMA2EN (AHB1ENR bit 1).
    let mut rcc = Fake::new(&[(0x88, 0b11 << 10)]);
    lpuart::clocks(rcc.regs::<pac::rcc::RegisterBlock>());
    link::clocks(rcc.regs::<pac::rcc::RegisterBlock>());
    assert_eq!(rcc.at(0x5C), 1);
    assert_eq!(rcc.at(0x88) & 0b11 << 10, 0);
    assert_eq!(rcc.at(0x48), 1 << 1);
    // GPIOA from its reset values (RM0440 9.4): MODER 0xABFF_FFFF,
    // OSPEEDR 0x0C00_0000, PUPDR 0x6400_0000. PA2, PA3 alternate (0b10),
    // AF12 in AFRL, PA2 very high speed, PA3 pulled up; SWD's pins
    // (PA13, PA14) untouched.
    let mut a = Fake::new(&[(0x00, 0xABFF_FFFF), (0x08, 0x0C00_0000), (0x0C, 0x6400_0000)]);
    lpuart::pins(a.regs::<pac::gpioa::RegisterBlock>());
    assert_eq!(a.at(0x00), 0xABFF_FFFF & !(0b0101 << 4));
    assert_eq!(a.at(0x20), 12 << 8 | 12 << 12);
    assert_eq!(a.at(0x08), 0x0C00_0000 | 0b11 << 4);
    assert_eq!(a.at(0x0C), 0x6400_0000 | 0b01 << 6);
    // LPUART1: BRR, CR3: DMAR (6), DMAT (7), OVRDIS (12); CR1: FIFOEN
    // (29), UE (0), TE (3), RE (2); 8 data bits, no parity, one stop bit
    // (M, PCE, STOP all zero).
    let mut u = Fake::new(&[]);
    lpuart::enable(u.regs::<pac::lpuart1::RegisterBlock>(), ::link::BOARD_BAUD);
    assert_eq!(u.at(0x0C), 2901);
    assert_eq!(u.at(0x08), 1 << 6 | 1 << 7 | 1 << 12);
    assert_eq!(u.at(0x00), 1 << 29 | 1 | 1 << 3 | 1 << 2);
    assert_eq!(u.at(0x04), 0);
    // TDR is at 0x28, RDR at 0x24.
    assert_eq!(
        lpuart::tdr_address(u.regs::<pac::lpuart1::RegisterBlock>()),
        u.words.as_ptr() as u32 + 0x28
    );
    assert_eq!(
        lpuart::rdr_address(u.regs::<pac::lpuart1::RegisterBlock>()),
        u.words.as_ptr() as u32 + 0x24
    );
}

#[test]
fn link_dma_memory_to_lpuart_once_and_its_states() {
    // DMAMUX channels 8 and 9 serve DMA2 channels 1 and 2: LPUART1_TX is
    // request 35, LPUART1_RX 34.
    let mut mux = Fake::new(&[]);
    link::request(mux.regs::<pac::dmamux::RegisterBlock>());
    assert_eq!((mux.at(0x20), mux.at(0x24)), (35, 34));
    // Channel 2 (CCR at 0x1C): peripheral → memory, bytes, MINC, CIRC,
    // no interrupts, round a ring of 256.
    let mut d = Fake::new(&[]);
    link::receive(d.regs::<pac::dma1::RegisterBlock>(), 0x4000_8024, 0x2000_0800);
    assert_eq!(d.at(0x1C), 1 | 1 << 5 | 1 << 7);
    assert_eq!(
        (d.at(0x20), d.at(0x24), d.at(0x28)),
        (256, 0x4000_8024, 0x2000_0800)
    );
    // The ring read by position, across its wrap.
    let ring: Vec<u8> = (0..=255u8).collect();
    let mut rx = link::Receiver::new();
    let mut got = vec![];
    rx.take(256 - 10, |k| ring[k], |b| got.push(b));
    assert_eq!(got, (0..10).collect::<Vec<u8>>());
    got.clear();
    rx.take(256, |k| ring[k], |b| got.push(b));
    assert_eq!(got, (10..=255).collect::<Vec<u8>>(), "the DMA wrapped to 0");
    got.clear();
    rx.take(256 - 3, |k| ring[k], |b| got.push(b));
    assert_eq!(got, vec![0, 1, 2]);
    let mut d = Fake::new(&[]);
    link::transfer(d.regs::<pac::dma1::RegisterBlock>(), 0x2000_0400, 0x4000_8028, 62);
    // CCR1: EN, TCIE, TEIE, memory → peripheral, MINC, bytes both sides,
    // not circular, no half-transfer interrupt.
    assert_eq!(d.at(0x08), 1 | 1 << 1 | 1 << 3 | 1 << 4 | 1 << 7);
    assert_eq!(
        (d.at(0x0C), d.at(0x10), d.at(0x14)),
        (62, 0x4000_8028, 0x2000_0400)
    );
    // The flags: nothing sent is done; under way is busy; TCIF1 (bit 1)
    // done; TEIF1 (bit 3) an error, which wins.
    let mut d = Fake::new(&[]);
    let regs = d.regs::<pac::dma1::RegisterBlock>();
    assert_eq!(link::take_state(regs, false), link::State::Done);
    assert_eq!(link::take_state(regs, true), link::State::Busy);
    let mut d = Fake::new(&[(0x00, 0b0010)]);
    assert_eq!(
        link::take_state(d.regs::<pac::dma1::RegisterBlock>(), true),
        link::State::Done
    );
    assert_eq!(d.at(0x04), 1, "CGIF1 written");
    let mut d = Fake::new(&[(0x00, 0b1010)]);
    assert_eq!(
        link::take_state(d.regs::<pac::dma1::RegisterBlock>(), true),
        link::State::Error
    );
    // Another channel's flags are not channel 1's.
    let mut d = Fake::new(&[(0x00, 0b0010 << 4)]);
    assert_eq!(
        link::take_state(d.regs::<pac::dma1::RegisterBlock>(), true),
        link::State::Busy
    );
}

#[test]
fn settings_flash_pages_unlock_erase_program_and_error_flags() {
    use flash::{FlashError, Page};
    // The last 8 KiB: dual bank, bank 2 pages 124…127 (2 KiB each);
    // single bank, pages 126 and 127 (4 KiB each).
    assert_eq!(flash::SETTINGS_BASE + flash::SETTINGS_BYTES, 0x0808_0000);
    let p = |bank2, number| Some(Page { bank2, number });
    assert_eq!(
        flash::pages(flash::SETTINGS_BASE, true),
        [p(true, 124), p(true, 125)]
    );
    assert_eq!(
        flash::pages(flash::SETTINGS_BASE + 4096, true),
        [p(true, 126), p(true, 127)]
    );
    assert_eq!(flash::pages(flash::SETTINGS_BASE, false), [p(false, 126), None]);
    assert_eq!(flash::pages(0x0800_0000, true), [p(false, 0), p(false, 1)]);
    // Unlock (CR resets locked, 0xC000_0000): the second key last in KEYR
    // (offset 0x08).
    let mut f = Fake::new(&[(0x14, 0xC000_0000)]);
    flash::unlock(f.regs::<pac::flash::RegisterBlock>());
    assert_eq!(f.at(0x08), 0xCDEF_89AB);
    // Page erase: PER (bit 1), PNB (bits 3…9), BKER (bit 11), then STRT
    // (bit 16); never LOCK (bit 31) or OPTLOCK (bit 30), which CR resets
    // with (a write from the reset value would lock the flash mid-way).
    let mut f = Fake::new(&[(0x14, 0xC000_0000)]);
    flash::start_erase(
        f.regs::<pac::flash::RegisterBlock>(),
        Page {
            bank2: true,
            number: 125,
        },
    );
    assert_eq!(f.at(0x14), 1 << 1 | 125 << 3 | 1 << 11 | 1 << 16);
    // Programming: PG (bit 0) alone; the end clears it; lock sets LOCK
    // (and OPTLOCK, as at reset).
    flash::start_program(f.regs::<pac::flash::RegisterBlock>());
    assert_eq!(f.at(0x14), 1);
    flash::end_operation(f.regs::<pac::flash::RegisterBlock>());
    assert_eq!(f.at(0x14), 0);
    flash::lock(f.regs::<pac::flash::RegisterBlock>());
    assert_eq!(f.at(0x14), 0xC000_0000);
    // The data cache reset: DCEN (bit 10) back on, DCRST (bit 12) off,
    // the rest of ACR (4 wait states, prefetch, ICEN) kept.
    let mut f = Fake::new(&[(0x00, 4 | 1 << 8 | 1 << 9 | 1 << 10)]);
    flash::reset_data_cache(f.regs::<pac::flash::RegisterBlock>());
    assert_eq!(f.at(0x00), 4 | 1 << 8 | 1 << 9 | 1 << 10);
    // Error flags (SR at 0x10): each one named, cleared by writing it
    // back; BSY (bit 16) is neither an error nor written.
    let cases = [
        (1 << 1, FlashError::Operation),
        (1 << 3, FlashError::Programming),
        (1 << 4, FlashError::WriteProtected),
        (1 << 5, FlashError::Alignment),
        (1 << 6, FlashError::Size),
        (1 << 7, FlashError::Sequence),
        (1 << 8, FlashError::Miss),
        (1 << 9, FlashError::Fast),
    ];
    for (bit, e) in cases {
        let mut f = Fake::new(&[(0x10, bit | 1 << 16 | 1)]);
        assert_eq!(flash::take_errors(f.regs::<pac::flash::RegisterBlock>()), Err(e));
        assert_eq!(f.at(0x10), bit | 1, "written back to clear");
    }
    let mut f = Fake::new(&[(0x10, 1 << 16 | 1)]);
    assert!(flash::busy(f.regs::<pac::flash::RegisterBlock>()));
    assert_eq!(flash::take_errors(f.regs::<pac::flash::RegisterBlock>()), Ok(()));
    assert_eq!(f.at(0x10), 1, "EOP cleared, BSY not written");
    // The region: aligned and within 8 KiB.
    assert_eq!(flash::in_region(0, 8192, 4096), Ok(()));
    assert_eq!(flash::in_region(8, 16, 8), Ok(()));
    assert_eq!(flash::in_region(4, 8, 8), Err(FlashError::Bounds));
    assert_eq!(flash::in_region(8184, 16, 8), Err(FlashError::Bounds));
    assert_eq!(flash::in_region(u32::MAX - 3, 8, 1), Err(FlashError::Bounds));
}

#[test]
fn a_torn_settings_word_is_a_read_error_and_any_other_ecc_failure_is_not() {
    use flash::{ecc_failure, in_settings, take_settings_ecc};
    // FLASH_ECCR (RM0440 3.7.8): ECCD bit 31, ECCD2 bit 29, ECCC bit 30
    // (a corrected single error), BK_ECC bit 21, ADDR_ECC bits 18:0 (the
    // double word's address within its bank).
    // Dual bank: the settings' first double word, bank 2 at 0x3_E000.
    assert_eq!(ecc_failure(0x8023_E000, true), Some(0x0807_E000));
    assert!(in_settings(0x0807_E000) && in_settings(0x0807_FFF8));
    // Single bank: the same address, 0x7_E008 within the one bank.
    assert_eq!(ecc_failure(0x8007_E008, false), Some(0x0807_E008));
    // ECCD2 alone (the second double word of a 128-bit read).
    assert_eq!(ecc_failure(0x2023_E010, true), Some(0x0807_E010));
    // A corrected error is no failure; a program word is not the settings'.
    assert_eq!(ecc_failure(0x4023_E000, true), None);
    assert_eq!(ecc_failure(0x8000_1000, true), Some(0x0800_1000));
    assert!(!in_settings(0x0800_1000) && !in_settings(0x0808_0000));
    // Taken: ECCR at 0x18, OPTR at 0x20 (DBANK bit 22). The flags are
    // written back as 1 to clear them, ECCIE (bit 24) kept.
    let mut f = Fake::new(&[(0x18, 0x8123_E000), (0x20, 1 << 22)]);
    assert_eq!(
        take_settings_ecc(f.regs::<pac::flash::RegisterBlock>()),
        Some(0x0807_E000)
    );
    assert_eq!(
        f.at(0x18) & (1 << 31 | 1 << 29 | 1 << 24),
        1 << 31 | 1 << 29 | 1 << 24
    );
    // Not the settings': nothing cleared (the NMI resets the board).
    let mut f = Fake::new(&[(0x18, 0x8000_1000), (0x20, 1 << 22)]);
    assert_eq!(take_settings_ecc(f.regs::<pac::flash::RegisterBlock>()), None);
    assert_eq!(f.at(0x18), 0x8000_1000);
}

/// Each layout's DMA count and halves: two blocks round, the 1 ms
/// blocks in the first 50 rows of the buffer (the DMA's circular count
/// of 200 results), the 4 ms blocks each one `Rows`.
#[test]
fn the_arrays_buffer_halves_follow_the_layout() {
    use super::front_end::{array_half, array_results};
    use instrument::array::{Layout, Rows, BLOCK_INSTANTS, SCAN};
    assert_eq!(array_results(&Layout::BLOCK_4MS), 800);
    assert_eq!(array_results(&Layout::BLOCK_1MS), 200);
    let mut buf: [Rows; 2] = [[[0; SCAN]; BLOCK_INSTANTS]; 2];
    for (n, row) in buf.as_flattened_mut().iter_mut().enumerate() {
        *row = [n as i16; SCAN];
    }
    for (layout, n) in [(Layout::BLOCK_4MS, 100), (Layout::BLOCK_1MS, 25)] {
        for half in 0..2 {
            let rows = array_half(&mut buf, &layout, half);
            assert_eq!(rows.len(), n);
            assert_eq!(rows[0][0] as usize, half * n);
            assert_eq!(rows[n - 1][3] as usize, half * n + n - 1);
        }
        // A half beyond the second is the second.
        assert_eq!(array_half(&mut buf, &layout, 7)[0][0] as usize, n);
    }
}

/// A netlist's element lines (comments left out), each split into its
/// words: the element's name, its nodes, its value or model.
fn netlist(text: &str) -> Vec<Vec<&str>> {
    text.lines()
        .filter(|l| !l.starts_with('*'))
        .map(|l| l.split_whitespace().collect())
        .collect()
}

/// Element `name`'s line of a [`netlist`].
fn element<'a>(lines: &'a [Vec<&'a str>], name: &str) -> &'a [&'a str] {
    lines
        .iter()
        .find(|t| t.first() == Some(&name))
        .unwrap_or_else(|| panic!("no {name} in the netlist"))
}

/// The reference front end's netlist (`front-end/array/board.cir`,
/// generated from the same circuit as its schematic and bill of
/// materials) wires every input as [`INPUT_PINS`] maps it: sensor s's
/// stage output through its ADC resistor to the pin of input s + 1, the
/// excitation's follower to input 0's, the self-test's reference to
/// input 17's, and the DAC on PA4.
#[test]
fn the_netlist_wires_every_input_as_the_pin_map() {
    use instrument::array::{input_of, SENSORS, VOLTAGE_INPUT};
    let lines = netlist(include_str!("../../../front-end/array/board.cir"));
    let element = |name: &str| element(&lines, name);
    let pin = |input: usize| format!("P{}{}", INPUT_PINS[input].port, INPUT_PINS[input].pin);
    let adc = |input: usize, from: &str, resistor: &str| {
        let name = pin(input);
        assert_eq!(element(&format!("XADC_{name}"))[1], name, "input {input}");
        assert_eq!(element(resistor)[1..3], [from, name.as_str()], "input {input}");
    };
    for s in 0..SENSORS {
        let (tab, out) = (format!("TAB{s}"), format!("TIA{s}"));
        let stage = lines
            .iter()
            .find(|t| t.first().is_some_and(|n| n.starts_with("XU")) && t.get(2) == Some(&tab.as_str()))
            .unwrap_or_else(|| panic!("no stage on {tab}"));
        assert_eq!(stage[1..4], ["BIAS", tab.as_str(), out.as_str()], "sensor {s}");
        adc(input_of(s), &out, &format!("RA{s}"));
    }
    adc(VOLTAGE_INPUT, "VBUF", "RAV");
    adc(17, "TIAREF", "RAREF");
    assert_eq!(element("VDAC_PA4")[1], "PA4");
}

/// The multiplexed board's reference netlist (`front-end/mux/board.cir`)
/// puts the voltage on PA0 and the current on PA1 (the pins
/// [`pins::analog`] sets analog), the DAC on PA4, and drives both
/// multiplexers' address lines from the pins [`pins::mux_pins`] drives
/// and the range switch's from [`pins::range_pins`]'.
#[test]
fn the_multiplexed_netlist_wires_the_pins_the_firmware_drives() {
    let lines = netlist(include_str!("../../../front-end/mux/board.cir"));
    let element = |name: &str| element(&lines, name);
    assert_eq!(element("RAV")[1..3], ["VBUF", "PA0"]);
    assert_eq!(element("RAI")[1..3], ["TIA", "PA1"]);
    assert_eq!(element("XADC_PA0")[1], "PA0");
    assert_eq!(element("XADC_PA1")[1], "PA1");
    assert_eq!(element("VDAC_PA4")[1], "PA4");
    let gpio = |p: &pins::AnyPin| format!("PB{}", p.pin());
    let mux: Vec<String> = pins::mux_pins().iter().map(gpio).collect();
    let range: Vec<String> = pins::range_pins().iter().map(gpio).collect();
    // XU2 D S1…S8 A0 A1 A2 VDD ADG708; XU4 D S1…S4 A0 A1 VDD TMUX1104.
    for u in ["XU2", "XU3"] {
        assert_eq!(element(u)[10..13], mux[..], "{u}");
    }
    assert_eq!(element("XU4")[6..8], range[..]);
    for p in mux.iter().chain(&range) {
        assert_eq!(element(&format!("VGPIO_{p}"))[1], p.as_str());
    }
}
