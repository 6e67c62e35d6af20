//! The start and the end of `init` that both board applications share,
//! and the peripherals their tasks own afterwards.
//!
//! [`begin`]: log why the board last reset, freeze the watchdog and the
//! sample timers while a debugger halts the core, start the watchdog,
//! bring the system clock to 170 MHz. Then the application configures its front
//! end. [`finish`]: the record link's port (LPUART1 on the ST-LINK's
//! virtual COM port, DMA2 to feed it), wait until the watchdog has taken
//! its settings, feed it once, and hand the peripherals the tasks need
//! over as owned values ([`Owned`]), so that no task reaches a peripheral
//! through a raw pointer or `steal()`.

#[cfg(target_os = "none")]
use super::clocks;
use super::pac;
use super::scan::Adcs;
use super::watchdog;
#[cfg(target_os = "none")]
use super::{link, lpuart};

/// The independent watchdog, owned by the task that proves the chain is
/// alive.
pub struct Watchdog(pac::IWDG);

impl Watchdog {
    /// Reload the counter: a block went all the way through.
    pub fn feed(&mut self) {
        watchdog::feed(&self.0);
    }
}

/// The peripherals the tasks own after `init`.
pub struct Owned {
    /// DMA1: its interrupt flags, read and cleared by the DMA task.
    pub dma: pac::DMA1,
    /// DAC1: its DMA underrun flag, read and cleared by the DMA task
    /// (`board::dac::excitation_stopped`).
    pub dac: pac::DAC1,
    /// The five ADCs: their overrun flags, read and cleared by the array's
    /// DMA task.
    pub adcs: Adcs,
    /// The watchdog, fed by the processing task.
    pub watchdog: Watchdog,
    /// The record link's port, for its transmitter (`board::link`).
    pub link: LinkPort,
    /// The flash controller, for the stored settings (`board::flash`).
    pub flash: pac::FLASH,
    /// TIM6, the sample clock: the multiplexed board starts it last
    /// (`board::front_end::multiplexed`); the array's front end has.
    pub sample_clock: pac::TIM6,
}

/// The record link's port: DMA2, whose channel 1 feeds LPUART1 and whose
/// channel 2 empties it, and the addresses of LPUART1's data registers.
pub struct LinkPort {
    /// DMA2, the link's alone.
    pub dma: pac::DMA2,
    /// LPUART1_TDR's address.
    pub tdr: u32,
    /// LPUART1_RDR's address.
    pub rdr: u32,
}

/// Log the cause of the last reset, freeze the watchdog and the timers in
/// debug, start the watchdog (100 ms) and the
/// system clock (RM0440 6.1.5: boost, wait states, PLL at 170 MHz).
#[cfg(target_os = "none")]
pub fn begin(dp: &pac::Peripherals) {
    let cause = watchdog::take_reset_cause(&dp.RCC);
    defmt::println!("reset cause: {=str}", cause.as_str());
    watchdog::freeze_in_debug(&dp.DBGMCU);
    watchdog::start(&dp.IWDG);
    clocks::system(dp);
}

/// The watchdog's settings in force and fed once; the peripherals the
/// tasks own.
#[cfg(target_os = "none")]
pub fn finish(dp: pac::Peripherals) -> Owned {
    lpuart::clocks(&dp.RCC);
    link::clocks(&dp.RCC);
    // Read back: the clocks are on before their registers are written.
    let _ = dp.RCC.ahb1enr().read();
    let _ = dp.RCC.apb1enr2().read();
    lpuart::pins(&dp.GPIOA);
    link::request(&dp.DMAMUX);
    lpuart::enable(&dp.LPUART1, ::link::BOARD_BAUD);
    while !watchdog::ready(&dp.IWDG) {}
    watchdog::feed(&dp.IWDG);
    Owned {
        dma: dp.DMA1,
        dac: dp.DAC1,
        adcs: Adcs::new(dp.ADC1, dp.ADC2, dp.ADC3, dp.ADC4, dp.ADC5),
        watchdog: Watchdog(dp.IWDG),
        link: LinkPort {
            tdr: lpuart::tdr_address(&dp.LPUART1),
            rdr: lpuart::rdr_address(&dp.LPUART1),
            dma: dp.DMA2,
        },
        flash: dp.FLASH,
        sample_clock: dp.TIM6,
    }
}
