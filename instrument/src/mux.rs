//! The analog multiplexer in front of the ADC: channel address lines driven
//! by embedded-hal [`OutputPin`]s (an 8-channel part such as the ADG708:
//! three address lines, A0 = least significant bit).

use embedded_hal::digital::OutputPin;

/// A multiplexer with `BITS` address lines (2^BITS channels).
pub struct Mux<P: OutputPin, const BITS: usize> {
    pins: [P; BITS],
    selected: Option<u8>,
}

impl<P: OutputPin, const BITS: usize> Mux<P, BITS> {
    /// Channels this multiplexer selects between (a `u8` channel number
    /// addresses at most 8 lines: more is a compile-time error).
    pub const CHANNELS: usize = {
        assert!(BITS >= 1 && BITS <= 8, "1 to 8 address lines");
        1 << BITS
    };

    /// A multiplexer on `pins` (A0 first); nothing selected yet.
    pub fn new(pins: [P; BITS]) -> Self {
        Self { pins, selected: None }
    }

    /// Drive the address lines for `channel` (taken modulo the channel
    /// count). Returns true if the selection changed, so the caller knows
    /// to let the analog path settle.
    pub fn select(&mut self, channel: u8) -> Result<bool, P::Error> {
        let ch = (channel as usize % Self::CHANNELS) as u8;
        if self.selected == Some(ch) {
            return Ok(false);
        }
        for (bit, pin) in self.pins.iter_mut().enumerate() {
            if ch >> bit & 1 == 1 {
                pin.set_high()?;
            } else {
                pin.set_low()?;
            }
        }
        self.selected = Some(ch);
        Ok(true)
    }

    /// The selected channel.
    pub fn selected(&self) -> Option<u8> {
        self.selected
    }
}
