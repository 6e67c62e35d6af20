//! `live`: the host's end of the record link. Reads frames from a serial
//! port, a running QEMU's socket or a recorded stream, keeps the raw
//! bytes, writes the records and the data set, and prints the link's
//! health each second.

use anyhow::{Context, Result};
use clap::Parser;
use live::{Outcome, Session};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Read a running skin's records.
#[derive(Parser)]
#[command(name = "live", version)]
struct Cli {
    /// Replay a recorded stream (the raw bytes a session kept).
    #[arg(long, conflicts_with_all = ["serial", "tcp"])]
    replay: Option<PathBuf>,
    /// Read a serial port (the Nucleo's ST-LINK virtual COM port, e.g. /dev/ttyACM0).
    #[arg(long, conflicts_with = "tcp")]
    serial: Option<String>,
    /// The serial port's baud rate.
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// Connect to a TCP socket (QEMU's `-serial tcp:HOST:PORT,server`).
    #[arg(long)]
    tcp: Option<String>,
    /// Where the data set goes (records.csv as records arrive, the data
    /// set's files at the end, stream.bin with the raw bytes).
    #[arg(long, default_value = "out/live")]
    dataset: PathBuf,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(Outcome::Complete) => ExitCode::SUCCESS,
        Ok(Outcome::Incomplete(why)) => {
            eprintln!("incomplete: {why}");
            ExitCode::from(3)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<Outcome> {
    let mut session = Session::new(&cli.dataset)?;
    match (&cli.replay, &cli.serial, &cli.tcp) {
        (Some(path), _, _) => {
            let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
            session.push(&bytes)?;
        }
        (None, Some(port), _) => {
            let port = serialport::new(port, cli.baud)
                .timeout(Duration::from_millis(200))
                .open()
                .with_context(|| format!("opening the serial port {port} (in use, or not there?)"))?;
            follow(port, &mut session, &cli.dataset)?;
        }
        (None, None, Some(addr)) => {
            let sock = std::net::TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
            sock.set_read_timeout(Some(Duration::from_millis(200)))?;
            follow(sock, &mut session, &cli.dataset)?;
        }
        (None, None, None) => {
            anyhow::bail!("say where the records come from: --replay FILE, --serial PORT or --tcp HOST:PORT")
        }
    }
    let finished = session.finish()?;
    println!("{}", finished.summary.line());
    println!(
        "wrote {}: records.csv, {} trace files, {} fragments, calibration.csv, faults.csv",
        cli.dataset.display(),
        finished.written.traces.len(),
        finished.written.fragments.len()
    );
    Ok(finished.outcome)
}

/// Read `source` until it ends (EOF, a closed socket, a port that
/// vanished) or the stream's end frame arrives, keeping every byte in
/// `stream.bin` and printing the link's health each second.
fn follow(mut source: impl Read, session: &mut Session, dir: &std::path::Path) -> Result<()> {
    let raw_path = dir.join("stream.bin");
    let mut raw =
        std::fs::File::create(&raw_path).with_context(|| format!("creating {}", raw_path.display()))?;
    let mut buf = [0u8; 4096];
    let mut last = Instant::now();
    loop {
        let n = match source.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                0
            }
            Err(e) => {
                eprintln!("the source stopped: {e}");
                break;
            }
        };
        raw.write_all(&buf[..n]).context("keeping the raw stream")?;
        session.push(&buf[..n])?;
        if last.elapsed() >= Duration::from_secs(1) {
            last = Instant::now();
            session.flush()?;
            eprintln!("{}", session.summary().line());
        }
        if session.end().is_some() {
            break;
        }
    }
    raw.flush()?;
    Ok(())
}
