//! The one place that owns logging, panics, faults and exit in QEMU builds:
//! defmt over semihosting, and semihosting exit codes the test harness reads
//! (0 ok, 101 panic, 102 hard fault).

use defmt_semihosting as _;

/// Exit QEMU with `code`.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::println!("PANIC {}", defmt::Display2Format(info));
    exit(101)
}

#[cortex_m_rt::exception]
#[allow(non_snake_case)]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::println!("HARDFAULT pc={=u32:#x}", frame.pc());
    exit(102)
}

defmt::timestamp!("");
