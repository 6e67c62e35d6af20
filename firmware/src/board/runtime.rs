//! The one place that owns logging, panics and faults on the board: defmt
//! over RTT (read by probe-rs); a panic, a hard fault or an NMI (other
//! than the settings' ECC, which a read returns as an error) logs and resets the
//! board, whose next boot logs the cause (`watchdog::take_reset_cause`)
//! and measures again. A sensing skin left alone must come back, not wait
//! in a breakpoint for a debugger.

use defmt_rtt as _;

/// A panic logs where it happened, and its message when that is plain
/// text: a message with arguments is not formatted, since core's
/// formatting machinery would cost the 64 KiB image 730 bytes it does not
/// have, and the file and line name the fault. (The device paths have no
/// `unwrap`: a panic here is a bug.)
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
    let message = info.message().as_str().unwrap_or("(a formatted message)");
    defmt::println!("PANIC at {=str}:{=u32}: {=str}", file, line, message);
    cortex_m::peripheral::SCB::sys_reset()
}

#[cortex_m_rt::exception]
#[allow(non_snake_case)]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::println!("HARDFAULT pc={=u32:#x}", frame.pc());
    cortex_m::peripheral::SCB::sys_reset()
}

/// An NMI: a double ECC error in the settings' flash (a double word a
/// power cut tore) is the read's error, not a fault
/// ([`super::flash::take_ecc_nmi`]); any other (a torn program word, the
/// clock security system) logs and resets, as a hard fault does.
/// (`unsafe` as cortex-m-rt asks of an NMI handler: it must not share
/// state with code it preempts except through atomics, which it keeps.)
#[cortex_m_rt::exception]
#[allow(non_snake_case)]
#[allow(unsafe_code)]
unsafe fn NonMaskableInt() {
    if !super::flash::take_ecc_nmi() {
        defmt::println!("NMI");
        cortex_m::peripheral::SCB::sys_reset()
    }
}

defmt::timestamp!("");
