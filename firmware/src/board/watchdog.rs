//! IWDG, the independent watchdog, and why the last reset happened.
//!
//! The watchdog runs from the LSI (32 kHz, RM0440 §44) divided by 32: a
//! 1 ms tick, reload [`RELOAD`] → a reset 100 ms after the last
//! [`feed`]. The processing task feeds it after every record (one every
//! 5.44 ms), so a hang anywhere in the chain (a stuck interrupt, a DMA that
//! stopped, a task that never returns) resets the board within 100 ms;
//! the LSI's spread (29.5–34 kHz) moves that by under 10 %.
//!
//! A panic or a hard fault logs and resets at once (`runtime`); the next
//! boot logs the cause read from RCC_CSR ([`ResetCause`]) and clears it.

use super::pac::{dbgmcu, iwdg, rcc};

/// LSI frequency, Hz (nominal).
pub const LSI_HZ: u32 = 32_000;
/// Watchdog timeout, ms.
pub const TIMEOUT_MS: u32 = 100;
/// Reload value: ticks of LSI/32 in [`TIMEOUT_MS`], less one (≤ 0xFFF).
pub const RELOAD: u16 = (LSI_HZ / 32 * TIMEOUT_MS / 1000 - 1) as u16;
const _: () = assert!(RELOAD as u32 <= 0xFFF);

/// Start the watchdog (RM0440 §44.3.2: start, unlock, prescaler, reload);
/// it cannot be stopped again until the next reset. The caller waits for
/// [`ready`] and then feeds it once.
pub fn start(iwdg: &iwdg::RegisterBlock) {
    iwdg.kr().write(|w| w.key().start());
    iwdg.kr().write(|w| w.key().unlock());
    iwdg.pr().write(|w| w.pr().divide_by32());
    iwdg.rlr().write(|w| w.rl().set(RELOAD));
}

/// Freeze the watchdog and the sample timers while the core is halted by
/// a debugger (DBGMCU_APB1FZR1: DBG_IWDG_STOP, DBG_TIM6_STOP,
/// DBG_TIM7_STOP), so that a breakpoint held over 100 ms does not reset
/// the board, and the DAC and ADCs stay in step with the code.
pub fn freeze_in_debug(dbg: &dbgmcu::RegisterBlock) {
    dbg.apb1l_fz().modify(|_, w| {
        w.dbg_iwdg_stop()
            .set_bit()
            .dbg_timer6_stop()
            .set_bit()
            .dbg_tim7_stop()
            .set_bit()
    });
}

/// True once the prescaler and reload have reached the LSI domain.
pub fn ready(iwdg: &iwdg::RegisterBlock) -> bool {
    iwdg.sr().read().bits() == 0
}

/// Reload the counter: the system is alive.
pub fn feed(iwdg: &iwdg::RegisterBlock) {
    iwdg.kr().write(|w| w.key().feed());
}

/// Wait, feeding nothing, for the watchdog's reset (within
/// [`TIMEOUT_MS`] of the last [`feed`]): how start-up gives up on a board
/// it cannot run, after logging why.
#[cfg(target_os = "none")]
pub fn await_reset() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Why the board last reset, from RCC_CSR's flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// The independent watchdog: something hung for 100 ms.
    Watchdog,
    /// The window watchdog (not used by this firmware).
    WindowWatchdog,
    /// A software reset: this firmware's panic or hard-fault handler (or a
    /// debugger's reset request).
    Software,
    /// A low-power management reset.
    LowPower,
    /// Option bytes loaded.
    OptionBytes,
    /// Power-on or brown-out.
    PowerOn,
    /// The NRST pin (reset button, probe) alone.
    Pin,
    /// No flag set.
    Unknown,
}

impl ResetCause {
    /// The cause in RCC_CSR's bits. Internal resets also drive NRST, so
    /// PINRSTF comes with every cause: it counts only when alone.
    pub fn from_csr(bits: u32) -> Self {
        let bit = |n: u32| bits & (1 << n) != 0;
        if bit(29) {
            Self::Watchdog
        } else if bit(30) {
            Self::WindowWatchdog
        } else if bit(28) {
            Self::Software
        } else if bit(31) {
            Self::LowPower
        } else if bit(25) {
            Self::OptionBytes
        } else if bit(27) {
            Self::PowerOn
        } else if bit(26) {
            Self::Pin
        } else {
            Self::Unknown
        }
    }

    /// A word for the log.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Watchdog => "watchdog",
            Self::WindowWatchdog => "window-watchdog",
            Self::Software => "software (panic or hard fault)",
            Self::LowPower => "low-power",
            Self::OptionBytes => "option-bytes",
            Self::PowerOn => "power-on",
            Self::Pin => "reset-pin",
            Self::Unknown => "unknown",
        }
    }
}

/// Read the cause of the last reset and clear the flags (RMVF), so that
/// the next boot sees only its own.
pub fn take_reset_cause(rcc: &rcc::RegisterBlock) -> ResetCause {
    let cause = ResetCause::from_csr(rcc.csr().read().bits());
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    cause
}
