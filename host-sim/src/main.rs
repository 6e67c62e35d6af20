//! `host-sim`: command-line entry point.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use dsp_core::tline::LineModel;
use host_sim::chain::{self, Meter};
use host_sim::experiments::{self as exp, Ctx};
use host_sim::meter::{self, model_name, parse_model};
use host_sim::si;
use instrument::effects::{Effect, EffectSet};
use skin_sim::profile::Profile;
use skin_sim::sensor::Sensor;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The longest `trace`, s: an hour of simulated skin (3.6 million 1 ms
/// steps) still ends in minutes.
const MAX_TRACE_S: f64 = 3600.0;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "DE sensing skin: line model, inversion and simulations on the dsp-core the boards run"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// What a series Cs-Rs meter reads on a line of R and C, per model and frequency.
    Model {
        /// Total electrode resistance R (top + bottom), e.g. 700k.
        #[arg(long, value_parser = si::parse)]
        r: f64,
        /// Line capacitance C, e.g. 200p.
        #[arg(long, value_parser = si::parse)]
        c: f64,
        /// Excitation frequencies, comma separated, e.g. 500,2k,6k.
        #[arg(long, value_parser = si::parse, value_delimiter = ',', required = true)]
        f: Vec<f64>,
        /// Models: ladder sizes 1..64 or 'continuous', comma separated.
        #[arg(long, value_parser = parse_model, value_delimiter = ',', default_value = "1,2,4,30,continuous")]
        model: Vec<LineModel>,
        /// Print CSV instead of a table.
        #[arg(long)]
        csv: bool,
    },
    /// The line (true C and R) behind a series Cs-Rs reading.
    Invert {
        /// Series capacitance read by the meter, e.g. 150p.
        #[arg(long, value_parser = si::parse)]
        cs: f64,
        /// Series resistance read by the meter, e.g. 200k.
        #[arg(long, value_parser = si::parse)]
        rs: f64,
        /// Excitation frequency, e.g. 6k.
        #[arg(long, value_parser = si::parse)]
        f: f64,
        /// Model: ladder size 1..64 or 'continuous'.
        #[arg(long, value_parser = parse_model, default_value = "continuous")]
        model: LineModel,
        /// Expected capacitance, to choose between two fitting lines.
        #[arg(long, value_parser = si::parse)]
        c_hint: Option<f64>,
        /// The fraction of each electrode's resistance in its tab leads
        /// (`lead_resistance`, as `identify` reports it; 0: no leads).
        #[arg(long, default_value_t = 0.0)]
        lead_resistance: f64,
    },
    /// Every paper experiment: CSV, SVG figures and summary.md in --out.
    Paper(RunArgs),
    /// Static frequency sweep at 0, 15, 30 mm (Fig. 7).
    Sweep(RunArgs),
    /// Electrode resistance settling and in steady state (Fig. 8, 9).
    Resistance(RunArgs),
    /// Lumped capacitance at 500 Hz, 2 kHz, 6 kHz, 10 and 20 mm/s (Fig. 10).
    Capacitance(RunArgs),
    /// Paper's simulation with n = 1, 2, 4, 30 vs. measurement (Fig. 13, 14).
    Elements(RunArgs),
    /// Lumped vs. line-corrected error against the truth, 20 mm/s, ADC chain.
    Accuracy(RunArgs),
    /// Write a data set in the interchange format, optionally with non-ideal effects.
    Dataset {
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Seed of the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[command(flatten)]
        effects: EffectArgs,
    },
    /// Baseline model of a measured data set (uniform line, de-biased
    /// calibration, recorded R) and its residual per trace, with the noise floor.
    Residual {
        /// Data set folder (interchange format).
        dir: PathBuf,
        /// Line model: ladder size 1..64 or 'continuous'.
        #[arg(long, value_parser = parse_model, default_value = "continuous")]
        model: LineModel,
        /// Use the calibration's Cs as the true C (the paper's shortcut).
        #[arg(long)]
        raw_calibration: bool,
    },
    /// Trace the residual of a measured data set to the effect the uniform
    /// line lacks: report.md, report.json and residuals.svg in --out.
    Identify {
        /// Data set folder (interchange format).
        dir: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "out/identify")]
        out: PathBuf,
        /// Leave the static sweep out of the model.
        #[arg(long)]
        no_sweep: bool,
        /// The set is the founding paper's static sweep (`data/paper/dataset`):
        /// also predict the paper's dynamic numbers, out of fit, from the
        /// effects found.
        #[arg(long)]
        predict_paper: bool,
    },
    /// A firmware recording (a decoded log with `rec`/`truth` lines, or raw
    /// defmt bytes with --elf) → a data set in the interchange format:
    /// traces per channel and frequency, calibration from the static
    /// channels, faults.csv.
    Decode {
        /// The recording.
        input: PathBuf,
        /// The firmware ELF, when `input` is raw defmt.
        #[arg(long)]
        elf: Option<PathBuf>,
        /// Output folder.
        #[arg(long, default_value = "out/recording")]
        out: PathBuf,
        /// Channels that become traces, comma separated (default: the
        /// moving ones).
        #[arg(long, value_delimiter = ',')]
        traces: Option<Vec<u8>>,
        /// Channels that become calibration points (default: the static
        /// ones, stretch spread below 0.5 mm).
        #[arg(long, value_delimiter = ',')]
        statics: Option<Vec<u8>>,
    },
    /// Read the simulated sensor along any profile; CSV trace to stdout or --out.
    Trace(TraceArgs),
    /// The disturbance table: every class of disturbance (hum, interferers,
    /// aliases, steps, clipping, open and shorted sensors, undeclared
    /// wiring and film, resistance jumps, drift) on the multiplexed channel
    /// and on the array, with the share of records flagged and the worst
    /// error among those left valid; Markdown to stdout.
    Disturbances,
}

/// The options of `trace`.
#[derive(clap::Args)]
struct TraceArgs {
    /// trapezoid:RATE, ramp:RATE:AMPLITUDE, step:TIME:AMPLITUDE,
    /// const:STRETCH, or a CSV file with time_s,stretch_mm.
    #[arg(long)]
    profile: String,
    /// Duration, s.
    #[arg(long, value_parser = si::parse, default_value = "10")]
    duration: f64,
    /// Excitation frequency.
    #[arg(long, value_parser = si::parse, default_value = "2k")]
    f: f64,
    /// 'adc' (front end, ADC, dsp-core) or 'lcr' (ideal series meter).
    #[arg(long, default_value = "adc")]
    meter: String,
    /// Output CSV (default: stdout).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    effects: EffectArgs,
}

#[derive(clap::Args)]
struct RunArgs {
    /// Output folder.
    #[arg(long, default_value = "out/paper")]
    out: PathBuf,
    /// Seed of all noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trapezoid periods per dynamic run.
    #[arg(long, default_value_t = 2)]
    periods: u32,
    /// The simulated sensor: the founding paper's, as its text and
    /// `identify` on its static sweep describe it (tab leads, resistance
    /// rising under cycling), or the reference sensor (no leads, resistance
    /// falling under cycling; the firmware's skin in QEMU).
    #[arg(long, value_enum, default_value_t = SensorChoice::Paper)]
    sensor: SensorChoice,
}

/// Which simulated sensor.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum SensorChoice {
    /// `SensorParams::PAPER`.
    Paper,
    /// `SensorParams::REFERENCE`.
    Reference,
}

/// Non-ideal effects of the simulated sensor and its recording, all off by
/// default: one flag per effect of the catalogue (`instrument::effects`),
/// named for its id (`--contact-resistance 5k`), SI units with prefixes,
/// checked against the effect's physical limits.
#[derive(Clone, Copy, Default)]
struct EffectArgs(EffectSet);

/// The command-line flag of `e`: its id with `-` for `_`.
fn flag(e: Effect) -> String {
    e.id().replace('_', "-")
}

impl clap::FromArgMatches for EffectArgs {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut set = EffectSet::NONE;
        for e in Effect::ALL {
            if let Some(&v) = m.get_one::<f64>(e.id()) {
                set.set(e, v).map_err(|err| {
                    clap::Error::raw(
                        clap::error::ErrorKind::ValueValidation,
                        format!("--{}: {err}\n", flag(e)),
                    )
                })?;
            }
        }
        Ok(Self(set))
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl clap::Args for EffectArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        Effect::ALL.into_iter().fold(cmd, |cmd, e| {
            let i = e.info();
            let scope = if e.is_static() { "sensor" } else { "LCR meter" };
            cmd.arg(
                clap::Arg::new(i.id)
                    .long(flag(e))
                    .value_parser(si::parse)
                    .allow_hyphen_values(true)
                    .value_name(match (i.unit, i.display_unit) {
                        ("", "readings") => "READINGS",
                        ("", _) => "RATIO",
                        (u, _) => u,
                    })
                    .help(format!("{scope}: {}", i.doc)),
            )
        })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// Parse a profile argument; `points` keeps a CSV profile's table alive.
fn parse_profile<'a>(spec: &str, points: &'a mut Vec<(f64, f64)>) -> Result<Profile<'a>> {
    let num = |s: &str| si::parse(s).map_err(|e| anyhow::anyhow!("profile '{spec}': {e}"));
    let parts: Vec<&str> = spec.split(':').collect();
    Ok(match parts.as_slice() {
        ["trapezoid", rate] => {
            let r = num(rate)?;
            anyhow::ensure!(r > 0.0, "profile '{spec}': rate must be > 0");
            Profile::paper(r)
        }
        ["ramp", rate, amp] => {
            let r = num(rate)?;
            anyhow::ensure!(r > 0.0, "profile '{spec}': rate must be > 0");
            Profile::Ramp {
                rate: r,
                amplitude: num(amp)?,
            }
        }
        ["step", at, amp] => Profile::Step {
            at: num(at)?,
            amplitude: num(amp)?,
        },
        ["const", s] => Profile::Constant(num(s)?),
        _ => {
            *points = read_profile_csv(std::path::Path::new(spec))?;
            Profile::Table(points)
        }
    })
}

/// A profile table: columns time_s and stretch_mm, increasing times.
fn read_profile_csv(path: &std::path::Path) -> Result<Vec<(f64, f64)>> {
    use anyhow::Context;
    let name = path.display();
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .with_context(|| format!("{name}: cannot open (expected a profile kind or a CSV file)"))?;
    let head = rd
        .headers()
        .with_context(|| format!("{name}: no header row"))?
        .clone();
    let col = |n: &str| {
        head.iter()
            .position(|h| h.trim() == n)
            .ok_or_else(|| anyhow::anyhow!("{name}: missing column {n}"))
    };
    let (ct, cs) = (col("time_s")?, col("stretch_mm")?);
    let mut pts: Vec<(f64, f64)> = vec![];
    for rec in rd.records() {
        let rec = rec.with_context(|| format!("{name}: malformed CSV"))?;
        let line = rec.position().map_or(0, |p| p.line());
        let field = |c: usize, n: &str| -> Result<f64> {
            let v = rec.get(c).unwrap_or("").trim();
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => anyhow::bail!("{name}:{line}: column {n}: '{v}' is not a finite number"),
            }
        };
        let (t, s) = (field(ct, "time_s")?, field(cs, "stretch_mm")?);
        if let Some(&(tp, _)) = pts.last() {
            anyhow::ensure!(t > tp, "{name}:{line}: column time_s: {t} does not increase");
        }
        pts.push((t, s));
    }
    anyhow::ensure!(!pts.is_empty(), "{name}: no rows");
    Ok(pts)
}

fn ctx(a: &RunArgs, total_s: f64) -> Result<Ctx> {
    let mut c = Ctx::new(&a.out, a.seed)?.with_progress(total_s);
    c.periods = a.periods;
    c.sensor = match a.sensor {
        SensorChoice::Paper => skin_sim::sensor::SensorParams::PAPER,
        SensorChoice::Reference => skin_sim::sensor::SensorParams::REFERENCE,
    };
    Ok(c)
}

fn main() -> ExitCode {
    // A reader that stops early (`| head`) ends the program quietly, as it
    // does any Unix filter, instead of a panic in the next print.
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal at start-up,
    // before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<Incomplete>() => {
            eprintln!("incomplete: {e}");
            ExitCode::from(3)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Model { r, c, f, model, csv } => model_table(r, c, &f, &model, csv)?,
        Cmd::Invert {
            cs,
            rs,
            f,
            model,
            c_hint,
            lead_resistance,
        } => invert(cs, rs, f, model, c_hint, lead_resistance)?,
        Cmd::Paper(a) => {
            let c = ctx(&a, 600.0 + 9.0 * 10.0 * a.periods as f64)?;
            let (md, _) = exp::paper(&c)?;
            println!("{md}");
            println!("wrote CSV, SVG and summary.md to {}", a.out.display());
        }
        Cmd::Sweep(a) => println!("{}", exp::sweep(&ctx(&a, 0.0)?)?),
        Cmd::Resistance(a) => println!("{}", exp::resistance(&ctx(&a, 600.0)?)?),
        Cmd::Capacitance(a) => println!("{}", exp::capacitance(&ctx(&a, 60.0 * a.periods as f64)?)?.0),
        Cmd::Elements(a) => {
            let c = ctx(&a, 60.0 * a.periods as f64)?;
            let (_, runs) = exp::capacitance(&c)?;
            println!("{}", exp::elements(&c, &runs, &exp::calibration(&c)?)?);
        }
        Cmd::Accuracy(a) => println!("{}", exp::accuracy(&ctx(&a, 30.0 * a.periods as f64)?)?.0),
        Cmd::Dataset { out, seed, effects } => {
            let params = exp::with_effects(effects.0);
            let pb = Ctx::new(&out, seed)?.with_progress(180.0).progress;
            exp::dataset(&out, params, Meter::lcr(&effects.0), seed, pb)?;
            println!("wrote a data set to {}", out.display());
        }
        Cmd::Identify {
            dir,
            out,
            no_sweep,
            predict_paper,
        } => identify(&dir, &out, no_sweep, predict_paper)?,
        Cmd::Decode {
            input,
            elf,
            out,
            traces,
            statics,
        } => decode(
            &input,
            elf.as_deref(),
            &out,
            host_sim::recording::Roles { traces, statics },
        )?,
        Cmd::Residual {
            dir,
            model,
            raw_calibration,
        } => residual(&dir, model, raw_calibration)?,
        Cmd::Trace(t) => trace(t)?,
        Cmd::Disturbances => print!("{}", host_sim::disturbances::table()),
    }
    Ok(())
}

/// `model`: what a series Cs–Rs meter reads on a line of `r` and `c`, per
/// model and frequency, as a table or CSV.
fn model_table(r: f64, c: f64, f: &[f64], models: &[LineModel], csv: bool) -> Result<()> {
    if csv {
        println!("model,freq_hz,x,cs_pf,rs_ohm,d,cs_error_pct");
    } else {
        println!("line: R = {}, C = {}", si::fmt(r, "Ω"), si::fmt(c, "F"));
        println!(
            "{:<14} {:>11} {:>8} {:>11} {:>11} {:>8} {:>9}",
            "model", "f", "ωRC", "Cs", "Rs", "D", "Cs/C−1"
        );
    }
    for &fh in f {
        for &m in models {
            let rd = meter::read(m, r, c, fh)?;
            let (cs, rs) = (rd.series.cs_farad as f64, rd.series.rs_ohm as f64);
            let d = rd.series.dissipation(fh as f32);
            let err = 100.0 * (cs / c - 1.0);
            if csv {
                println!(
                    "{},{fh},{:.6},{:.4},{:.1},{d:.6},{err:.4}",
                    model_name(m),
                    rd.x,
                    cs * 1e12,
                    rs
                );
            } else {
                println!(
                    "{:<14} {:>11} {:>8.4} {:>11} {:>11} {:>8.4} {:>8.3}%",
                    model_name(m),
                    si::fmt(fh, "Hz"),
                    rd.x,
                    si::fmt(cs, "F"),
                    si::fmt(rs, "Ω"),
                    d,
                    err
                );
            }
        }
    }
    Ok(())
}

/// `invert`: the line behind one series reading.
fn invert(cs: f64, rs: f64, f: f64, model: LineModel, c_hint: Option<f64>, leads: f64) -> Result<()> {
    let line = meter::invert_with_leads(model, leads, cs, rs, f, c_hint)?;
    if leads > 0.0 {
        println!(
            "model: {}, {:.1} % of each electrode in its tab leads",
            model_name(model),
            100.0 * leads
        );
    } else {
        println!("model: {}", model_name(model));
    }
    println!("C   = {}", si::fmt(line.c_farad as f64, "F"));
    println!(
        "R   = {}  (top + bottom electrode)",
        si::fmt(line.r_ohm as f64, "Ω")
    );
    println!("ωRC = {:.5}", line.x);
    Ok(())
}

/// `decode`: a firmware recording to a data set.
fn decode(input: &Path, elf: Option<&Path>, out: &Path, roles: host_sim::recording::Roles) -> Result<()> {
    use host_sim::recording;
    let (recs, ended) = recording::read_recording(input, elf)?;
    let w = recording::write_dataset(out, &recs, &roles)?;
    // A run cut short is said so beside its data, as `live` does.
    let marker = out.join("INCOMPLETE");
    match ended {
        true => match std::fs::remove_file(&marker) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e.into()),
            _ => {}
        },
        false => std::fs::write(
            &marker,
            format!(
                "{}: no '{}' line: the run was cut short (a crash, a hang, or a recording stopped by hand)\n",
                input.display(),
                recording::END
            ),
        )?,
    }
    println!(
        "{} records → {} trace files ({} rows), {} fragments (runs shorter than a trace), {} calibration points, {} faults in {}",
        recs.len(),
        w.traces.len(),
        w.rows,
        w.fragments.len(),
        w.calibration_points,
        w.faults,
        out.display()
    );
    for why in &w.left_out {
        println!("left out: {why}");
    }
    if !ended {
        return Err(Incomplete(format!(
            "{}: no '{}' line: the run was cut short (a crash, a hang, or a recording stopped by hand); \
             the data set holds what it recorded, marked INCOMPLETE",
            input.display(),
            recording::END
        ))
        .into());
    }
    Ok(())
}

/// A recording cut short: its data set written, marked; exit status 3
/// (as `live`'s for a stream cut short).
#[derive(Debug)]
struct Incomplete(String);

impl std::fmt::Display for Incomplete {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Incomplete {}

/// Say so when the data set in `dir` was recorded by a run cut short
/// (`decode`'s or `live`'s INCOMPLETE mark), or by a `live` session that
/// never ended (its records, no manifest).
fn note_incomplete(dir: &Path) {
    use host_sim::recording::{INCOMPLETE, MANIFEST};
    if let Ok(why) = std::fs::read_to_string(dir.join(INCOMPLETE)) {
        eprintln!("note: {} is marked INCOMPLETE: {}", dir.display(), why.trim());
    } else if dir.join("records.csv").exists() && !dir.join(MANIFEST).exists() {
        eprintln!(
            "note: {} is incomplete: a live session's folder without its {MANIFEST} (the session never ended: killed, crashed or out of disk)",
            dir.display()
        );
    }
}

/// `residual`: the baseline's residual per trace.
fn residual(dir: &Path, model: LineModel, raw_calibration: bool) -> Result<()> {
    note_incomplete(dir);
    let ds = host_sim::dataset::read_dir(dir)?;
    let b = host_sim::baseline::Baseline::from_calibration(&ds.calibration, model, !raw_calibration)?;
    println!("electrode resistance: {}\n", ds.calibration.resistance);
    println!("| trace | rows | residual RMS | max | noise floor | RMS / noise |");
    println!("|---|---:|---:|---:|---:|---:|");
    for r in host_sim::baseline::residuals(&ds, &b) {
        println!(
            "| {} | {} | {:.3} pF | {:.3} pF | {:.3} pF | {:.2} |",
            r.file,
            r.n,
            r.rms_pf,
            r.max_pf,
            r.noise_pf,
            r.rms_pf / r.noise_pf
        );
    }
    for t in ds.traces.iter().chain(&ds.sweep).chain([&ds.calibration]) {
        if t.flagged > 0 {
            println!(
                "\n{}: {} rows the instrument flagged, left out",
                t.path.display(),
                t.flagged
            );
        }
    }
    Ok(())
}

/// `identify`: the reports of what the residual says the model lacks,
/// written all or none.
fn identify(dir: &Path, out: &Path, no_sweep: bool, predict_paper: bool) -> Result<()> {
    use host_sim::identify;
    note_incomplete(dir);
    let options = identify::Options {
        sweep: !no_sweep,
        ..Default::default()
    };
    // A failed run leaves no reports: none from an earlier run
    // that would pass for this one's, and no half-written ones.
    const REPORTS: [&str; 3] = ["residuals.svg", "report.json", "report.md"];
    for name in REPORTS {
        let path = out.join(name);
        if path.is_file() {
            std::fs::remove_file(&path).with_context(|| format!("removing the old {}", path.display()))?;
        }
    }
    let ds = host_sim::dataset::read_dir(dir)?;
    let pb = identify_progress();
    let report = identify::identify_with(&ds, options, &pb);
    pb.finish_and_clear();
    let report = report?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut md = report.markdown(&dir.display().to_string(), Some("residuals.svg"));
    let mut j = report.json();
    if predict_paper {
        let (section, outcomes) = exp::predict_paper(&report.final_fit().params)?;
        md += "\n";
        md += &section;
        j["predictions"] = outcomes.iter().map(prediction_json).collect();
        let (table, rows) = host_sim::experiments::consistency(&ds, &report)?;
        md += "\n";
        md += &table;
        j["consistency"] = rows
            .iter()
            .map(|m| {
                serde_json::json!({
                    "mechanism": m.label,
                    "parameters": m.params,
                    "unresolved": m.unresolved,
                    "static_points": m.static_points,
                    "static_points_off": m.statics_off.iter().map(|(p, e, t)| serde_json::json!({"point": p, "residual_pf": e, "tolerance_pf": t})).collect::<Vec<_>>(),
                    "predictions": m.dynamics.iter().map(prediction_json).collect::<Vec<_>>(),
                    "excluded_by": m.excluded_by(),
                    "consistent": m.consistent(),
                })
            })
            .collect();
    }
    let json = serde_json::to_string_pretty(&j)? + "\n";
    let temp = || {
        tempfile::Builder::new()
            .prefix(".identify-")
            .tempfile_in(out)
            .with_context(|| format!("writing into {}", out.display()))
    };
    let (svg_t, json_t, md_t) = (temp()?, temp()?, temp()?);
    identify::plot(&report, &ds, svg_t.path())?;
    std::fs::write(json_t.path(), &json).with_context(|| format!("writing {}", json_t.path().display()))?;
    std::fs::write(md_t.path(), &md).with_context(|| format!("writing {}", md_t.path().display()))?;
    // All three are complete: rename them into place, and take the
    // ones already placed back if a rename fails.
    let mut placed = vec![];
    for (t, name) in [svg_t, json_t, md_t].into_iter().zip(REPORTS) {
        let path = out.join(name);
        if let Err(e) = t.persist(&path) {
            for p in &placed {
                let _ = std::fs::remove_file(p);
            }
            return Err(anyhow::Error::new(e.error).context(format!("writing {}", path.display())));
        }
        placed.push(path);
    }
    println!("{md}");
    println!("wrote {}/report.md, report.json, residuals.svg", out.display());
    Ok(())
}

/// `trace`: the simulated sensor along a profile, read by a meter.
fn trace(t: TraceArgs) -> Result<()> {
    let TraceArgs {
        profile,
        duration,
        f,
        meter,
        out,
        seed,
        effects,
    } = t;
    let mut points = vec![];
    let p = parse_profile(&profile, &mut points)?;
    let m = match meter.as_str() {
        "adc" => Meter::ADC,
        "lcr" => Meter::lcr(&effects.0),
        other => anyhow::bail!("--meter '{other}': expected 'adc' or 'lcr'"),
    };
    anyhow::ensure!(
        duration > 0.0 && duration <= MAX_TRACE_S,
        "--duration must be within 0..{MAX_TRACE_S} s (the simulated sensor steps by 1 ms)"
    );
    anyhow::ensure!((100.0..=50e3).contains(&f), "--f must be within 100 Hz..50 kHz");
    let params = exp::with_effects(effects.0);
    let mut s = Sensor::settled(params);
    let setup = chain::Setup {
        freq_hz: f,
        meter: m,
        model: LineModel::Continuous,
        prior_farad: exp::rest_calibration(params),
        seed,
        lead_ratio: params.effects.statics().lead_ratio(),
    };
    let rs = chain::run(&mut s, &p, setup, 0.0, duration, |_| {});
    match out {
        Some(path) => {
            exp::write_trace(&path, &rs, true)?;
            println!("wrote {} readings to {}", rs.len(), path.display());
        }
        None => exp::write_trace_to(std::io::stdout().lock(), &rs, true)?,
    }
    Ok(())
}

/// The progress of `identify`'s candidate models, on stderr (hidden when
/// it is not a terminal).
fn identify_progress() -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(0);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} identify: {msg:<32} [{bar:30}] {pos}/{len} models, {elapsed}",
        )
        .expect("template")
        .progress_chars("=> "),
    );
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    pb
}

/// One of the paper's claims as `identify --predict-paper` predicts it, for
/// `report.json`.
fn prediction_json(o: &exp::Outcome) -> serde_json::Value {
    serde_json::json!({
        "id": o.claim.id,
        "use": o.claim.role,
        "paper": o.claim.value,
        "predicted": o.sim,
        "unit": o.claim.unit,
        "deviation": o.deviation(),
        "tolerance": o.claim.tolerance(),
        "within": o.within(),
    })
}
