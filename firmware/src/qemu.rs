//! The one place that owns logging, panics, faults, exit and the command
//! line in QEMU builds: defmt over semihosting, semihosting exit codes the
//! test harness reads (0 ok, 2 a bad command line, 101 panic, 102 hard
//! fault), and the scenario arguments both QEMU apps read.

use defmt_semihosting as _;

/// Exit QEMU with `code`.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// The end of a run that went through: how deep the stack went
/// ([`crate::stack`], from the paint of `init`), the `end` line the
/// harness looks for, then exit code 0.
pub fn end() -> ! {
    let (used, free) = crate::stack::high_water();
    defmt::println!("stack {=u32} bytes used, {=u32} never touched", used, free);
    defmt::println!("end");
    exit(0)
}

/// UART0 of the lm3s6965 as QEMU models it: a byte written to its data
/// register leaves on the serial port QEMU connects (`-serial
/// file:PATH`, or a socket): the record link's frames.
pub struct Uart0 {
    _owned: (),
}

/// UART0's line control register.
const UART0_LCRH: usize = 0x4000_C02C;
/// UART0's data register.
const UART0_DR: usize = 0x4000_C000;
/// UART0's flag register; bit 5 is "transmit FIFO full", bit 4 "receive
/// FIFO empty".
const UART0_FR: usize = 0x4000_C018;

impl Uart0 {
    /// UART0, for the one task that writes the link (the app's `init`
    /// takes it once and hands it over as a resource).
    pub fn take() -> Self {
        // SAFETY: UART0's line control register; FEN (bit 4) turns both
        // 16-byte FIFOs on, so that a poll after each block takes up to
        // 16 received bytes, not one; WLEN 8 bits (bits 5-6).
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::write_volatile(UART0_LCRH as *mut u32, 1 << 4 | 0b11 << 5);
        }
        Self { _owned: () }
    }

    /// The next byte received, if one is waiting (never waits).
    #[allow(unsafe_code)]
    pub fn read(&mut self) -> Option<u8> {
        // SAFETY: as for `write`: UART0's registers, owned by this value.
        unsafe {
            match core::ptr::read_volatile(UART0_FR as *const u32) & (1 << 4) != 0 {
                true => None,
                false => Some(core::ptr::read_volatile(UART0_DR as *const u32) as u8),
            }
        }
    }

    /// Send `bytes`, waiting while the transmit FIFO is full.
    #[allow(unsafe_code)]
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            // SAFETY: UART0's registers exist at these addresses on the
            // lm3s6965; this value owns them (one per app, from `take`).
            unsafe {
                while core::ptr::read_volatile(UART0_FR as *const u32) & (1 << 5) != 0 {}
                core::ptr::write_volatile(UART0_DR as *mut u32, u32::from(b));
            }
        }
    }
}

/// The sending end of the record link on UART0: numbers, encodes and
/// sends each frame.
pub struct LinkSender {
    uart: Uart0,
    encoder: link::Encoder,
    records: u32,
    last_t_us: u64,
    requests: link::Decoder,
}

impl LinkSender {
    /// The link on `uart`, its start frame sent.
    pub fn start(uart: Uart0, start: link::Start) -> Self {
        let mut link = Self::new(uart);
        link.send_start(&start);
        link
    }

    /// The link on `uart`, nothing sent yet: the start frame is
    /// [`LinkSender::send_start`]'s, first (the array's, after its
    /// self-test).
    pub fn new(uart: Uart0) -> Self {
        Self {
            uart,
            encoder: link::Encoder::new(),
            records: 0,
            last_t_us: 0,
            requests: link::Decoder::new(),
        }
    }

    /// Send the stream's start frame.
    pub fn send_start(&mut self, start: &link::Start) {
        self.send(|e, out| e.start(start, out));
    }

    /// Number, encode (with one of [`link::Encoder`]'s per-body
    /// encoders) and send one frame; false if it could not be encoded
    /// (nothing is sent then).
    fn send(
        &mut self,
        encode: impl for<'b> FnOnce(&mut link::Encoder, &'b mut [u8]) -> Result<&'b [u8], link::Error>,
    ) -> bool {
        let mut out = [0u8; link::MAX_FRAME];
        match encode(&mut self.encoder, &mut out) {
            Ok(bytes) => {
                self.uart.write(bytes);
                true
            }
            Err(_) => false,
        }
    }

    /// Send one record.
    pub fn record(&mut self, rec: link::Record) {
        self.last_t_us = rec.t_us;
        if self.send(|e, out| e.record(&rec, out)) {
            self.records = self.records.wrapping_add(1);
        }
    }

    /// Send a status (how the CPU keeps up).
    pub fn status(&mut self, status: &link::Status) {
        self.send(|e, out| e.status(status, out));
    }

    /// The time of the last record sent, µs; 0 before the first.
    pub fn last_t_us(&self) -> u64 {
        self.last_t_us
    }

    /// Send the frame of a set applied.
    pub fn applied(&mut self, applied: &link::Applied) {
        self.send(|e, out| e.applied(applied, out));
    }

    /// Send a reply to a request.
    pub fn reply(&mut self, reply: link::Reply) {
        self.send(|e, out| e.reply(&reply, out));
    }

    /// The next request the host sent down the link, with its sequence
    /// number, from the bytes received so far (never waits; frames that
    /// are not requests, or do not check, are passed over).
    pub fn request(&mut self) -> Option<(u32, link::Request)> {
        while let Some(b) = self.uart.read() {
            if let Some(Ok(request)) = self.requests.push_request(b) {
                return Some(request);
            }
        }
        None
    }

    /// Send the end frame: `dropped` records never reached the link.
    pub fn end(&mut self, dropped: u32) {
        let end = link::End {
            records: self.records,
            dropped,
        };
        self.send(|e, out| e.end(&end, out));
    }
}

/// QEMU's clock for [`instrument::busy::Busy`]: SysTick, free-running
/// on the core clock, read as instructions. Under the tests' `-icount
/// shift=7` each instruction takes 128 ns of QEMU's virtual time, and the
/// lm3s6965evb's SysTick ticks at 12.5 MHz: 1.6 ticks an instruction
/// (`dsp-bench` measures the same ratio at its start; the array's test
/// checks a run's figures against the benchmark's).
pub struct Instructions;

impl Instructions {
    /// SysTick started, free-running over its 24 bits.
    pub fn start(mut syst: cortex_m::peripheral::SYST) -> Self {
        syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
        syst.set_reload(0x00ff_ffff);
        syst.clear_current();
        syst.enable_counter();
        Self
    }

    /// The counter now (it counts down).
    pub fn now() -> u32 {
        cortex_m::peripheral::SYST::get_current()
    }

    /// Instructions since `then` (a reading of [`Instructions::now`],
    /// less than 2²⁴ ticks ago).
    pub fn since(then: u32) -> u32 {
        (then.wrapping_sub(Self::now()) & 0x00ff_ffff) * 5 / 8
    }
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

/// `make()` written into `slot` (a static, or a caller's local) from a
/// frame of its own: the value (several KiB, a simulated skin or a
/// reader) is built there and its temporaries are not kept on the stack
/// of the caller (an RTIC `init`, whose frame stays allocated while it
/// runs).
#[inline(never)]
pub fn place<T>(slot: &mut core::mem::MaybeUninit<T>, make: impl FnOnce() -> T) -> &mut T {
    slot.write(make())
}

/// The array's reader built in `slot` ([`place`]), then following mains
/// hum at `mains_hz` from a frame of its own
/// ([`instrument::reader::ArrayReader::follow_mains`]): built together,
/// the two would take the array images' stack past its margin. None
/// where the layout's comb does not lay out.
pub fn place_reader<'a, const N: usize>(
    slot: &'a mut core::mem::MaybeUninit<Result<instrument::reader::ArrayReader, dsp_core::comb::CombError>>,
    layout: instrument::array::Layout,
    sensors: &instrument::sensor::Sensors<N, { instrument::array::SENSORS }>,
    mains_hz: u32,
) -> Option<&'a mut instrument::reader::ArrayReader> {
    let reader = place(slot, || {
        instrument::reader::ArrayReader::with_mains(layout, sensors, None)
    })
    .as_mut()
    .ok()?;
    reader.follow_mains(mains_hz);
    Some(reader)
}
