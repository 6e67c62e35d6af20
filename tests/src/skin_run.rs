//! A skin of four array boards (64 sensors) in one `live` session, their
//! clocks offset and drifting: the test of the common time base and the
//! main job's `out/skin`.
//!
//! QEMU runs the array's sixteen sensors several times slower than real
//! time (the simulated skin's lines are f64 on a core without an f64
//! unit), so a board cannot be run paced to the host's clock. Each
//! board's image runs first, as fast as QEMU goes, with its own
//! `device=`, `offset_us=` and `drift_ppm=`; then each stream is sent
//! down a TCP socket in real time, every block's frames at the moment
//! the board would have sent them (the block's end on the shared true
//! clock, plus the board's processing latency), as its link would
//! bring them. `live` reads the four sockets in one session and fits
//! each board's clock to the host's as it would a board's serial port.
//! The truth of each record's instant is known (the stamps are the
//! image's clock, which the test set), so the placement of every record
//! on the skin's time axis is checked against it.

use anyhow::{bail, Context, Result};
use std::io::Write;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// One simulated board: its name in the skin, its device id, its clock.
#[derive(Clone, Copy, Debug)]
pub struct BoardSpec {
    /// Its name in the skin's description.
    pub name: &'static str,
    /// The device id its start frame reports.
    pub device_id: u32,
    /// Its clock's reading at true time 0, µs.
    pub offset_us: u32,
    /// Its clock's drift, ppm.
    pub drift_ppm: i32,
}

impl BoardSpec {
    /// True time (µs since the shared start) of device time `t_us`.
    pub fn true_us(&self, t_us: u64) -> f64 {
        (t_us as f64 - self.offset_us as f64) / (1.0 + self.drift_ppm as f64 * 1e-6)
    }
}

/// Four boards whose clocks disagree as real boards' do: started
/// seconds apart, drifting by tens of ppm each way (a crystal's
/// tolerance and temperature; a board's internal RC would be worse).
pub const FOUR: [BoardSpec; 4] = [
    BoardSpec {
        name: "A",
        device_id: 0x0A11_0001,
        offset_us: 1_250_000,
        drift_ppm: 85,
    },
    BoardSpec {
        name: "B",
        device_id: 0x0A11_0002,
        offset_us: 3_900_000,
        drift_ppm: -60,
    },
    BoardSpec {
        name: "C",
        device_id: 0x0A11_0003,
        offset_us: 250_000,
        drift_ppm: 20,
    },
    BoardSpec {
        name: "D",
        device_id: 0x0A11_0004,
        offset_us: 17_500_000,
        drift_ppm: -110,
    },
];

/// From a block's end to its records on the wire, µs: the array's
/// latency on the board (docs/benchmarks.md, `array_latency_us`, in
/// cycles at 170 MHz).
pub const LATENCY_US: u64 = 850;

/// The skin's description: sixteen sensors a board, each board a 4×4
/// patch of a forearm's layout, its group the board's region.
pub fn skin_toml(boards: &[BoardSpec]) -> String {
    const REGIONS: [&str; 4] = ["wrist", "forearm-inner", "forearm-outer", "elbow"];
    let mut t = String::from("[skin]\nname = \"forearm\"\nunits = \"mm\"\n");
    for (b, spec) in boards.iter().enumerate() {
        writeln!(
            t,
            "\n[[board]]\nname = \"{}\"\ndevice = {:#x}",
            spec.name, spec.device_id
        );
        for i in 0..16u32 {
            let (x, y) = (b as u32 * 60 + (i % 4) * 14, (i / 4) * 14);
            writeln!(
                t,
                "\n[[sensor]]\nname = \"{}-{i:02}\"\nboard = \"{}\"\nindex = {i}\ngroup = \"{}\"\n\
                 place = [{}, {}]\noutline = [[{x}, {y}], [{}, {y}], [{}, {}], [{x}, {}]]",
                spec.name,
                spec.name,
                REGIONS[b % 4],
                x + 6,
                y + 6,
                x + 12,
                x + 12,
                y + 12,
                y + 12
            );
        }
    }
    t
}

/// `writeln!` into a String (which cannot fail).
macro_rules! writeln {
    ($s:expr, $($arg:tt)*) => {{
        use std::fmt::Write as _;
        let _ = std::writeln!($s, $($arg)*);
    }};
}
use writeln;

/// Each board's stream: the array image run in QEMU (the `paper`
/// scenario: sixteen of the paper's sensors, each later in the paper's
/// cycle than the last, read with the rig's calibrated set; `seconds` s
/// at `records` records/s), two at a time.
pub fn streams(boards: &[BoardSpec], seconds: u32, records: u32) -> Result<Vec<Vec<u8>>> {
    let elf = crate::build_firmware("skin-array", &["qemu"])?;
    let run = |b: &BoardSpec| -> Result<Vec<u8>> {
        let args = [
            "paper".to_string(),
            format!("seconds={seconds}"),
            format!("records={records}"),
            format!("device={:#x}", b.device_id),
            format!("offset_us={}", b.offset_us),
            format!("drift_ppm={}", b.drift_ppm),
        ];
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let run = crate::run_qemu_args(&elf, &args, Duration::from_secs(60 * seconds as u64))?.ok()?;
        Ok(run.serial)
    };
    let mut out = vec![];
    for pair in boards.chunks(2) {
        let got: Vec<Result<Vec<u8>>> = std::thread::scope(|s| {
            let hs: Vec<_> = pair.iter().map(|b| s.spawn(move || run(b))).collect();
            hs.into_iter()
                .map(|h| h.join().unwrap_or_else(|_| bail!("a QEMU run panicked")))
                .collect()
        });
        for g in got {
            out.push(g?);
        }
    }
    Ok(out)
}

/// When each frame of `stream` leaves the board, µs of true time after
/// the start: a record's when its block's records go (its block's end
/// plus [`LATENCY_US`]), any other frame with the frame before it.
fn departures<'a>(stream: &'a [u8], board: &BoardSpec, block_us: u64) -> Vec<(&'a [u8], u64)> {
    let mut due = 0u64;
    stream
        .split_inclusive(|&b| b == 0)
        .map(|f| {
            if let Ok(link::Frame {
                body: link::Body::Record(r),
                ..
            }) = link::decode(&f[..f.len() - 1])
            {
                let end = board.true_us(r.t_us) + block_us as f64 / 2.0;
                due = due.max(end.max(0.0) as u64 + LATENCY_US);
            }
            (f, due)
        })
        .collect()
}

/// Send `stream` to the first client of `listener` in real time from
/// `start`: each block's frames in one write at its departure.
pub fn send_paced(
    listener: TcpListener,
    stream: Vec<u8>,
    board: BoardSpec,
    block_us: u64,
    start: Instant,
) -> Result<()> {
    let (mut sock, _) = listener.accept().context("waiting for live")?;
    sock.set_nodelay(true)?;
    let frames = departures(&stream, &board, block_us);
    let mut k = 0;
    while k < frames.len() {
        let due = frames[k].1;
        let mut out = vec![];
        while k < frames.len() && frames[k].1 == due {
            out.extend_from_slice(frames[k].0);
            k += 1;
        }
        if let Some(wait) = Duration::from_micros(due).checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        sock.write_all(&out)?;
    }
    sock.flush()?;
    Ok(())
}

/// Microseconds since the Unix epoch, now.
pub fn now_utc_us() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as i64)
}

/// A skin session run: what `live` made of each board, and the host's
/// UTC at the shared true time 0.
pub struct SkinRun {
    /// Each board's recording.
    pub boards: Vec<live::boards::BoardDone>,
    /// The host's UTC at true time 0, µs.
    pub start_utc_us: i64,
    /// The session's folder.
    pub dir: PathBuf,
}

/// Read `streams` (of `boards`) in one `live` session into `dir`, each
/// sent in real time down its own socket, shown on `dashboard` where
/// one is served.
pub fn session(
    dir: &Path,
    boards: &[BoardSpec],
    streams: Vec<Vec<u8>>,
    block_us: u64,
    dashboard: Option<&live::dashboard::Dashboard>,
) -> Result<SkinRun> {
    std::fs::create_dir_all(dir)?;
    let skin_path = dir.with_extension("toml");
    std::fs::write(&skin_path, skin_toml(boards))?;
    let skin = live::skin::read(&skin_path)?;
    let mut listeners = vec![];
    let mut sources = vec![];
    for b in boards {
        let l = TcpListener::bind("127.0.0.1:0")?;
        sources.push(
            format!("{}=tcp:{}", b.name, l.local_addr()?)
                .parse()
                .map_err(anyhow::Error::msg)?,
        );
        listeners.push(l);
    }
    let stop = std::sync::atomic::AtomicBool::new(false);
    let (start, start_utc_us) = (Instant::now(), now_utc_us());
    std::thread::scope(|s| {
        let senders: Vec<_> = listeners
            .into_iter()
            .zip(streams)
            .zip(boards)
            .map(|((l, bytes), b)| s.spawn(move || send_paced(l, bytes, *b, block_us, start)))
            .collect();
        let done = live::boards::read_all(dir, live::Earlier::Overwrite, &skin, &sources, &stop, dashboard)?;
        for h in senders {
            h.join().unwrap_or_else(|_| bail!("a sender panicked"))?;
        }
        Ok(SkinRun {
            boards: done,
            start_utc_us,
            dir: dir.to_path_buf(),
        })
    })
}

/// How well a board's records sit on the skin's time axis.
#[derive(Clone, Debug)]
pub struct Placed {
    /// The board.
    pub board: String,
    /// Its records on the axis.
    pub records: u64,
    /// Their mean lateness on the axis against their true instant, ms
    /// (the link's mean delay, which the arrival line holds).
    pub mean_ms: f64,
    /// The largest distance of one of its records from the skin's
    /// common lateness (the median over every board), ms: how far
    /// from the other boards' records of the same instant it is put.
    pub worst_ms: f64,
}

/// Each board's placement, from the skin's `records.csv`.
pub fn placement(run: &SkinRun, boards: &[BoardSpec]) -> Result<Vec<Placed>> {
    let text = std::fs::read_to_string(run.dir.join(live::RECORDS_CSV))?;
    let mut late: Vec<Vec<f64>> = vec![vec![]; boards.len()];
    for (n, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (Some(board), Some(t), Some(t_us)) = (f.first(), f.get(2), f.get(5)) else {
            bail!("records.csv:{}: too few fields", n + 1);
        };
        let k = boards
            .iter()
            .position(|b| b.name == *board)
            .context("a board not in the skin")?;
        let t: i64 = t
            .parse()
            .with_context(|| format!("records.csv:{}: no time on the axis", n + 1))?;
        let t_us: u64 = t_us.parse()?;
        let truth = run.start_utc_us as f64 + boards[k].true_us(t_us);
        late[k].push((t as f64 - truth) * 1e-3);
    }
    let mut all: Vec<f64> = late.iter().flatten().copied().collect();
    if all.is_empty() {
        bail!("no record on the axis");
    }
    all.sort_by(f64::total_cmp);
    let common = all[all.len() / 2];
    Ok(boards
        .iter()
        .zip(&late)
        .map(|(b, l)| Placed {
            board: b.name.to_string(),
            records: l.len() as u64,
            mean_ms: l.iter().sum::<f64>() / l.len().max(1) as f64,
            worst_ms: l.iter().map(|x| (x - common).abs()).fold(0.0, f64::max),
        })
        .collect())
}
