//! Firmware records decoded from defmt, and their CSV in the interchange
//! format (`shared/data-format.md`): one trace file per channel and
//! excitation frequency, since the format wants a constant frequency per
//! trace and the firmware changes it.

use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// Flag bits (as `firmware::faults::Flags`).
pub mod flags {
    /// ADC clipped.
    pub const CLIPPED: u8 = 1;
    /// Open sensor.
    pub const OPEN: u8 = 2;
    /// Shorted sensor.
    pub const SHORTED: u8 = 4;
    /// Inversion out of range.
    pub const RANGE: u8 = 8;
    /// Settling after a switch.
    pub const SETTLING: u8 = 16;
    /// C held (ill-conditioned).
    pub const HELD: u8 = 32;
    /// Flags that make C untrustworthy.
    pub const INVALID: u8 = CLIPPED | OPEN | SHORTED | RANGE | SETTLING;
}

/// One `rec` line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rec {
    /// Block start, ms.
    pub t_ms: u32,
    /// Channel.
    pub channel: u8,
    /// Excitation frequency, Hz.
    pub freq_hz: f64,
    /// Lumped Cs, pF.
    pub cs_pf: f64,
    /// Lumped Rs, Ω.
    pub rs_ohm: f64,
    /// Line-corrected C, pF.
    pub c_pf: f64,
    /// Line-corrected R (both electrodes), Ω.
    pub r_ohm: f64,
    /// Stretch from the calibration, mm.
    pub stretch_mm: f64,
    /// Flag bits.
    pub flags: u8,
    /// The simulated truth of the same block (QEMU only).
    pub truth: Option<Truth>,
}

/// One `truth` line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Truth {
    /// True line capacitance, pF.
    pub c_pf: f64,
    /// True line resistance, Ω.
    pub r_ohm: f64,
    /// True stretch, mm.
    pub stretch_mm: f64,
    /// End-to-end top electrode resistance, as the rig's ohmmeter reads
    /// it through the tabs, Ω.
    pub r_top_ohm: f64,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom_ohm: f64,
}

impl Rec {
    /// True if C can be trusted.
    pub fn valid(&self) -> bool {
        self.flags & flags::INVALID == 0
    }
}

/// Parse decoded defmt lines into records, pairing each with the truth
/// line of the same block.
pub fn parse(lines: &[String]) -> Result<Vec<Rec>> {
    let mut out = vec![];
    let mut truth: BTreeMap<(u32, u8), Truth> = BTreeMap::new();
    for (n, l) in lines.iter().enumerate() {
        let w: Vec<&str> = l.split_whitespace().collect();
        let num = |i: usize| -> Result<f64> {
            w.get(i)
                .and_then(|v| v.parse::<f64>().ok())
                .with_context(|| format!("record {}: field {i} of '{l}'", n + 1))
        };
        match w.first() {
            Some(&"truth") => {
                truth.insert(
                    (num(1)? as u32, num(2)? as u8),
                    Truth {
                        c_pf: num(3)?,
                        r_ohm: num(4)?,
                        stretch_mm: num(5)?,
                        r_top_ohm: num(6)?,
                        r_bottom_ohm: num(7)?,
                    },
                );
            }
            Some(&"rec") => {
                if w.len() != 10 {
                    bail!("record {}: expected 10 fields in '{l}'", n + 1);
                }
                let (t_ms, channel) = (num(1)? as u32, num(2)? as u8);
                out.push(Rec {
                    t_ms,
                    channel,
                    freq_hz: num(3)?,
                    cs_pf: num(4)?,
                    rs_ohm: num(5)?,
                    c_pf: num(6)?,
                    r_ohm: num(7)?,
                    stretch_mm: num(8)?,
                    flags: num(9)? as u8,
                    truth: truth.remove(&(t_ms, channel)),
                });
            }
            _ => {}
        }
    }
    Ok(out)
}

/// Write the records as trace files `trace_ch{c}_{f}hz.csv` in `dir`
/// (interchange format: time_s, stretch_mm, freq_hz, cs_pf, rs_ohm, plus
/// the firmware's c_corrected_pf, r_corrected_ohm, flags and, when known,
/// the truth). Records without a measurement (open, shorted, settling) are
/// left out, and listed in `faults.csv` instead. Returns the files written.
pub fn write_csv(dir: &Path, recs: &[Rec]) -> Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut groups: BTreeMap<(u8, u64), Vec<&Rec>> = BTreeMap::new();
    let mut faults = std::io::BufWriter::new(std::fs::File::create(dir.join("faults.csv"))?);
    writeln!(faults, "time_s,channel,freq_hz,flags")?;
    for r in recs {
        if r.cs_pf > 0.0 && r.flags & (flags::OPEN | flags::SHORTED | flags::SETTLING) == 0 {
            groups
                .entry((r.channel, r.freq_hz.round() as u64))
                .or_default()
                .push(r);
        }
        if r.flags & flags::INVALID != 0 {
            writeln!(
                faults,
                "{:.4},{},{},{}",
                r.t_ms as f64 / 1e3,
                r.channel,
                r.freq_hz,
                r.flags
            )?;
        }
    }
    let mut files = vec![];
    for ((ch, f), rs) in groups {
        let path = dir.join(format!("trace_ch{ch}_{f}hz.csv"));
        let mut w = std::io::BufWriter::new(std::fs::File::create(&path)?);
        writeln!(
            w,
            "# firmware channel {ch}, excitation {f} Hz; stretch_mm from the firmware's calibration"
        )?;
        writeln!(w, "time_s,stretch_mm,freq_hz,cs_pf,rs_ohm,c_corrected_pf,r_corrected_ohm,flags,c_true_pf,r_true_ohm,stretch_true_mm")?;
        for r in rs {
            let (tc, tr, ts) = r
                .truth
                .map_or((String::new(), String::new(), String::new()), |t| {
                    (
                        format!("{:.4}", t.c_pf),
                        format!("{:.0}", t.r_ohm),
                        format!("{:.4}", t.stretch_mm),
                    )
                });
            writeln!(
                w,
                "{:.4},{:.4},{},{:.4},{:.0},{:.4},{:.0},{},{tc},{tr},{ts}",
                (r.t_ms as f64 + 2.56) / 1e3,
                r.stretch_mm,
                r.freq_hz,
                r.cs_pf,
                r.rs_ohm,
                r.c_pf,
                r.r_ohm,
                r.flags
            )?;
        }
        files.push(path);
    }
    Ok(files)
}

/// Write the records of the `identify` scenario as a data set of the
/// interchange format (`shared/data-format.md`), as a rig would record it:
/// the firmware's lumped Cs at a fixed frequency per channel, the stretch
/// from the rig's encoder and the end-to-end electrode resistances from
/// its ohmmeter (here the simulation's truth). Channels in `traces` give
/// `trace_ch{c}_{f}hz.csv`; each channel in `statics` gives one
/// calibration point (the mean of its valid records). Returns the number
/// of trace rows written.
pub fn write_dataset(dir: &Path, recs: &[Rec], traces: &[u8], statics: &[u8]) -> Result<usize> {
    std::fs::create_dir_all(dir)?;
    let good = |r: &&Rec| r.valid() && r.cs_pf > 0.0 && r.truth.is_some();
    let mut cal = std::io::BufWriter::new(std::fs::File::create(dir.join("calibration.csv"))?);
    writeln!(cal, "# firmware lumped Cs, mean of each static channel's records")?;
    writeln!(cal, "stretch_mm,freq_hz,cs_pf,r_top_ohm,r_bottom_ohm")?;
    for &ch in statics {
        let rs: Vec<&Rec> = recs.iter().filter(|r| r.channel == ch).filter(good).collect();
        if rs.is_empty() {
            bail!("static channel {ch} has no valid record");
        }
        let n = rs.len() as f64;
        let mean = |g: fn(&Rec) -> f64| rs.iter().map(|r| g(r)).sum::<f64>() / n;
        let t = |g: fn(&Truth) -> f64| rs.iter().filter_map(|r| r.truth.as_ref().map(g)).sum::<f64>() / n;
        writeln!(
            cal,
            "{:.4},{},{:.4},{:.0},{:.0}",
            t(|t| t.stretch_mm),
            rs[0].freq_hz,
            mean(|r| r.cs_pf),
            t(|t| t.r_top_ohm),
            t(|t| t.r_bottom_ohm)
        )?;
    }
    cal.flush()?;
    let mut rows = 0;
    for &ch in traces {
        let rs: Vec<&Rec> = recs.iter().filter(|r| r.channel == ch).filter(good).collect();
        let Some(first) = rs.first() else {
            bail!("trace channel {ch} has no valid record");
        };
        let path = dir.join(format!("trace_ch{ch}_{:.0}hz.csv", first.freq_hz));
        let mut w = std::io::BufWriter::new(std::fs::File::create(&path)?);
        writeln!(w, "time_s,stretch_mm,r_top_ohm,r_bottom_ohm,freq_hz,cs_pf,rs_ohm")?;
        for r in rs {
            let Some(t) = r.truth else { continue };
            writeln!(
                w,
                "{:.5},{:.4},{:.0},{:.0},{},{:.4},{:.0}",
                (r.t_ms as f64 + 2.56) / 1e3,
                t.stretch_mm,
                t.r_top_ohm,
                t.r_bottom_ohm,
                r.freq_hz,
                r.cs_pf,
                r.rs_ohm
            )?;
            rows += 1;
        }
        w.flush()?;
    }
    Ok(rows)
}

/// Build the QEMU firmware, run `scenario`, decode its records.
pub fn run_scenario(scenario: &str) -> Result<(crate::Run, Vec<Rec>)> {
    run_scenario_args(&[scenario])
}

/// [`run_scenario`] with further semihosting arguments after the name.
pub fn run_scenario_args(args: &[&str]) -> Result<(crate::Run, Vec<Rec>)> {
    let elf = crate::build_firmware("skin-qemu", &["qemu"])?;
    let run = crate::run_qemu_args(&elf, args, std::time::Duration::from_secs(600))?;
    let lines = crate::decode_defmt(&elf, &run.raw)?;
    let recs = parse(&lines)?;
    Ok((
        crate::Run {
            stdout: lines.join("\n"),
            ..run
        },
        recs,
    ))
}
