//! The one place that owns logging, panics, faults, exit and the command
//! line in QEMU builds: defmt over semihosting, semihosting exit codes the
//! test harness reads (0 ok, 2 a bad command line, 101 panic, 102 hard
//! fault), and the scenario arguments both QEMU apps read.

use defmt_semihosting as _;

/// Exit QEMU with `code`.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// The end of a run that went through: the `end` line the harness looks
/// for, then exit code 0.
pub fn end() -> ! {
    defmt::println!("end");
    exit(0)
}

/// Bytes of the semihosting command line the QEMU apps accept.
pub const COMMAND_LINE: usize = 256;

/// Call `f` with the semihosting command line's arguments (the scenario's
/// name first). A command line longer than [`COMMAND_LINE`] bytes, or an
/// argument that is not UTF-8, ends the run with exit code 2 and says
/// why: a run never falls back to a scenario it was not asked for.
pub fn with_args<R>(f: impl FnOnce(&mut dyn Iterator<Item = &str>) -> R) -> R {
    let Ok(args) = semihosting::experimental::env::args::<COMMAND_LINE>() else {
        defmt::println!(
            "the semihosting command line cannot be read (longer than {=usize} bytes?)",
            COMMAND_LINE
        );
        exit(2)
    };
    let mut words = (&args).map(|a| {
        a.unwrap_or_else(|_| {
            defmt::println!("a command-line argument is not UTF-8");
            exit(2)
        })
    });
    f(&mut words)
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
