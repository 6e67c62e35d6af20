//! Pins: PA0 (ADC1_IN1), PA1 (ADC2_IN2) and PA4 (DAC1_OUT1) analog; PB0,
//! PB1, PB2 push-pull outputs driving the multiplexer's address lines
//! A0..A2, PB5 and PB6 the transimpedance range switch's
//! (`instrument::design::TIA_RANGES_OHM`) (embedded-hal `OutputPin`).

use super::pac::{gpioa, gpiob, gpioc};
use instrument::config::{MUX_ADDRESS_LINES, RANGE_ADDRESS_LINES};

/// PA0, PA1, PA4 analog.
pub fn analog(gpioa: &gpioa::RegisterBlock) {
    gpioa
        .moder()
        .modify(|_, w| w.moder0().analog().moder1().analog().moder4().analog());
}

/// The array's analog pins ([`super::scan::INPUT_PINS`] and PA4, the
/// DAC's output): MODER 0b11 on each. The reset leaves most pins analog
/// already; this does not rely on it.
#[allow(unsafe_code)]
pub fn array_analog(
    gpioa: &gpioa::RegisterBlock,
    gpiob: &gpiob::RegisterBlock,
    gpioc: &gpioc::RegisterBlock,
) {
    let (a, b, c) = array_analog_masks();
    // SAFETY: MODER takes any 32-bit value; the masks only set whole
    // 2-bit fields of the pins listed.
    gpioa.moder().modify(|r, w| unsafe { w.bits(r.bits() | a) });
    gpiob.moder().modify(|r, w| unsafe { w.bits(r.bits() | b) });
    gpioc.moder().modify(|r, w| unsafe { w.bits(r.bits() | c) });
}

/// MODER bits of the array's analog pins on ports A, B and C.
pub const fn array_analog_masks() -> (u32, u32, u32) {
    let (mut a, mut b, mut c) = (0b11u32 << 8, 0u32, 0u32);
    let pins = super::scan::INPUT_PINS;
    let mut i = 0;
    while i < pins.len() {
        let m = 0b11 << (2 * pins[i].pin as u32);
        match pins[i].port {
            'A' => a |= m,
            'B' => b |= m,
            _ => c |= m,
        }
        i += 1;
    }
    (a, b, c)
}

/// PB0..PB2, PB5, PB6 outputs.
pub fn mux_outputs(gpiob: &gpiob::RegisterBlock) {
    gpiob.moder().modify(|_, w| {
        w.moder0()
            .output()
            .moder1()
            .output()
            .moder2()
            .output()
            .moder5()
            .output()
            .moder6()
            .output()
    });
}

/// Multiplexer address line on GPIOB pin `N`.
pub struct PinB<const N: u8>;

impl<const N: u8> embedded_hal::digital::ErrorType for PinB<N> {
    type Error = core::convert::Infallible;
}

#[cfg(target_os = "none")]
impl<const N: u8> embedded_hal::digital::OutputPin for PinB<N> {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        // SAFETY: BSRR is write-only and atomic per bit; this pin is owned
        // by the multiplexer alone.
        #[allow(unsafe_code)]
        unsafe {
            (*super::pac::GPIOB::ptr())
                .bsrr()
                .write(|w| w.bits(1 << (N + 16)));
        }
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        // SAFETY: as above.
        #[allow(unsafe_code)]
        unsafe {
            (*super::pac::GPIOB::ptr()).bsrr().write(|w| w.bits(1 << N));
        }
        Ok(())
    }
}

/// One of the three address lines.
pub enum AnyPin {
    /// PB0
    A0(PinB<0>),
    /// PB1
    A1(PinB<1>),
    /// PB2
    A2(PinB<2>),
    /// PB5 (range switch A0)
    R0(PinB<5>),
    /// PB6 (range switch A1)
    R1(PinB<6>),
}

impl AnyPin {
    /// Its pin number on GPIOB.
    pub const fn pin(&self) -> u8 {
        match self {
            AnyPin::A0(_) => 0,
            AnyPin::A1(_) => 1,
            AnyPin::A2(_) => 2,
            AnyPin::R0(_) => 5,
            AnyPin::R1(_) => 6,
        }
    }
}

impl embedded_hal::digital::ErrorType for AnyPin {
    type Error = core::convert::Infallible;
}

#[cfg(target_os = "none")]
impl embedded_hal::digital::OutputPin for AnyPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        match self {
            AnyPin::A0(p) => p.set_low(),
            AnyPin::A1(p) => p.set_low(),
            AnyPin::A2(p) => p.set_low(),
            AnyPin::R0(p) => p.set_low(),
            AnyPin::R1(p) => p.set_low(),
        }
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        match self {
            AnyPin::A0(p) => p.set_high(),
            AnyPin::A1(p) => p.set_high(),
            AnyPin::A2(p) => p.set_high(),
            AnyPin::R0(p) => p.set_high(),
            AnyPin::R1(p) => p.set_high(),
        }
    }
}

/// The three address lines.
pub fn mux_pins() -> [AnyPin; MUX_ADDRESS_LINES] {
    [AnyPin::A0(PinB), AnyPin::A1(PinB), AnyPin::A2(PinB)]
}

/// The range switch's two address lines.
pub fn range_pins() -> [AnyPin; RANGE_ADDRESS_LINES] {
    [AnyPin::R0(PinB), AnyPin::R1(PinB)]
}
