//! `host-sim`: command-line entry point.

use anyhow::Result;
use clap::{Parser, Subcommand};
use dsp_core::tline::LineModel;
use host_sim::meter::{self, model_name, parse_model};
use host_sim::si;
use std::process::ExitCode;

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
    },
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Model { r, c, f, model, csv } => {
            if csv {
                println!("model,freq_hz,x,cs_pf,rs_ohm,d,cs_error_pct");
            } else {
                println!("line: R = {}, C = {}", si::fmt(r, "Ω"), si::fmt(c, "F"));
                println!(
                    "{:<14} {:>11} {:>8} {:>11} {:>11} {:>8} {:>9}",
                    "model", "f", "ωRC", "Cs", "Rs", "D", "Cs/C−1"
                );
            }
            for &fh in &f {
                for &m in &model {
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
        }
        Cmd::Invert {
            cs,
            rs,
            f,
            model,
            c_hint,
        } => {
            let line = meter::invert(model, cs, rs, f, c_hint)?;
            println!("model: {}", model_name(model));
            println!("C   = {}", si::fmt(line.c_farad as f64, "F"));
            println!(
                "R   = {}  (top + bottom electrode)",
                si::fmt(line.r_ohm as f64, "Ω")
            );
            println!("ωRC = {:.5}", line.x);
        }
    }
    Ok(())
}
