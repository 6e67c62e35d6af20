//! The Cortex-M4's cycles for a stream of executed instructions: each
//! instruction's cost by its class (Cortex-M4 TRM r0p1, §3.3 and §7.2),
//! load and store pipelining, taken branches' refill, an address that
//! waits on the instruction before; and where the code runs from: CCM
//! SRAM on the instruction bus (no wait state), or the STM32G474's flash
//! at 4 wait states (170 MHz, RM0440 §3.3.3) behind its ART accelerator
//! (a 1 KiB instruction cache, a 256 B data cache, both taken as fully
//! associative with the least recently used word out, and the prefetch
//! of the next sequential 64-bit word). A low and a high bound where the
//! documents leave a range.

use super::insn::{Class, Insn};
use std::collections::VecDeque;

/// Flash wait states at 170 MHz.
pub const WAIT_STATES: u64 = 4;
/// The ART's instruction cache, in 64-bit words (1 KiB).
const ICACHE_WORDS: usize = 128;
/// The ART's data cache, in 64-bit words (256 B).
const DCACHE_WORDS: usize = 32;

/// Cycles counted, low and high.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cycles {
    /// Instructions.
    pub insns: u64,
    /// Cycles, the low bound.
    pub lo: u64,
    /// Cycles, the high bound.
    pub hi: u64,
}

impl std::ops::Sub for Cycles {
    type Output = Cycles;
    fn sub(self, o: Cycles) -> Cycles {
        Cycles {
            insns: self.insns - o.insns,
            lo: self.lo - o.lo,
            hi: self.hi - o.hi,
        }
    }
}

/// Where the code runs from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Memory {
    /// CCM SRAM on the instruction bus: no wait state.
    Ccm,
    /// Flash behind the ART accelerator.
    Flash,
    /// As the image places it: the span `hot` (the section the firmware
    /// links for CCM SRAM, `firmware/hot-ram.x`) and any address from
    /// 0x1000_0000 up (CCM SRAM, or SRAM) at
    /// no wait state, the rest in flash.
    Placed {
        /// The hot section's addresses, start and end.
        hot: (u32, u32),
    },
}

impl Memory {
    /// Whether code at `addr` is fetched at no wait state.
    fn zero_wait(&self, addr: u32) -> bool {
        match *self {
            Memory::Ccm => true,
            Memory::Flash => false,
            Memory::Placed { hot: (start, end) } => addr >= 0x1000_0000 || (start..end).contains(&addr),
        }
    }
}

/// A cache of 64-bit words, fully associative, the least recently used
/// out first.
struct WordCache {
    words: VecDeque<u32>,
    capacity: usize,
}

impl WordCache {
    fn new(capacity: usize) -> Self {
        Self {
            words: VecDeque::with_capacity(capacity),
            capacity,
        }
    }

    /// Look `word` up: whether it was there (it is after).
    fn touch(&mut self, word: u32) -> bool {
        let hit = match self.words.iter().position(|&w| w == word) {
            Some(k) => {
                self.words.remove(k);
                true
            }
            None => {
                if self.words.len() == self.capacity {
                    self.words.pop_back();
                }
                false
            }
        };
        self.words.push_front(word);
        hit
    }
}

/// The model's state: the instruction before, and the flash's caches.
pub struct Core {
    memory: Memory,
    prev: Option<Insn>,
    icache: WordCache,
    dcache: WordCache,
    /// The 64-bit word being executed, and the cycles (low, high) spent
    /// in it so far.
    word: Option<u32>,
    in_word: (u64, u64),
    /// The counts so far.
    pub total: Cycles,
}

impl Core {
    /// A core running code from `memory`.
    pub fn new(memory: Memory) -> Self {
        Self {
            memory,
            prev: None,
            icache: WordCache::new(ICACHE_WORDS),
            dcache: WordCache::new(DCACHE_WORDS),
            word: None,
            in_word: (0, 0),
            total: Cycles::default(),
        }
    }

    /// Execute `i`; `next` is the address executed after it (to tell a
    /// branch taken).
    pub fn step(&mut self, i: &Insn, next: Option<u32>) {
        let (mut lo, mut hi) = self.fetch(i);
        let (clo, chi) = self.cost(i, next);
        lo += clo;
        hi += chi;
        if i.literal && !self.memory.zero_wait(i.addr) {
            let at = ((i.addr + 4) & !3) >> 3;
            let wait = if self.dcache.touch(at) { 0 } else { WAIT_STATES };
            lo += wait;
            hi += wait;
        }
        self.in_word.0 += lo;
        self.in_word.1 += hi;
        self.total.insns += 1;
        self.total.lo += lo;
        self.total.hi += hi;
        self.prev = Some(i.clone());
    }

    /// The fetch of `i`'s first 64-bit word where it starts one: no wait
    /// in CCM SRAM or on a cache hit; a miss waits for the flash: in the
    /// low bound, a sequential one only for what the prefetch did not
    /// cover while the word before ran; in the high bound (no prefetch)
    /// every one fully.
    fn fetch(&mut self, i: &Insn) -> (u64, u64) {
        let word = i.addr >> 3;
        if self.word == Some(word) {
            return (0, 0);
        }
        let sequential = self.word.is_some_and(|w| w + 1 == word);
        let spent = self.in_word;
        self.word = Some(word);
        self.in_word = (0, 0);
        if self.memory.zero_wait(i.addr) {
            return (0, 0);
        }
        if self.icache.touch(word) {
            return (0, 0);
        }
        let lo = match sequential {
            true => (WAIT_STATES + 1).saturating_sub(spent.0),
            false => WAIT_STATES,
        };
        (lo, WAIT_STATES)
    }

    /// `i`'s own cycles, low and high, at no wait state.
    fn cost(&self, i: &Insn, next: Option<u32>) -> (u64, u64) {
        let taken = i.writes_pc && next.is_none_or(|n| n != i.next());
        // A taken branch refills the pipeline: 1 to 3 cycles.
        let refill = if taken { (1, 3) } else { (0, 0) };
        let prev = self.prev.as_ref().map(|p| p.class);
        // An address that waits on the instruction before's result.
        let waits = match (i.base, self.prev.as_ref().and_then(|p| p.dest)) {
            (Some(b), Some(d)) if b == d && b != 13 && b != 15 => 1,
            _ => 0,
        };
        let (lo, hi) = match i.class {
            Class::Alu => (1, 1),
            Class::MulAcc => (2, 2),
            Class::Div => (2, 12),
            Class::Load | Class::Store => {
                // Neighbouring single loads and stores pipeline their
                // address and data phases: one cycle after a load (low
                // bound: after a store too).
                let lo = if matches!(prev, Some(Class::Load | Class::Store)) {
                    1
                } else {
                    2
                };
                let hi = if matches!(prev, Some(Class::Load)) { 1 } else { 2 };
                (lo + waits, hi + waits)
            }
            Class::Double => (3 + waits, 3 + waits),
            Class::Multiple(n) => (1 + u64::from(n), 1 + u64::from(n)),
            Class::Branch => (1, 1),
            Class::It => (0, 1),
            Class::Fpu => (1, 1),
            Class::FpuMac => (3, 3),
            Class::FpuLong => (14, 14),
            Class::FpuMem => (2 + waits, 2 + waits),
            Class::FpuMultiple(n) => (1 + u64::from(n), 1 + u64::from(n)),
            Class::Barrier => (2, 4),
        };
        // An instruction whose condition fails takes one cycle (low).
        let lo = if i.conditional && !taken { lo.min(1) } else { lo };
        (lo + refill.0, hi + refill.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(memory: Memory, lines: &[&str]) -> Cycles {
        let insns: Vec<Insn> = lines.iter().map(|l| Insn::parse(l).unwrap()).collect();
        let mut core = Core::new(memory);
        // The last falls through.
        for (k, i) in insns.iter().enumerate() {
            core.step(i, Some(insns.get(k + 1).map_or(i.next(), |n| n.addr)));
        }
        core.total
    }

    /// Sequences whose cycles the TRM gives, in CCM SRAM.
    #[test]
    fn sequences_cost_what_the_trm_says() {
        // Three independent loads: 2 + 1 + 1 (pipelined).
        let c = run(
            Memory::Ccm,
            &[
                "0x00000000:  6801       ldr      r1, [r0]",
                "0x00000002:  6842       ldr      r2, [r0, #4]",
                "0x00000004:  6883       ldr      r3, [r0, #8]",
            ],
        );
        assert_eq!((c.insns, c.lo, c.hi), (3, 4, 4));
        // A load whose address the instruction before computed: 1 + 2 + 1.
        let c = run(
            Memory::Ccm,
            &[
                "0x00000000:  3004       adds     r0, #4",
                "0x00000002:  6801       ldr      r1, [r0]",
            ],
        );
        assert_eq!((c.lo, c.hi), (4, 4));
        // PUSH of 4: 1 + 4; LDRD: 3; VMLA 3; VDIV 14; MLA 2.
        let c = run(
            Memory::Ccm,
            &[
                "0x00000000:  b5f0       push     {r4, r5, r6, r7, lr}",
                "0x00000002:  e9d1 2300  ldrd     r2, r3, [r1]",
                "0x00000006:  ee00 0a20  vmla.f32 s0, s0, s1",
                "0x0000000a:  ee80 0a20  vdiv.f32 s0, s0, s1",
                "0x0000000e:  fb00 2103  mla      r1, r0, r3, r2",
            ],
        );
        assert_eq!((c.lo, c.hi), (6 + 3 + 3 + 14 + 2, 6 + 3 + 3 + 14 + 2));
        // A taken branch: 1 + P, P from 1 to 3; not taken: 1.
        let taken = run(
            Memory::Ccm,
            &[
                "0x00000000:  e7fe       b        #0x10",
                "0x00000010:  2000       movs     r0, #0",
            ],
        );
        assert_eq!((taken.lo, taken.hi), (3, 5));
        let not = run(
            Memory::Ccm,
            &[
                "0x00000000:  d007       beq      #0x12",
                "0x00000002:  2000       movs     r0, #0",
            ],
        );
        assert_eq!((not.lo, not.hi), (2, 2));
    }

    /// From flash: a first fetch of a word waits 4 states; a word in the
    /// cache waits none.
    #[test]
    fn flash_waits_on_a_miss_and_not_on_a_hit() {
        let body = [
            "0x00000100:  3001       adds     r0, #1",
            "0x00000102:  3901       subs     r1, #1",
            "0x00000104:  d1fc       bne      #0x100",
        ];
        let once = run(Memory::Flash, &body);
        assert_eq!((once.lo, once.hi), (3 + 4, 3 + 4));
        let mut twice = body.to_vec();
        twice.extend(body);
        let c = run(Memory::Flash, &twice);
        // The second turn: the branch before it taken (1 + P), no wait.
        assert_eq!((c.lo - once.lo, c.hi - once.hi), (3 + 1, 3 + 3));
        let ccm = run(Memory::Ccm, &twice);
        assert_eq!(c.lo - ccm.lo, 4);
    }

    /// As placed: code in the hot span or above 0x1000_0000 as in CCM
    /// SRAM, the rest as in flash.
    #[test]
    fn placed_code_waits_only_outside_the_hot_span() {
        let body = [
            "0x00000100:  3001       adds     r0, #1",
            "0x00000102:  3901       subs     r1, #1",
            "0x00000104:  d1fc       bne      #0x100",
        ];
        let hot = Memory::Placed { hot: (0x100, 0x108) };
        assert_eq!(run(hot, &body), run(Memory::Ccm, &body));
        let cold = Memory::Placed { hot: (0x200, 0x208) };
        assert_eq!(run(cold, &body), run(Memory::Flash, &body));
        let sram = ["0x20000100:  3001       adds     r0, #1"];
        assert_eq!(run(cold, &sram), run(Memory::Ccm, &sram));
    }
}
