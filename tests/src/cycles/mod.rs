//! A cycle model of the STM32G474's Cortex-M4, from the instructions QEMU
//! executed: QEMU logs each translated block's instructions (`-d in_asm`)
//! and each block it runs (`-d exec,nochain`); the model walks that
//! stream ([`model::Core`]) once with the code in CCM SRAM and once in
//! flash, and sums each region between two calls of a marker function
//! (the benchmark's measured spans).

pub mod insn;
pub mod model;

use anyhow::{Context, Result};
use insn::Insn;
use model::{Core, Cycles, Memory};
use std::collections::HashMap;
use std::io::BufRead;

/// What one region cost: with all the code in CCM SRAM, all in flash,
/// and as the image places it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Region {
    /// In CCM SRAM.
    pub ccm: Cycles,
    /// In flash, behind the ART.
    pub flash: Cycles,
    /// As placed ([`Memory::Placed`]).
    pub placed: Cycles,
}

/// The regions of a QEMU log read from `log`: the spans between
/// successive executions of the function `marker` (its own instructions
/// not counted), in order; and the whole run's counts. `hot` is the
/// span of the image's hot section ([`Memory::Placed`]).
///
/// A block's `Trace` line says it is about to run; it is counted once
/// the next line shows it did: a `Stopped execution of TB chain` line
/// after it says it did not, and `cpu_io_recompile: rewound execution of
/// TB to ADDR` that it ran only up to ADDR (an I/O access under
/// `-icount`: the rest runs again as a block of its own).
pub fn regions(log: impl BufRead, marker: &str, hot: (u32, u32)) -> Result<(Vec<Region>, Region)> {
    let mut walk = Walk {
        blocks: HashMap::new(),
        cores: [
            Core::new(Memory::Ccm),
            Core::new(Memory::Flash),
            Core::new(Memory::Placed { hot }),
        ],
        regions: vec![],
        open: None,
        in_marker: false,
    };
    let mut translated: Vec<Insn> = vec![];
    let mut translating = false;
    // The block about to run: its host address, and whether it did.
    let mut pending: Option<u64> = None;
    for line in log.lines() {
        let line = line.context("reading the QEMU log")?;
        if line.starts_with("IN:") {
            translating = true;
            translated.clear();
            continue;
        }
        if translating {
            match Insn::parse(&line) {
                Some(i) => translated.push(i),
                None if line.trim().is_empty() => translating = false,
                None => {}
            }
            continue;
        }
        if line.starts_with("Stopped execution of TB chain") {
            pending = None;
            continue;
        }
        if let Some(to) = line.strip_prefix("cpu_io_recompile: rewound execution of TB to ") {
            if let (Some(host), Ok(to)) = (pending.take(), u32::from_str_radix(to.trim(), 16)) {
                walk.run(host, Some(to), Some(to));
            }
            continue;
        }
        let Some((host, pc, symbol)) = trace_line(&line) else {
            continue;
        };
        if !translated.is_empty() {
            // The block just translated is this one.
            walk.blocks
                .insert(host, (std::mem::take(&mut translated), symbol == marker));
        }
        if let Some(prev) = pending.take() {
            walk.run(prev, Some(pc), None);
        }
        pending = Some(host);
    }
    if let Some(prev) = pending {
        walk.run(prev, None, None);
    }
    let whole = Region {
        ccm: walk.cores[0].total,
        flash: walk.cores[1].total,
        placed: walk.cores[2].total,
    };
    Ok((walk.regions, whole))
}

/// The blocks known, the two cores, and the regions so far.
struct Walk {
    blocks: HashMap<u64, (Vec<Insn>, bool)>,
    cores: [Core; 3],
    regions: Vec<Region>,
    /// The counts where the open region began.
    open: Option<[Cycles; 3]>,
    /// Whether the block before was the marker's: a call of it may run
    /// as several blocks (one cut at an I/O access), but counts once.
    in_marker: bool,
}

impl Walk {
    /// Block `host` ran (up to `until`, where it was cut there), `next`
    /// the address run after it: the marker opens or closes a region,
    /// any other block runs on both cores.
    fn run(&mut self, host: u64, next: Option<u32>, until: Option<u32>) {
        let Some(&(_, is_marker)) = self.blocks.get(&host) else {
            return;
        };
        let entered = is_marker && !self.in_marker;
        self.in_marker = is_marker;
        if is_marker && !entered {
            return;
        }
        if entered {
            let now = self.cores.each_ref().map(|c| c.total);
            match self.open.take() {
                None => self.open = Some(now),
                Some(start) => self.regions.push(Region {
                    ccm: now[0] - start[0],
                    flash: now[1] - start[1],
                    placed: now[2] - start[2],
                }),
            }
            return;
        }
        let Some((insns, _)) = self.blocks.get(&host) else {
            return;
        };
        let ran = insns.iter().take_while(|i| until.is_none_or(|u| i.addr < u));
        let ran: Vec<&Insn> = ran.collect();
        for (k, i) in ran.iter().enumerate() {
            let after = ran.get(k + 1).map(|n| n.addr).or(next);
            for c in self.cores.iter_mut() {
                c.step(i, after);
            }
        }
    }
}

/// A benchmark's figure in instructions and in cycles: low and high
/// bounds with all the code in CCM SRAM, all in flash, and as the image
/// places it (its hot section in CCM SRAM, the rest in flash).
#[derive(Clone, Debug, PartialEq)]
pub struct CycleBench {
    /// Its name.
    pub name: String,
    /// Its unit, as the instruction count's (`insn/pair`, `permille`).
    pub unit: String,
    /// As measured (QEMU's instruction count).
    pub insns: f64,
    /// The model's instructions.
    pub model_insns: f64,
    /// Cycles, code in CCM SRAM: low, high.
    pub ccm: (f64, f64),
    /// Cycles, code in flash behind the ART: low, high.
    pub flash: (f64, f64),
    /// Cycles, code as placed: low, high.
    pub placed: (f64, f64),
}

/// The span of `elf`'s hot section (`__shot_ram` … `__ehot_ram`,
/// `firmware/hot-ram.x`) as linked.
pub fn hot_span(elf: &std::path::Path) -> Result<(u32, u32)> {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
    let file = object::File::parse(&*data)?;
    let at = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| s.address() as u32)
            .with_context(|| format!("{}: no symbol {name}", elf.display()))
    };
    Ok((at("__shot_ram")?, at("__ehot_ram")?))
}

/// The benchmark image `elf` run once under QEMU's execution log, its
/// spans' cycles modelled; then run again with each table of the
/// spans' counts (the model's instructions, and each bound's cycles) in
/// place of its clock, so that each figure comes out of the same
/// arithmetic in cycles. Beside `measured` (its instruction counts),
/// for the figures that count (instructions, shares, latencies).
pub fn bench(elf: &std::path::Path, measured: &[crate::Bench]) -> Result<Vec<CycleBench>> {
    let dir = tempfile::tempdir()?;
    let log = dir.path().join("exec.log");
    let log_arg = log.display().to_string();
    let watchdog = std::time::Duration::from_secs(300);
    crate::run_qemu_with(elf, &[], &["-d", "in_asm,exec,nochain", "-D", &log_arg], watchdog)?.ok()?;
    let file = std::fs::File::open(&log).context("the execution log")?;
    let (regions, _) = regions(std::io::BufReader::new(file), "bench_region", hot_span(elf)?)?;
    std::fs::remove_file(&log)?;
    let picks: [fn(&Region) -> u64; 7] = [
        |r| r.ccm.insns,
        |r| r.ccm.lo,
        |r| r.ccm.hi,
        |r| r.flash.lo,
        |r| r.flash.hi,
        |r| r.placed.lo,
        |r| r.placed.hi,
    ];
    let mut runs = vec![];
    for (k, pick) in picks.iter().enumerate() {
        let table = dir.path().join(format!("table{k}.bin"));
        let bytes: Vec<u8> = regions
            .iter()
            .flat_map(|r| u32::try_from(pick(r)).unwrap_or(u32::MAX).to_le_bytes())
            .collect();
        std::fs::write(&table, bytes)?;
        let arg = format!("cycles={}", table.display());
        let run = crate::run_qemu_with(elf, &[&arg], &[], watchdog)?.ok()?;
        runs.push(crate::parse_bench(&run.stdout));
    }
    let value = |k: usize, name: &str| runs[k].iter().find(|b| b.name == name).map(|b| b.value);
    Ok(measured
        .iter()
        .filter(|b| b.unit.starts_with("insn") || b.unit == "permille" || b.unit == "us")
        .filter_map(|b| {
            Some(CycleBench {
                name: b.name.clone(),
                unit: b.unit.clone(),
                insns: b.value,
                model_insns: value(0, &b.name)?,
                ccm: (value(1, &b.name)?, value(2, &b.name)?),
                flash: (value(3, &b.name)?, value(4, &b.name)?),
                placed: (value(5, &b.name)?, value(6, &b.name)?),
            })
        })
        .collect())
}

/// A `-d exec` line: the block's host address, its guest PC and its
/// symbol (`Trace 0: 0x7fe268000100 [00800408/000000f0/00000110/ff020200] Reset`).
fn trace_line(line: &str) -> Option<(u64, u32, &str)> {
    let rest = line.strip_prefix("Trace ")?;
    let (_, rest) = rest.split_once(": 0x")?;
    let (host, rest) = rest.split_once(" [")?;
    let (fields, symbol) = rest.split_once("] ")?;
    let pc = fields.split('/').nth(1)?;
    Some((
        u64::from_str_radix(host, 16).ok()?,
        u32::from_str_radix(pc, 16).ok()?,
        symbol.trim(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_reads_as_regions_between_markers() {
        let log = "\
----------------
IN: main
0x00000100:  f000 f810  bl       #0x124

Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] main
----------------
IN: mark
0x00000124:  4770       bx       lr

Trace 0: 0x7f0000000200 [00800408/00000124/00000110/ff020200] mark
----------------
IN: main
0x00000104:  3001       adds     r0, #1
0x00000106:  3901       subs     r1, #1
0x00000108:  d1fc       bne      #0x104

Trace 0: 0x7f0000000300 [00800408/00000104/00000110/ff020200] main
Trace 0: 0x7f0000000300 [00800408/00000104/00000110/ff020200] main
----------------
IN: main
0x0000010a:  f000 f80b  bl       #0x124

Trace 0: 0x7f0000000400 [00800408/0000010a/00000110/ff020200] main
Trace 0: 0x7f0000000200 [00800408/00000124/00000110/ff020200] mark
";
        let (regions, whole) = regions(log.as_bytes(), "mark", (0, 0)).unwrap();
        assert_eq!(regions.len(), 1);
        let r = regions[0];
        // Two turns of three instructions (the first branch taken, 1 + P
        // with P from 1 to 3; the second not), and the call of the
        // marker (taken).
        assert_eq!(r.ccm.insns, 7);
        assert_eq!((r.ccm.lo, r.ccm.hi), (3 + 1 + 3 + 2, 3 + 3 + 3 + 4));
        // From flash: a sequential miss the prefetch hides (low), or not.
        assert!(r.flash.lo >= r.ccm.lo && r.flash.hi > r.ccm.hi);
        // The marker's own instructions are in no count.
        assert_eq!(whole.ccm.insns, 8);
    }
}
