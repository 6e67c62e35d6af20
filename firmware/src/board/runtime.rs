//! The one place that owns logging, panics and faults on the board: defmt
//! over RTT (read by probe-rs); a panic or hard fault logs and resets the
//! board, whose next boot logs the cause (`watchdog::take_reset_cause`)
//! and measures again. A sensing skin left alone must come back, not wait
//! in a breakpoint for a debugger.

use defmt_rtt as _;

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::println!("PANIC {}", defmt::Display2Format(info));
    cortex_m::peripheral::SCB::sys_reset()
}

#[cortex_m_rt::exception]
#[allow(non_snake_case)]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::println!("HARDFAULT pc={=u32:#x}", frame.pc());
    cortex_m::peripheral::SCB::sys_reset()
}

defmt::timestamp!("");
