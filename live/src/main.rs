//! `live`: the host's end of the record link. Reads frames from a serial
//! port, a running QEMU's socket or a recorded stream, keeps the raw
//! bytes, writes the records and the data set, and prints the link's
//! health each second.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use live::config::Unreadable;
use live::dashboard::Dashboard;
use live::{follow, Outcome, Session, Sink, Stopped};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Read a running skin's records; `live config` reads and writes the
/// settings a device keeps.
#[derive(Parser)]
#[command(name = "live", version, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Replay a recorded stream (the raw bytes a session kept).
    #[arg(long, conflicts_with_all = ["serial", "tcp"])]
    replay: Option<PathBuf>,
    /// With --replay: when its records arrived (the session's
    /// arrivals.csv; default: the one beside the stream, where there is
    /// one), so that they keep their host times.
    #[arg(long, requires = "replay")]
    arrivals: Option<PathBuf>,
    /// Read a serial port (the Nucleo's ST-LINK virtual COM port, e.g. /dev/ttyACM0).
    #[arg(long, conflicts_with = "tcp")]
    serial: Option<String>,
    /// The serial port's baud rate: the board's (LPUART1 into the
    /// ST-LINK's virtual COM port, 8N1).
    #[arg(long, default_value_t = link::BOARD_BAUD)]
    baud: u32,
    /// Connect to a TCP socket (QEMU's `-serial tcp:HOST:PORT,server`).
    #[arg(long)]
    tcp: Option<String>,
    /// Where the data set goes (records.csv as records arrive, the data
    /// set's files at the end, stream.bin with the raw bytes): a folder
    /// that is new or empty. Default: a new folder per session,
    /// out/sessions/<UTC date and time>.
    #[arg(long)]
    dataset: Option<PathBuf>,
    /// Replace the session in --dataset's folder (its records, stream,
    /// marker and data set) once the new stream has started, instead of
    /// refusing a folder that holds files.
    #[arg(long)]
    overwrite: bool,
    /// Serve the live dashboard on this local address (127.0.0.1:PORT;
    /// port 0 picks a free one); its address is printed first.
    #[arg(long)]
    serve: Option<std::net::SocketAddr>,
    /// With --serve: keep serving this many seconds after the stream
    /// ends (a replay ends at once).
    #[arg(long, default_value_t = 0)]
    linger: u64,
    /// Follow the link without recording until asked (`start` on
    /// standard input, or the dashboard's Record); --dataset is then the
    /// first recording's folder.
    #[arg(long, conflicts_with = "replay")]
    idle: bool,
    /// The skin's description (TOML: each sensor's name, board, index,
    /// group and place; docs/live.md): its names in the manifest and the
    /// feed, and the sensors the device lacks or adds said.
    #[arg(long)]
    skin: Option<PathBuf>,
    /// With --skin: which of the skin's boards this device is.
    #[arg(long, requires = "skin")]
    board: Option<String>,
    /// With --skin, once per board: read several boards in one session,
    /// NAME=tcp:HOST:PORT, NAME=serial:PORT[@BAUD] or NAME=replay:PATH
    /// (NAME a board of the skin). Each board's recording goes to
    /// <dataset>/NAME/; the skin's records, keyed by board and sensor on
    /// the host's UTC through each board's clock fit, to
    /// <dataset>/records.csv, its manifest to skin.json.
    #[arg(
        long = "source",
        value_name = "NAME=SOURCE",
        requires = "skin",
        conflicts_with_all = ["replay", "serial", "tcp", "board", "idle"]
    )]
    sources: Vec<live::boards::BoardSource>,
}

#[derive(Subcommand)]
enum Command {
    /// The settings a device keeps, as `name = value` lines.
    Config {
        #[command(subcommand)]
        action: ConfigAction,
    },
    /// Calibrate each sensor from records taken while the skin is held at
    /// known stretches: its line, tab leads, contact and parasitic
    /// capacitance fitted, its stretch table built, the set stored on the
    /// device (which measures with it from its next block, the
    /// multiplexed board from its next start).
    #[command(after_help = CALIBRATE_HELP)]
    Calibrate(CalibrateArgs),
}

const CALIBRATE_HELP: &str = "\
How: start the device with nothing stored (or its old set), relaxed. Guided
(--at 0,10,20,30): for each stretch, hold the skin still, press Enter; the
device's records over the next --hold-s seconds are that stretch's. Or hold
the skin at each stretch of a holds file in turn (0 mm first, then at least
one more; 0, 3, ..., 30 mm gives the table its eleven points). Each
sensor's fit is checked: a fit that does not explain its data, a C that does
not grow with stretch, or values beyond the device's ranges are refused, and
that sensor keeps what the device held. The report gives each fitted value
with its 1 sigma and names what the data could not tell apart.";

#[derive(Subcommand)]
enum ConfigAction {
    /// Print every setting of the set in force.
    #[command(after_help = live::config::help())]
    Get {
        #[command(flatten)]
        target: Target,
    },
    /// Change settings (`name=value` …), check the whole set with the
    /// device's rules, and store it; nothing is written if any is refused.
    #[command(after_help = live::config::help())]
    Set {
        #[command(flatten)]
        target: Target,
        /// `name=value` (`live config get` lists the names).
        #[arg(required = true)]
        assignments: Vec<String>,
        /// With --flash: store over an image that holds data but no set
        /// that reads back (a spoiled slot), starting from the defaults;
        /// without it, such an image is refused.
        #[arg(long)]
        replace_unreadable: bool,
    },
}

/// Where the settings are: a flash image, or a device on the link.
#[derive(clap::Args)]
#[group(required = true, multiple = false)]
struct Target {
    /// A settings flash image (QEMU's: `skin-qemu flash=PATH`; created
    /// erased by `set` if missing).
    #[arg(long)]
    flash: Option<PathBuf>,
    /// A running device on a TCP socket (QEMU's `-serial tcp:…`).
    #[arg(long)]
    tcp: Option<String>,
    /// A device on a serial port (the board's ST-LINK virtual COM port).
    #[arg(long)]
    serial: Option<String>,
}

/// How long a device may take to answer a request.
const REPLY_TIMEOUT: Duration = Duration::from_secs(20);

/// The settings where `target` says: read, and (with `set`) written.
fn with_target(
    target: &Target,
    change: Option<&dyn Fn(Option<instrument::stored::Stored>) -> Result<instrument::stored::Stored>>,
    unreadable: live::config::Unreadable,
) -> Result<(instrument::stored::Stored, u32, bool)> {
    use live::config::{read_image, update_image, Device};
    let device = |port: Box<dyn ReadWrite>| Device::new(port, REPLY_TIMEOUT);
    let mut dev = match (&target.flash, &target.tcp, &target.serial) {
        (Some(flash), _, _) => {
            return match change {
                None => {
                    let read = read_image(flash)?;
                    // A spoiled slot beside the one in force: said.
                    for line in live::config::spoiled_slots(flash)? {
                        eprintln!("{}: {line}", flash.display());
                    }
                    Ok(read.map_or(
                        (instrument::stored::Stored::uncalibrated(), 0, false),
                        |(s, g)| (s, g, true),
                    ))
                }
                Some(f) => {
                    let (set, g) = update_image(flash, unreadable, f)?;
                    Ok((set, g, true))
                }
            };
        }
        _ => device(open_device(target)?),
    };
    let stored = dev.read()?;
    match change {
        None => Ok(stored.map_or(
            (instrument::stored::Stored::uncalibrated(), 0, false),
            |(s, g)| (s, g, true),
        )),
        Some(f) => {
            let set = f(stored.map(|(s, _)| s))?;
            let g = dev.write(&set)?;
            Ok((set, g, true))
        }
    }
}

/// The device `target` names on a socket or a serial port (reads time
/// out after 200 ms, so that a silent device is noticed).
fn open_device(target: &Target) -> Result<Box<dyn ReadWrite>> {
    match (&target.tcp, &target.serial) {
        (Some(addr), _) => {
            let sock = std::net::TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
            sock.set_read_timeout(Some(Duration::from_millis(200)))?;
            Ok(Box::new(sock))
        }
        (None, Some(name)) => Ok(Box::new(
            serialport::new(name, link::BOARD_BAUD)
                .timeout(Duration::from_millis(200))
                .open()
                .with_context(|| format!("opening the serial port {name} (in use, or not there?)"))?,
        )),
        (None, None) => anyhow::bail!("say where the device is: --tcp HOST:PORT or --serial PORT"),
    }
}

/// A port that reads and writes.
trait ReadWrite: std::io::Read + std::io::Write {}
impl<T: std::io::Read + std::io::Write> ReadWrite for T {}

/// `live config …`.
fn config(action: ConfigAction) -> Result<()> {
    use live::config::{assign, entries};
    match action {
        ConfigAction::Get { target } => {
            let (set, generation, stored) = with_target(&target, None, Unreadable::Refuse)?;
            let mut lines = vec![];
            match stored {
                true => lines.push(format!("# generation {generation}")),
                false => lines.push("# nothing stored: a new device's defaults".to_string()),
            }
            lines.extend(entries(&set).into_iter().map(|(n, v)| format!("{n} = {v}")));
            // Written whole or stopped quietly when the reader goes
            // (`| head`).
            let mut out = std::io::stdout().lock();
            for line in lines {
                match writeln!(out, "{line}") {
                    Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                    other => other?,
                }
            }
        }
        ConfigAction::Set {
            target,
            assignments,
            replace_unreadable,
        } => {
            let change = |current: Option<instrument::stored::Stored>| {
                // A new device starts from its defaults.
                let mut set = current.unwrap_or_else(instrument::stored::Stored::uncalibrated);
                for a in &assignments {
                    let (name, value) = a.split_once('=').with_context(|| format!("'{a}': name=value"))?;
                    assign(&mut set, name.trim(), value)?;
                }
                Ok(set)
            };
            let unreadable = match replace_unreadable {
                true => Unreadable::Replace,
                false => Unreadable::Refuse,
            };
            let (_, generation, _) = with_target(&target, Some(&change), unreadable)?;
            println!("stored: generation {generation}");
        }
    }
    Ok(())
}

/// `live calibrate`'s options.
#[derive(clap::Args)]
struct CalibrateArgs {
    #[command(flatten)]
    target: Target,
    /// The holds: CSV `stretch_mm,from_s,to_s`, one line per stretch
    /// held (at least two), spans in the device's clock (s since its
    /// start; leave out the settling after each move); or
    /// `sensor,stretch_mm,from_s,to_s`, each sensor its own stretches
    /// (`sensor`: its index, or with --skin its name or its group's).
    #[arg(long, required_unless_present = "at", conflicts_with = "at")]
    holds: Option<PathBuf>,
    /// The skin's description: the names and groups a holds file's
    /// `sensor` may give.
    #[arg(long, requires = "holds")]
    skin: Option<PathBuf>,
    /// With --skin: which of the skin's boards this device is.
    #[arg(long, requires = "skin")]
    board: Option<String>,
    /// Guided: the stretches to hold in turn, mm (e.g. 0,10,20,30);
    /// for each, hold the skin still and press Enter.
    #[arg(long, value_delimiter = ',')]
    at: Option<Vec<f64>>,
    /// Guided: first measure an open fixture: every sensor unplugged,
    /// its cable left on the board; the cables' capacitance is then
    /// measured, not only fitted.
    #[arg(long, requires = "at")]
    open: bool,
    /// The open fixture's span in a recording or a holds run: FROM,TO
    /// (s of the device's clock) in which every sensor was unplugged,
    /// its cable left on.
    #[arg(long, value_delimiter = ',', value_name = "FROM,TO", conflicts_with = "at")]
    open_at: Option<Vec<f64>>,
    /// Guided: seconds measured at each stretch (the device's clock).
    #[arg(long, default_value_t = 2.0)]
    hold_s: f64,
    /// Guided: seconds left out after Enter (the electrodes settle).
    #[arg(long, default_value_t = 0.25)]
    settle_s: f64,
    /// Fit the records of a recorded stream (`stream.bin`) instead of
    /// reading them from the device (needed with --flash).
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Write the report (Markdown) here too.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Keep the records read from the device (the raw stream) here.
    #[arg(long)]
    keep: Option<PathBuf>,
    /// Fit and report, store nothing.
    #[arg(long)]
    dry_run: bool,
    /// Measure again instead: each sensor's stretch at each hold as
    /// the device reads it (with the set stored, in force from the
    /// block after it was stored), against the stretch held; nothing
    /// stored.
    #[arg(long, conflicts_with = "dry_run")]
    verify: bool,
    /// Stop the device once the set is stored.
    #[arg(long)]
    stop: bool,
}

/// Guided: ask for each step on stderr, wait for Enter on stdin.
fn ask(k: usize, step: live::calibrate::Step, now_s: f64) -> Result<live::calibrate::Ready> {
    use live::calibrate::Step;
    let what = match step {
        Step::Open => "unplug every sensor, leaving its cable on the board (the open fixture)".to_string(),
        Step::Stretch(mm) if k > 0 => format!("with the sensors plugged in, hold the skin still at {mm} mm"),
        Step::Stretch(mm) => format!("hold the skin still at {mm} mm"),
    };
    eprint!(
        "[{}] the device at {now_s:.1} s: {what}, then press Enter ",
        k + 1
    );
    std::io::stderr().flush()?;
    let mut line = String::new();
    if std::io::stdin().read_line(&mut line)? == 0 {
        anyhow::bail!("no answer (stdin closed): calibration abandoned, nothing stored");
    }
    Ok(live::calibrate::Ready::Now)
}

/// `live calibrate …`.
fn calibrate(a: CalibrateArgs) -> Result<()> {
    use live::calibrate::{self as cal, Options};
    let CalibrateArgs {
        target,
        holds,
        skin,
        board,
        at,
        open,
        open_at,
        hold_s,
        settle_s,
        replay,
        report,
        keep,
        dry_run,
        verify,
        stop,
    } = a;
    let guide = at.map(|at_mm| cal::Guide {
        open,
        at_mm,
        settle_s,
        hold_s,
        sweep: true,
    });
    let holds = match (&holds, &guide) {
        (Some(path), _) => {
            let skin = match &skin {
                Some(p) => Some(live::skin::read(p)?.on_board(board.as_deref())?),
                None => None,
            };
            cal::read_holds(path, skin.as_ref())?
        }
        (None, Some(_)) if replay.is_some() => {
            anyhow::bail!("--at guides a live device: a recording needs --holds")
        }
        _ => vec![],
    };
    let opts = Options {
        open: match open_at.as_deref() {
            Some(&[from, to]) if from >= 0.0 && to > from => Some((from, to)),
            Some(v) => anyhow::bail!("--open-at {v:?}: FROM,TO with 0 ≤ FROM < TO (s)"),
            None => None,
        },
        ..Options::default()
    };
    if verify {
        return verify_device(target, holds, guide, replay, report, keep, stop);
    }
    let text = match (&replay, &target.flash) {
        (Some(path), _) => calibrate_recording(&target, path, &holds, &opts, dry_run)?,
        (None, Some(_)) => anyhow::bail!("--flash holds no records: give the recorded stream with --replay"),
        (None, None) => {
            if dry_run {
                anyhow::bail!("--dry-run fits a recording: give it with --replay");
            }
            calibrate_device(&target, guide.as_ref(), &holds, &opts, stop, keep.as_deref())?
        }
    };
    println!("{text}");
    if let Some(path) = &report {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// `live calibrate --replay`: the recorded stream at `path` fitted, the
/// set stored into `target` unless `dry_run`; the report.
fn calibrate_recording(
    target: &Target,
    path: &Path,
    holds: &[live::calibrate::Hold],
    opts: &live::calibrate::Options,
    dry_run: bool,
) -> Result<String> {
    use live::calibrate as cal;
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let records = cal::records_of(&bytes);
    // A flash image not yet made is a new device.
    let base = match &target.flash {
        Some(f) if !f.exists() => instrument::stored::Stored::uncalibrated(),
        _ => with_target(target, None, Unreadable::Refuse)?.0,
    };
    let (set, outcomes) = cal::calibrate(&records, holds, &base, opts);
    let text = cal::report(holds, &outcomes);
    if !outcomes.iter().any(|o| matches!(o, cal::Outcome::Fitted(_))) {
        anyhow::bail!("no sensor could be calibrated:\n{text}");
    }
    if !dry_run {
        let change = |_: Option<instrument::stored::Stored>| Ok(set);
        let (_, generation, _) = with_target(target, Some(&change), Unreadable::Refuse)?;
        println!("stored: generation {generation}");
    }
    Ok(text)
}

/// `live calibrate` on a running device: guided (`guide`) or at the
/// spans of `holds`, the stream kept at `keep`; the report.
fn calibrate_device(
    target: &Target,
    guide: Option<&live::calibrate::Guide>,
    holds: &[live::calibrate::Hold],
    opts: &live::calibrate::Options,
    stop: bool,
    keep: Option<&Path>,
) -> Result<String> {
    use live::calibrate as cal;
    let port = open_device(target)?;
    let done = match guide {
        Some(g) => cal::guided(port, g, ask, opts, stop, REPLY_TIMEOUT)?,
        None => cal::on_device(port, holds, opts, stop, REPLY_TIMEOUT)?,
    };
    if let Some(path) = keep {
        std::fs::write(path, &done.stream).with_context(|| format!("writing {}", path.display()))?;
    }
    for (k, said) in done.sweeps.iter().enumerate().filter(|(_, s)| *s != "swept") {
        eprintln!("hold {}: {said}", k + 1);
    }
    println!(
        "stored: generation {} (in force from the device's next block, or next start on the multiplexed board: its applied frame says)",
        done.generation
    );
    Ok(cal::report(&done.holds, &done.outcomes))
}

/// `live calibrate --verify`: the device measured again at known
/// stretches, nothing stored.
fn verify_device(
    target: Target,
    holds: Vec<live::calibrate::Hold>,
    guide: Option<live::calibrate::Guide>,
    replay: Option<PathBuf>,
    report: Option<PathBuf>,
    keep: Option<PathBuf>,
    stop: bool,
) -> Result<()> {
    use live::calibrate as cal;
    let (holds, checks, stream) = match &replay {
        Some(path) => {
            let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
            let checks = cal::verify(&cal::records_of(&bytes), &holds);
            (holds, checks, vec![])
        }
        None => {
            let port =
                open_device(&target).context("--verify measures a device, or a recording with --replay")?;
            let (holds, checks, stream, port) = match &guide {
                Some(g) => {
                    let (h, c, s) = cal::verify_guided(port, g, ask, stop, REPLY_TIMEOUT)?;
                    (h, c, s, None)
                }
                None => {
                    let mut port = port;
                    let until = holds.iter().map(|h| h.to_s).fold(0.0, f64::max);
                    let (records, stream) = cal::collect(&mut port, until, REPLY_TIMEOUT)?;
                    let checks = cal::verify(&records, &holds);
                    (holds, checks, stream, Some(port))
                }
            };
            if stop {
                if let Some(port) = port {
                    live::config::Device::new(port, REPLY_TIMEOUT).stop()?;
                }
            }
            (holds, checks, stream)
        }
    };
    if let Some(path) = &keep {
        std::fs::write(path, &stream).with_context(|| format!("writing {}", path.display()))?;
    }
    let text = cal::check_report(&holds, &checks);
    println!("{text}");
    if let Some(path) = &report {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn main() -> ExitCode {
    // A file that reaches the size limit (`ulimit -f`) fails its write,
    // which the session reports with every file cut back to whole lines,
    // instead of the process being killed in the middle of a line.
    // SAFETY: setting a signal's disposition to SIG_IGN, before any
    // thread is started.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    let mut cli = Cli::parse();
    let done = match cli.command.take() {
        Some(Command::Config { action }) => Some(config(action)),
        Some(Command::Calibrate(args)) => Some(calibrate(args)),
        None => None,
    };
    if let Some(done) = done {
        return match done {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        };
    }
    match run(cli) {
        Ok(Outcome::Complete | Outcome::Stopped) => ExitCode::SUCCESS,
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

/// Say why reading `what` stopped, unless the stream ended as it should.
fn report(what: &str, stopped: Stopped) {
    match stopped {
        Stopped::End => {}
        Stopped::Source(why) => eprintln!("{what} stopped: {why}"),
        Stopped::Asked => {
            eprintln!("stopped (Ctrl-C or `quit`): the recording holds every record that arrived")
        }
    }
}

fn run(cli: Cli) -> Result<Outcome> {
    let dataset = cli.dataset.clone().unwrap_or_else(new_session_folder);
    if !cli.sources.is_empty() {
        return run_skin(&cli, &dataset);
    }
    let following = cli.replay.is_none();
    // The skin, checked whole before anything starts.
    let skin = match &cli.skin {
        Some(path) => Some(Arc::new(live::skin::read(path)?.on_board(cli.board.as_deref())?)),
        None => None,
    };
    // Markers, and recordings started and stopped, from the page and
    // from standard input, to the loop that reads the link.
    let (marks_tx, marks) = std::sync::mpsc::channel();
    let (commands_tx, commands) = std::sync::mpsc::channel();
    let dashboard = serve(
        cli.serve,
        following.then(|| marks_tx.clone()),
        following.then(|| commands_tx.clone()),
    )?;
    // Ctrl-C ends a live stream (a board's never ends by itself), the
    // normal way to end a run: the recording running is written with
    // what arrived, complete. `quit` on standard input does the same.
    let stop = stop_on_ctrl_c()?;
    if following {
        read_stdin(Arc::clone(&stop), marks_tx, commands_tx);
    }
    let earlier = earlier(cli.overwrite);
    let mut folders = live::Folders::new(dataset.clone(), earlier);
    // The first recording from the start, unless --idle (checked now:
    // a folder that holds files is refused before the source opens).
    let first = match cli.idle {
        true => None,
        false => Some(Session::new(&folders.take_next(), earlier)?),
    };
    let first = first.map(|mut s| {
        if let Some(skin) = &skin {
            s.set_skin(skin.clone());
        }
        s
    });
    if let (Some(d), Some(skin)) = (&dashboard, &skin) {
        d.set_skin(skin.clone());
    }
    let mut sink = Sink::new(first, dashboard.as_ref());
    sink.skin = skin;
    sink.marks = Some(&marks);
    if following {
        sink.commands = Some(&commands);
        sink.folders = Some(folders);
    }
    let stopped = read_source(&cli, &mut sink, &stop)?;
    if let Some(d) = &dashboard {
        if let Some(s) = &sink.session {
            d.availability(s.availability(), s.interpolated(), true);
        }
        d.end();
    }
    if dashboard.is_some() && cli.linger > 0 {
        eprintln!("the stream ended; serving the dashboard {} s more", cli.linger);
        std::thread::sleep(Duration::from_secs(cli.linger));
    }
    end_recordings(&mut sink, stopped)
}

/// What a session does with a folder that holds files: replaced where
/// `--overwrite` asks, else refused.
fn earlier(overwrite: bool) -> live::Earlier {
    match overwrite {
        true => live::Earlier::Overwrite,
        false => live::Earlier::Refuse,
    }
}

/// The flag Ctrl-C sets: it ends a live stream (a board's never ends by
/// itself), the normal way to end a run.
fn stop_on_ctrl_c() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("installing the Ctrl-C handler")?;
    Ok(stop)
}

/// Several boards in one session (`--source`, once per board): each
/// read until it ends or Ctrl-C, the skin's records and manifest
/// written; each board's ending printed.
fn run_skin(cli: &Cli, dataset: &Path) -> Result<Outcome> {
    let Some(path) = &cli.skin else {
        anyhow::bail!("--source needs the skin's description: --skin FILE");
    };
    let skin = live::skin::read(path)?;
    for said in live::boards::check(&skin, &cli.sources)? {
        eprintln!("{said}");
    }
    let earlier = earlier(cli.overwrite);
    let stop = stop_on_ctrl_c()?;
    let dashboard = serve(cli.serve, None, None)?;
    let done = live::boards::read_all(dataset, earlier, &skin, &cli.sources, &stop, dashboard.as_ref())?;
    if let Some(d) = &dashboard {
        d.end();
        if cli.linger > 0 {
            eprintln!(
                "the boards' streams ended; serving the dashboard {} s more",
                cli.linger
            );
            std::thread::sleep(Duration::from_secs(cli.linger));
        }
    }
    let mut outcome = Outcome::Complete;
    for b in &done {
        println!("board {}: {}", b.board, b.summary);
        let devices: Vec<String> = b.devices.iter().map(|d| format!("{d:#010x}")).collect();
        println!(
            "board {}: device {} ({} segments, opened again {} times)",
            b.board,
            devices.join(", "),
            b.devices.len(),
            b.reconnects
        );
        for line in clock_lines(&b.clocks) {
            println!("board {}: {line}", b.board);
        }
        if let Outcome::Incomplete(why) = &b.outcome {
            outcome = Outcome::Incomplete(format!("board {}: {why}", b.board));
        }
    }
    println!(
        "wrote {}: records.csv (every board's, on the host's UTC), {}, a folder per board",
        dataset.display(),
        live::boards::SKIN_JSON
    );
    Ok(outcome)
}

/// The run is over (`stopped`: how a live source stopped): the
/// recordings that ended before named, the one running finished and
/// printed; how the run ended.
fn end_recordings(sink: &mut Sink, stopped: Option<Stopped>) -> Result<Outcome> {
    let earlier_ones = std::mem::take(&mut sink.finished);
    let several = !earlier_ones.is_empty();
    for (dir, done) in &earlier_ones {
        println!("recording {}: {}", dir.display(), done.summary.line());
    }
    let Some(mut session) = sink.session.take() else {
        return Ok(match stopped.as_ref().and_then(source_lost) {
            Some(why) if !several => {
                Outcome::Incomplete(format!("the source was lost ({why}) before any recording"))
            }
            _ => Outcome::Stopped,
        });
    };
    if stopped == Some(Stopped::Asked) {
        session.ask_stop();
    }
    if several {
        println!("recording {}:", session.dir().display());
    }
    print_finished(session)
}

/// Read the source `cli` names into `sink` until it ends: a recorded
/// stream to its end (None), a live one until `stop` or its end (why
/// it stopped, said).
fn read_source(cli: &Cli, sink: &mut Sink, stop: &AtomicBool) -> Result<Option<Stopped>> {
    let (stopped, what) = match (&cli.replay, &cli.serial, &cli.tcp) {
        (Some(path), _, _) => {
            // Read in pieces: a recording of a day does not fit in memory.
            let file = std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
            let beside = path.with_file_name(live::ARRIVALS_CSV);
            let arrivals = match &cli.arrivals {
                Some(a) => Some(live::Arrivals::open(a)?),
                None if beside.is_file() => Some(live::Arrivals::open(&beside)?),
                None => None,
            };
            live::replay_from(file, sink, arrivals)?;
            return Ok(None);
        }
        (None, Some(name), _) => {
            let port = serialport::new(name, cli.baud)
                .timeout(Duration::from_millis(200))
                .open()
                .with_context(|| format!("opening the serial port {name} (in use, or not there?)"))?;
            (follow(port, sink, stop)?, format!("the serial port {name}"))
        }
        (None, None, Some(addr)) => {
            let sock = std::net::TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
            sock.set_read_timeout(Some(Duration::from_millis(200)))?;
            (follow(sock, sink, stop)?, format!("the socket {addr}"))
        }
        (None, None, None) => {
            anyhow::bail!("say where the records come from: --replay FILE, --serial PORT or --tcp HOST:PORT")
        }
    };
    report(&what, stopped.clone());
    Ok(Some(stopped))
}

/// Why the source was lost, where it was.
fn source_lost(stopped: &Stopped) -> Option<String> {
    match stopped {
        Stopped::Source(why) => Some(why.clone()),
        _ => None,
    }
}

/// The recording `session` finished: its summary, availability, clock
/// and files printed; how it ended.
fn print_finished(session: Session) -> Result<Outcome> {
    print_refused(&session);
    let session_clock: Vec<_> = session.segments().iter().map(|g| g.clock.line()).collect();
    for (k, g) in session.segments().iter().enumerate() {
        println!(
            "segment {k}: {}, device {:#010x}, stored settings generation {}",
            g.start.firmware_str(),
            g.start.device_id,
            g.start.generation
        );
        println!(
            "segment {k}: {}",
            live::self_test::line(&g.start.self_test, g.start.sensors)
        );
        for (seq, a) in &g.applied {
            println!(
                "segment {k}: settings generation {} applied at {:.3} s (frame {seq}), in force for the records after it",
                a.generation,
                a.t_us as f64 * 1e-6
            );
        }
    }
    let started = session.start().is_some();
    let dataset = session.dir().to_path_buf();
    let finished = session.finish()?;
    println!("{}", finished.summary.line());
    for line in finished.summary.availability_lines() {
        println!("  {line}");
    }
    for line in clock_lines(&session_clock) {
        println!("{line}");
    }
    if started {
        println!(
            "wrote {}: records.csv, stream.bin, {} trace files, {} fragments, calibration.csv, faults.csv",
            dataset.display(),
            finished.written.traces.len(),
            finished.written.fragments.len()
        );
        for why in &finished.written.left_out {
            println!("left out: {why}");
        }
    } else {
        println!("no start frame arrived: nothing written to {}", dataset.display());
    }
    Ok(finished.outcome)
}

/// The dashboard on `addr`, where asked (this machine's addresses only);
/// its address printed first.
fn serve(
    addr: Option<std::net::SocketAddr>,
    marks: Option<std::sync::mpsc::Sender<live::markers::Mark>>,
    commands: Option<std::sync::mpsc::Sender<live::Command>>,
) -> Result<Option<Dashboard>> {
    let Some(addr) = addr else {
        return Ok(None);
    };
    if !addr.ip().is_loopback() {
        anyhow::bail!("--serve {addr}: the dashboard serves this machine only (127.0.0.1 or [::1])")
    }
    let d = Dashboard::serve(addr, marks, commands)?;
    println!("dashboard: http://{}/", d.addr());
    std::io::stdout().flush()?;
    Ok(Some(d))
}

/// Each segment's clock fit, a line each (where there is one).
fn clock_lines(fits: &[Option<live::clock::Line>]) -> Vec<String> {
    fits.iter()
        .enumerate()
        .filter_map(|(k, l)| {
            let l = l.as_ref()?;
            let drift = match l.rate_fitted {
                true => format!(
                    "drift {:+.1} ± {:.1} ppm",
                    (l.rate - 1.0) * 1e6,
                    l.sigma_rate * 1e6
                ),
                false => format!("drift not fitted (under {} s)", live::clock::DRIFT_SPAN_S),
            };
            Some(format!(
                "device clock, segment {}: started {} UTC (±{:.2} ms), {drift}, arrivals scatter {:.2} ms RMS ({} reads)",
                k + 1,
                live::clock::utc(l.offset_s).unwrap_or_default(),
                l.sigma_offset_s * 1e3,
                l.rms_s * 1e3,
                l.points
            ))
        })
        .collect()
}

/// Standard input while a stream is followed, a line a request:
/// `start [FOLDER]` starts a recording, `stop` stops it (its set written,
/// complete; `live` reads on), `quit` ends the run as Ctrl-C does; any
/// other line is a marker with its text (a thread of its own; it ends
/// with standard input).
fn read_stdin(
    stop: Arc<AtomicBool>,
    marks: std::sync::mpsc::Sender<live::markers::Mark>,
    commands: std::sync::mpsc::Sender<live::Command>,
) {
    std::thread::spawn(move || {
        let mut line = String::new();
        loop {
            line.clear();
            match std::io::stdin().read_line(&mut line) {
                Ok(0) | Err(_) => return,
                Ok(_) => {}
            }
            let sent = match line.trim() {
                "" => Ok(()),
                "quit" => {
                    stop.store(true, Ordering::Relaxed);
                    Ok(())
                }
                "stop" => commands.send(live::Command::Stop(None)).map_err(drop),
                "start" => commands.send(live::Command::Start(None, None)).map_err(drop),
                text => match text.strip_prefix("start ") {
                    Some(dir) => commands
                        .send(live::Command::Start(Some(PathBuf::from(dir.trim())), None))
                        .map_err(drop),
                    None => marks.send(live::markers::Mark::now("stdin", text)).map_err(drop),
                },
            };
            if sent.is_err() {
                return;
            }
        }
    });
}

/// The frames the session refused: the first named with their place,
/// the rest counted.
fn print_refused(session: &Session) {
    for (at, why) in session.refused() {
        eprintln!("a frame ending at byte {at} of the stream was refused: {why}");
    }
    let more = session.stats().bad.saturating_sub(session.refused().len() as u64);
    if more > 0 {
        eprintln!("… and {more} more refused");
    }
}

/// A new session's folder: out/sessions/<UTC date and time>, with `-2`,
/// `-3`, … after a name an earlier session of the same second took.
fn new_session_folder() -> PathBuf {
    let stamp = chrono::Utc::now().format("%Y-%m-%dT%H-%M-%SZ").to_string();
    let base = PathBuf::from("out/sessions");
    (1..)
        .map(|k| match k {
            1 => base.join(&stamp),
            _ => base.join(format!("{stamp}-{k}")),
        })
        .find(|p| !p.exists())
        .unwrap_or_else(|| base.join(stamp))
}
