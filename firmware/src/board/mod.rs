//! The STM32G474 (Nucleo-G474RE) hardware, one module per peripheral.
//!
//! Each register write is a small function over the peripheral's register
//! block, written with the PAC's field writers: the host tests
//! (`board/tests.rs`) apply them to register blocks in RAM and
//! check the values against RM0440. The `init` sequences (target only) add
//! the waits and the order the reference manual requires.
//!
//! | module | what |
//! |---|---|
//! | [`clocks`] | HSI16 → PLL → 170 MHz, range-1 boost, flash wait states, peripheral clocks |
//! | [`pins`] | analog inputs, the multiplexer's address lines (embedded-hal `OutputPin`) |
//! | [`adc`] | ADC1 + ADC2 in dual regular simultaneous mode, paced by TIM6 |
//! | [`scan`] | the array: five ADCs each scanning four inputs, 16× oversampled; the pin map |
//! | [`opamp`] | the array: three op-amps as followers into ADC3 and ADC5 |
//! | [`dac`] | DAC1 channel 1, paced by TIM6 (the array: TIM7), fed by DMA |
//! | [`excitation`] | the multiplexed board's DAC ring of quarter slots, refilled as it plays |
//! | [`dma`] | DMAMUX and DMA1 channels 1 (ADC → RAM) and 2 (RAM → DAC), the interrupt's events; the array's channels 1–6 |
//! | [`lpuart`] | LPUART1 on PA2/PA3 at [`link::BOARD_BAUD`](::link::BOARD_BAUD): the ST-LINK's virtual COM port |
//! | [`link`] | DMA2 channel 1: the record link's queued frames into LPUART1; channel 2: the host's bytes round a ring |
//! | [`requests`] | the host's requests from the ring, answered from the settings store |
//! | [`flash`] | the settings' 8 KiB of flash as an `embedded-storage` `NorFlash`: unlock, page erase, double-word programming, error flags |
//! | [`front_end`] | each front end started in RM0440's order; the DAC's slot waveforms; the DMA buffers' shapes |
//! | [`timer`] | TIM6 at the sample rate |
//! | [`device_id`] | the board's id in its start frame: the CRC-32 of the G474's unique device ID |
//! | [`watchdog`] | IWDG (100 ms), the cause of the last reset |
//! | `settings` | (target) the multiplexed board's sensors at start: the set stored in flash, or uncalibrated; the request side |
//! | [`setup`] | the start and end of both board apps' `init`: reset cause, watchdog, clocks, the peripherals the tasks own |
//!
//! The front end's values (sample rate, clock, amplitude) come from
//! `instrument::design`.

pub use stm32g4::stm32g474 as pac;

pub mod adc;
pub mod clocks;
pub mod dac;
pub mod device_id;
pub mod dma;
pub mod excitation;
pub mod flash;
pub mod front_end;
pub mod link;
pub mod lpuart;
pub mod opamp;
pub mod pins;
pub mod requests;
#[cfg(target_os = "none")]
mod runtime;
pub mod scan;
#[cfg(target_os = "none")]
pub mod settings;
pub mod setup;
pub mod timer;
pub mod watchdog;

#[cfg(test)]
mod tests;
