//! The one place that owns logging, panics and faults on the board: defmt
//! over RTT (read by probe-rs), and a panic or hard fault logs and halts
//! in a breakpoint so the debugger stops there.

use defmt_rtt as _;

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::println!("PANIC {}", defmt::Display2Format(info));
    loop {
        cortex_m::asm::bkpt();
    }
}

#[cortex_m_rt::exception]
#[allow(non_snake_case)]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::println!("HARDFAULT pc={=u32:#x}", frame.pc());
    loop {
        cortex_m::asm::bkpt();
    }
}

defmt::timestamp!("");
