//! One Thumb-2 instruction as QEMU's `-d in_asm` log prints it, sorted
//! into the classes of the Cortex-M4's instruction timings (Cortex-M4
//! Technical Reference Manual, r0p1, §3.3 "Processor instruction
//! timings", and the FPU's, §7.2 "FPU instruction set").

/// What an instruction costs, by class.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Data processing, moves, compares, shifts, bit fields, single-cycle
    /// multiplies (MUL, UMULL, SMULL, UMLAL, SMLAL, SMMUL…, the DSP
    /// extension's): 1.
    Alu,
    /// MLA, MLS: 2.
    MulAcc,
    /// SDIV, UDIV: 2 to 12 (early termination by the operands).
    Div,
    /// A single load (LDR, LDRH, LDRB, LDRSH, LDRSB, LDREX): 2, 1 when
    /// pipelined after another single load or store.
    Load,
    /// A single store: 2, 1 when pipelined.
    Store,
    /// LDRD, STRD: 3.
    Double,
    /// LDM, STM, PUSH, POP of n registers: 1 + n.
    Multiple(u8),
    /// A branch (B, BL, BX, BLX, CBZ, CBNZ, TBB, TBH): 1, or 1 + P when
    /// taken (P, the pipeline refill: 1 to 3); TBB/TBH one more.
    Branch,
    /// IT: 1, or none when folded onto the 16-bit instruction before.
    It,
    /// VADD, VSUB, VMUL, VNMUL, VABS, VNEG, VCMP, VCVT, VMOV, VMRS: 1.
    Fpu,
    /// VMLA, VMLS, VNMLA, VNMLS, VFMA, VFMS: 3.
    FpuMac,
    /// VDIV, VSQRT: 14.
    FpuLong,
    /// VLDR, VSTR: 2.
    FpuMem,
    /// VLDM, VSTM, VPUSH, VPOP of n registers: 1 + n.
    FpuMultiple(u8),
    /// ISB, DSB, DMB: 1 + P (they drain the pipeline).
    Barrier,
}

/// One instruction.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Insn {
    /// Its address.
    pub addr: u32,
    /// Its length, bytes (2 or 4).
    pub len: u8,
    /// Its cost class.
    pub class: Class,
    /// Executed only if its condition holds (a conditional branch, or
    /// an instruction in an IT block).
    pub conditional: bool,
    /// Where it branches, when the target is in the instruction.
    pub target: Option<u32>,
    /// Whether it writes the PC (a branch taken, a POP or LDR of PC).
    pub writes_pc: bool,
    /// Whether it loads from the literal pool (`[pc, …]`): a data read
    /// of flash where the code is in flash.
    pub literal: bool,
    /// The register it writes first (its destination), if a core one.
    pub dest: Option<u8>,
    /// The base register of its address, if it addresses memory.
    pub base: Option<u8>,
}

/// The condition codes a mnemonic may end with.
const CONDITIONS: [&str; 16] = [
    "eq", "ne", "hs", "cs", "lo", "cc", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

impl Insn {
    /// An instruction of the log's line `line`
    /// (`0x000000f4:  480e       ldr      r0, [pc, #0x38]`); None for a
    /// line that is not one.
    pub fn parse(line: &str) -> Option<Self> {
        let (addr, rest) = line.split_once(":  ")?;
        let addr = u32::from_str_radix(addr.strip_prefix("0x")?, 16).ok()?;
        let rest = rest.trim_start();
        let (hex, rest) = rest.split_once("  ")?;
        let len = match hex.split(' ').filter(|h| h.len() == 4).count() {
            1 => 2,
            2 => 4,
            _ => return None,
        };
        let rest = rest.trim_start();
        let (mnemonic, operands) = rest.split_once(' ').unwrap_or((rest, ""));
        let operands = operands.trim();
        let base = mnemonic.split('.').next().unwrap_or(mnemonic);
        let (stem, conditional) = strip_condition(base);
        let class = classify(stem, operands);
        let writes_pc = matches!(class, Class::Branch)
            || (operands.contains("pc}") && matches!(class, Class::Multiple(_)))
            || (matches!(class, Class::Load) && operands.starts_with("pc,"));
        let is_branch = matches!(class, Class::Branch);
        Some(Self {
            addr,
            len,
            class,
            conditional: conditional || (is_branch && is_conditional_branch(stem)),
            target: is_branch.then(|| branch_target(operands)).flatten(),
            writes_pc,
            literal: operands.contains("[pc"),
            dest: first_register(operands),
            base: base_register(operands),
        })
    }

    /// The address after it.
    pub fn next(&self) -> u32 {
        self.addr + u32::from(self.len)
    }
}

/// The mnemonic without its condition code, and whether it had one
/// (`movlo` → `mov`; `bls` → `b`, a conditional branch). A name that
/// merely ends in a condition's letters (`vmls`, `mls`, `teq`, `bics`)
/// is not cut: what is left of it is no instruction's name.
fn strip_condition(m: &str) -> (&str, bool) {
    for c in CONDITIONS {
        if let Some(stem) = m.strip_suffix(c) {
            if known_stem(stem) {
                return (stem, true);
            }
        }
    }
    (m, false)
}

/// Whether `s` is an instruction's name (to tell `blt` = `b` + `lt` from
/// a name that ends in a condition's letters).
fn known_stem(s: &str) -> bool {
    let s = s
        .strip_suffix('s')
        .filter(|t| !t.is_empty() && known_base(t))
        .unwrap_or(s);
    known_base(s)
}

fn known_base(s: &str) -> bool {
    matches!(
        s,
        "b" | "bl"
            | "bx"
            | "blx"
            | "mov"
            | "movw"
            | "movt"
            | "add"
            | "addw"
            | "sub"
            | "subw"
            | "adc"
            | "sbc"
            | "rsb"
            | "and"
            | "orr"
            | "eor"
            | "bic"
            | "mvn"
            | "orn"
            | "cmp"
            | "cmn"
            | "tst"
            | "teq"
            | "lsl"
            | "lsr"
            | "asr"
            | "ror"
            | "rrx"
            | "mul"
            | "mla"
            | "mls"
            | "ldr"
            | "ldrb"
            | "ldrh"
            | "ldrsb"
            | "ldrsh"
            | "ldrd"
            | "str"
            | "strb"
            | "strh"
            | "strd"
            | "ldm"
            | "stm"
            | "push"
            | "pop"
            | "clz"
            | "smull"
            | "umull"
            | "smlal"
            | "umlal"
            | "vmov"
            | "vldr"
            | "vstr"
            | "vcmp"
            | "vmrs"
            | "vadd"
            | "vsub"
            | "vmul"
            | "vneg"
            | "vabs"
            | "asrs"
            | "lsls"
            | "lsrs"
            | "sxth"
            | "uxth"
            | "sxtb"
            | "uxtb"
    )
}

fn is_conditional_branch(stem: &str) -> bool {
    matches!(stem, "cbz" | "cbnz")
}

/// The class of an instruction named `stem` (no condition) with
/// `operands`.
fn classify(stem: &str, operands: &str) -> Class {
    let list = || {
        let inner = operands
            .split_once('{')
            .and_then(|(_, r)| r.split_once('}'))
            .map_or("", |(l, _)| l);
        register_count(inner)
    };
    match stem {
        "b" | "bl" | "bx" | "blx" | "cbz" | "cbnz" | "tbb" | "tbh" => Class::Branch,
        s if s.starts_with("it") && s[2..].chars().all(|c| c == 't' || c == 'e') => Class::It,
        "mla" | "mls" => Class::MulAcc,
        "sdiv" | "udiv" => Class::Div,
        "ldrd" | "strd" => Class::Double,
        "ldm" | "ldmia" | "ldmdb" | "stm" | "stmia" | "stmdb" | "push" | "pop" => Class::Multiple(list()),
        "vmla" | "vmls" | "vnmla" | "vnmls" | "vfma" | "vfms" | "vfnma" | "vfnms" => Class::FpuMac,
        "vdiv" | "vsqrt" => Class::FpuLong,
        "vldr" | "vstr" => Class::FpuMem,
        "vldm" | "vldmia" | "vldmdb" | "vstm" | "vstmia" | "vstmdb" | "vpush" | "vpop" => {
            Class::FpuMultiple(list())
        }
        "isb" | "dsb" | "dmb" => Class::Barrier,
        s if s.starts_with("ldr") || s.starts_with("ldrex") => Class::Load,
        s if s.starts_with("str") => Class::Store,
        s if s.starts_with('v') => Class::Fpu,
        _ => Class::Alu,
    }
}

/// Registers in a list's inside (`r4, r5, r6, r7, lr` or `s16-s23`).
fn register_count(inner: &str) -> u8 {
    inner
        .split(',')
        .map(str::trim)
        .filter(|r| !r.is_empty())
        .map(|r| match r.split_once('-') {
            Some((a, b)) => {
                let n = |x: &str| {
                    x.trim_start_matches(|c: char| c.is_ascii_alphabetic())
                        .parse::<u8>()
                        .ok()
                };
                match (n(a), n(b)) {
                    (Some(a), Some(b)) if b >= a => b - a + 1,
                    _ => 1,
                }
            }
            None => 1,
        })
        .sum()
}

/// A branch's target from its operands (`#0x1c854`).
fn branch_target(operands: &str) -> Option<u32> {
    let hex = operands.rsplit('#').next()?.trim().strip_prefix("0x")?;
    u32::from_str_radix(hex, 16).ok()
}

/// A core register's number (`r0`…`r12`, `sb`, `sl`, `fp`, `ip`, `sp`,
/// `lr`, `pc`).
fn register(name: &str) -> Option<u8> {
    let name = name.trim().trim_end_matches('!');
    match name {
        "sb" => Some(9),
        "sl" => Some(10),
        "fp" => Some(11),
        "ip" => Some(12),
        "sp" => Some(13),
        "lr" => Some(14),
        "pc" => Some(15),
        _ => name.strip_prefix('r')?.parse().ok().filter(|&n| n < 16),
    }
}

/// The first operand, where it is a core register.
fn first_register(operands: &str) -> Option<u8> {
    register(operands.split(',').next()?)
}

/// The base register of a memory operand (`[r3, #4]`, `r0!, {…}`).
fn base_register(operands: &str) -> Option<u8> {
    if let Some((_, rest)) = operands.split_once('[') {
        return register(rest.split([',', ']']).next()?);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_parse_to_their_classes() {
        let i = Insn::parse("0x000000f4:  480e       ldr      r0, [pc, #0x38]").unwrap();
        assert_eq!(
            (i.addr, i.len, i.class, i.literal, i.dest, i.base),
            (0xf4, 2, Class::Load, true, Some(0), Some(15))
        );
        let i = Insn::parse("0x000000f0:  f01c fbb0  bl       #0x1c854").unwrap();
        assert_eq!(
            (i.len, i.class, i.target, i.conditional),
            (4, Class::Branch, Some(0x1c854), false)
        );
        let i = Insn::parse("0x000000fc:  d001       beq      #0x102").unwrap();
        assert_eq!(
            (i.class, i.target, i.conditional),
            (Class::Branch, Some(0x102), true)
        );
        let i = Insn::parse("0x0001c858:  bd80       pop      {r7, pc}").unwrap();
        assert_eq!((i.class, i.writes_pc), (Class::Multiple(2), true));
        let i = Insn::parse("0x00000100:  e8bd 4ff0  pop.w    {r4, r5, r6, r7, r8, sb, sl, fp, lr}").unwrap();
        assert_eq!((i.class, i.writes_pc), (Class::Multiple(9), false));
        let i = Insn::parse("0x00000200:  ed2d 8b08  vpush    {d8, d9, d10, d11}").unwrap();
        assert_eq!(i.class, Class::FpuMultiple(4));
        let i = Insn::parse("0x00000204:  ee00 0a20  vmla.f32 s0, s0, s1").unwrap();
        assert_eq!(i.class, Class::FpuMac);
        let i = Insn::parse("0x00000208:  ee80 0a20  vmls.f32 s0, s0, s1").unwrap();
        assert_eq!((i.class, i.conditional), (Class::FpuMac, false));
        let i = Insn::parse("0x0000020c:  bf38       it       lo").unwrap();
        assert_eq!(i.class, Class::It);
        let i = Insn::parse("0x0000020e:  2301       movlo    r3, #1").unwrap();
        assert_eq!((i.class, i.conditional), (Class::Alu, true));
        let i = Insn::parse("0x00000210:  fb91 f2f3  sdiv     r2, r1, r3").unwrap();
        assert_eq!(i.class, Class::Div);
        let i = Insn::parse("0x00000214:  e9d0 2300  ldrd     r2, r3, [r0]").unwrap();
        assert_eq!((i.class, i.base), (Class::Double, Some(0)));
        let i = Insn::parse("0x00000218:  f8b0 1004  ldrhls.w r1, [r0, #4]").unwrap();
        assert_eq!((i.class, i.conditional), (Class::Load, true));
        let i = Insn::parse("0x0000021c:  fb00 2103  mls      r1, r0, r3, r2").unwrap();
        assert_eq!((i.class, i.conditional), (Class::MulAcc, false));
        let i = Insn::parse("0x00000220:  d9f0       bls      #0x204").unwrap();
        assert_eq!(
            (i.class, i.conditional, i.target),
            (Class::Branch, true, Some(0x204))
        );
        let i = Insn::parse("0x00000222:  fba0 2301  umull    r2, r3, r0, r1").unwrap();
        assert_eq!(i.class, Class::Alu);
        assert!(Insn::parse("Trace 0: 0x7fe268000100 [00800408/000000f0/00000110/ff020200] Reset").is_none());
    }
}
