//! How deep the stack went: paint the free stack with a pattern at start,
//! and at the end find the deepest word that no longer holds it. There is
//! no stack guard on these targets (no flip-link, no MPU region): a stack
//! that grows into the statics corrupts them silently, so the QEMU tests
//! hold every image to a margin (`qemu_tests::STACK_MARGIN`) measured
//! this way.
//!
//! The stack is cortex-m-rt's: from `_stack_start` (the top of RAM) down
//! to `_stack_end` (the end of the statics).

/// The pattern of a word never written.
const PAINT: u32 = 0xDEAD_57AC;

/// Bytes left below the caller's frame unpainted (the painting loop's own
/// frame and what an interrupt could push meanwhile).
const SLACK: usize = 256;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The stack's top and bottom addresses (the linker's symbols; only
/// their addresses are taken).
fn bounds() -> (usize, usize) {
    (
        core::ptr::addr_of!(_stack_start) as usize,
        core::ptr::addr_of!(_stack_end) as usize,
    )
}

/// Paint the stack below the caller's frame (call first thing in `init`,
/// interrupts off).
#[inline(never)]
pub fn paint() {
    let (_, bottom) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let mut at = bottom;
    while at + 4 <= sp.saturating_sub(SLACK) {
        // SAFETY: between the statics' end and the live stack: memory no
        // Rust object owns, written before any frame grows into it.
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::write_volatile(at as *mut u32, PAINT)
        };
        at += 4;
    }
}

/// (bytes of stack used at the deepest, bytes never touched) since
/// [`paint`].
pub fn high_water() -> (u32, u32) {
    let (top, bottom) = bounds();
    let mut at = bottom;
    // SAFETY: reads of the stack region below the live frames, words
    // aligned (both bounds are).
    #[allow(unsafe_code)]
    while at < top && unsafe { core::ptr::read_volatile(at as *const u32) } == PAINT {
        at += 4;
    }
    ((top - at) as u32, (at - bottom) as u32)
}
