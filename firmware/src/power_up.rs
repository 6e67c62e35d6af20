//! The array's power-up self-test in an image ([`instrument::selftest`]):
//! the first blocks after reset read the reference network and every
//! path, no record is made of them, and the result goes into the start
//! frame, which is sent only then. Each path's figures are logged; the
//! reader refuses the records of the paths that failed.

use dsp_core::comb::Tones;
use dsp_core::demod::FrontEnd;
use instrument::array::{Layout, TONES};
use instrument::reader::{ArrayReader, Demodulated};
use instrument::selftest::{Limits, Outcome, SelfTest, PATHS};

/// The self-test while it runs, then nothing.
pub struct PowerUp {
    test: Option<SelfTest>,
}

impl PowerUp {
    /// A test of blocks of `layout`, from the first block.
    pub fn new(layout: Layout) -> Self {
        Self {
            test: Some(SelfTest::new(layout)),
        }
    }

    /// Blocks the test takes from the start.
    pub fn blocks(layout: Layout) -> u64 {
        SelfTest::new(layout).blocks_needed() as u64
    }

    /// Is the test still reading blocks (none of them to be recorded)?
    pub fn testing(&self) -> bool {
        self.test.is_some()
    }

    /// One block of the test: the reader's sums of it, the reference's,
    /// the inputs on a rail. When it was the last: the result logged,
    /// the failing paths' sensors refused by `reader`, and the start
    /// frame's field returned.
    pub fn block(
        &mut self,
        reader: &mut ArrayReader,
        block: &Demodulated,
        reference: &Tones<TONES>,
        rail: impl Fn(usize) -> bool,
        front_end: &FrontEnd,
    ) -> Option<link::SelfTest> {
        let test = self.test.as_mut()?;
        test.add(block, reference, rail);
        if !test.done() {
            return None;
        }
        let out = test.outcome(front_end, reader.reference_rotation(), &Limits::DEFAULT);
        self.test = None;
        log(&out);
        reader.refuse(out.refused());
        Some(out.frame())
    }
}

/// Each path's figures, the reference's, and the verdict.
fn log(out: &Outcome) {
    for p in 0..PATHS {
        log_path(out, p);
    }
    for k in 0..TONES {
        log_tone(out, k);
    }
    if out.passed() {
        defmt::println!("self-test passed");
    } else {
        defmt::println!(
            "self-test failed: paths {=u32:#x}, sensors refused {=u16:#x}",
            out.failed,
            out.refused()
        );
    }
}

/// Path `p`'s line (out of line: a loop of calls, not a copy a path).
#[inline(never)]
fn log_path(out: &Outcome, p: usize) {
    defmt::println!(
        "self-test path {=usize}: offset {=f32} counts, noise {=f32}x{=str}{=str}",
        p,
        out.offset_counts[p],
        out.noise[p],
        if out.failed & 1 << p != 0 { ", FAILED" } else { "" },
        if out.noisy & 1 << p != 0 { ", noisy" } else { "" },
    );
}

/// The comb's tone `k`'s line (the word "tone" would read as a record's
/// keyword to the log's decoder).
#[inline(never)]
fn log_tone(out: &Outcome, k: usize) {
    defmt::println!(
        "self-test comb {=usize}: excitation {=f32} %, reference |Z| {=f32} %, phase {=f32} mrad",
        k,
        out.excitation[k] * 100.0,
        out.gain[k] * 100.0,
        out.phase_rad[k] * 1e3,
    );
}
