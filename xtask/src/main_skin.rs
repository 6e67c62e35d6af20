//! The main job's whole skin: four array boards (64 sensors) in QEMU,
//! their clocks offset and drifting, read by `live` in one session
//! (`qemu_tests::skin_run`); their placement on the skin's time axis
//! against the truth, each board's clock and availability, and a plot of
//! one sensor of each board on the common axis, written to `out/skin`.

use anyhow::{bail, Context, Result};
use host_sim::plot::{figure, Panel, Series};
use qemu_tests::skin_run::{self, BoardSpec, Placed, FOUR};
use std::fmt::Write as _;
use std::path::Path;

/// Seconds each board runs: past the drift fit's span.
const SECONDS: u32 = 12;
/// Records a second of each sensor (4 ms blocks).
const RECORDS: u32 = 250;

/// Run the skin and write `out`'s summary, plot and session; returns the
/// summary.
pub fn run(out: &Path) -> Result<String> {
    eprintln!("running four array boards in QEMU ({SECONDS} s each, 64 sensors), then reading them in one session in real time...");
    let streams = skin_run::streams(&FOUR, SECONDS, RECORDS)?;
    let dashboard = live::dashboard::Dashboard::serve("127.0.0.1:0".parse()?, None, None)?;
    let shot = out.join("dashboard.png");
    let _ = std::fs::remove_file(&shot);
    let url = format!("http://{}/", dashboard.addr());
    let run = std::thread::scope(|s| {
        let camera = s.spawn(|| screenshot(&url, &shot));
        let run = skin_run::session(
            &out.join("session"),
            &FOUR,
            streams,
            1_000_000 / RECORDS as u64,
            Some(&dashboard),
        );
        camera
            .join()
            .map_err(|_| anyhow::anyhow!("the screenshot's thread panicked"))??;
        run
    })?;
    dashboard.end();
    let placed = skin_run::placement(&run, &FOUR)?;
    let valid = valid_shares(&run.dir.join(live::RECORDS_CSV), &FOUR)?;
    let mut md = format!(
        "# The whole skin: four boards in one session\n\n\
         Four array boards of sixteen sensors each (64 sensors, the `paper` scenario, {RECORDS} records/s \
         each, the paper's sensors under its 20 mm/s trapezoid, calibrated), their clocks started seconds apart and drifting by tens of ppm each way, were run in QEMU; \
         each board's stream was then sent down its own socket in real time, as its link would bring it, \
         and `live --skin session.toml --source A=tcp:… …` read the four in one session, fitting each \
         board's clock to the host's. Every record is placed on the host's UTC and checked against the \
         instant it was taken (the images' clocks are known).\n\n{}",
        table(&run, &placed, &valid)
    );
    let worst = placed.iter().map(|p| p.worst_ms).fold(0.0, f64::max);
    let records: u64 = placed.iter().map(|p| p.records).sum();
    writeln!(
        md,
        "\n**{records} records of {} sensors from {} boards, aligned within {worst:.3} ms** (the largest \
         distance of a record from the skin's common lateness; the goal is 1 ms).\n\n\
         Wrote the session (`session/`: a folder per board, the skin's `records.csv` keyed by board and \
         sensor on the host's UTC, `skin.json`), `session.toml` (the skin's description) and \
         `skin_axis.svg` (sensor 0 of each board on the common axis: the four boards measure the same \
         stretching, so their traces lie on each other when aligned), and `dashboard.png`: the dashboard \
         (`--serve`) in headless Chromium {SHOT_AT_S} s into the session, the skin's 64 sensors on its \
         layout coloured by their stretch, the boards' clocks and links, sensor 0's charts with its \
         group's.",
        16 * FOUR.len(),
        FOUR.len()
    )?;
    plot(out, &run)?;
    std::fs::write(out.join("summary.md"), &md)?;
    if worst >= 1.0 {
        bail!("the boards' records are {worst:.3} ms apart on the skin's axis (goal: 1 ms)");
    }
    Ok(md)
}

/// The per-board table: device, records, valid share, clock, placement.
fn table(run: &skin_run::SkinRun, placed: &[Placed], valid: &[f64]) -> String {
    let mut t = String::from(
        "| board | device | records | valid | clock offset set | drift set | drift fitted (1σ) | \
         against the others: set, fitted | offset 1σ | mean lateness | farthest from the others |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let line = |b: &live::boards::BoardDone| b.clocks.first().copied().flatten();
    let fitted: Vec<f64> = run
        .boards
        .iter()
        .map(|b| line(b).map_or(f64::NAN, |l| (1.0 / l.rate - 1.0) * 1e6))
        .collect();
    let mean_fit = fitted.iter().sum::<f64>() / fitted.len() as f64;
    let mean_set = FOUR.iter().map(|b| b.drift_ppm as f64).sum::<f64>() / FOUR.len() as f64;
    for ((((b, spec), p), v), f) in run.boards.iter().zip(&FOUR).zip(placed).zip(valid).zip(&fitted) {
        let (sigma_rate, sigma) = line(b).map_or((f64::NAN, f64::NAN), |l| {
            (l.sigma_rate * 1e6, l.sigma_offset_s * 1e3)
        });
        let _ = writeln!(
            t,
            "| {} | {:#010x} | {} | {:.1} % | {:.3} s | {:+} ppm | {f:+.2} ± {sigma_rate:.2} ppm | \
             {:+.1}, {:+.2} ppm | {sigma:.3} ms | {:.2} ms | {:.3} ms |",
            b.board,
            spec.device_id,
            p.records,
            100.0 * v,
            spec.offset_us as f64 * 1e-6,
            spec.drift_ppm,
            spec.drift_ppm as f64 - mean_set,
            f - mean_fit,
            p.mean_ms,
            p.worst_ms
        );
    }
    let _ = writeln!(
        t,
        "\nThe drifts are fitted against the host's UTC clock, which stamps the arrivals. A term every board \
         shares (here {:+.2} ppm on average) is the host's: its UTC clock against the monotonic one that paced \
         the streams, and sends that fall later as the host gets busier (headless Chromium draws the dashboard \
         beside). Against each other the boards' drifts are what was set within {:.2} ppm.",
        mean_fit - mean_set,
        FOUR.iter()
            .zip(&fitted)
            .map(|(b, f)| ((f - mean_fit) - (b.drift_ppm as f64 - mean_set)).abs())
            .fold(0.0, f64::max)
    );
    t
}

/// Each board's share of records flagged valid, from the skin's table.
fn valid_shares(path: &Path, boards: &[BoardSpec]) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut n = vec![(0u64, 0u64); boards.len()];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let Some(k) = boards.iter().position(|b| Some(&b.name) == f.first()) else {
            continue;
        };
        let flags: u16 = f
            .get(19)
            .and_then(|s| s.parse().ok())
            .context("a record without flags")?;
        n[k].0 += 1;
        n[k].1 += u64::from(instrument::faults::Flags(flags).valid());
    }
    Ok(n.iter()
        .map(|(all, ok)| *ok as f64 / (*all).max(1) as f64)
        .collect())
}

/// Sensor 0 of each board on the skin's axis (s from the first record).
fn plot(out: &Path, run: &skin_run::SkinRun) -> Result<()> {
    let text = std::fs::read_to_string(run.dir.join(live::RECORDS_CSV))?;
    let mut series: Vec<Series> = FOUR
        .iter()
        .map(|b| Series::new(format!("board {}", b.name), vec![]))
        .collect();
    let mut t0 = None;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (Some(t), Some(c)) = (f[2].parse::<i64>().ok(), f[13].parse::<f64>().ok()) else {
            continue;
        };
        let t0 = *t0.get_or_insert(t);
        let valid = f
            .get(19)
            .and_then(|s| s.parse().ok())
            .is_some_and(|b| instrument::faults::Flags(b).valid());
        if f[6] == "0" && valid {
            if let Some(k) = FOUR.iter().position(|b| b.name == f[0]) {
                series[k].points.push(((t - t0) as f64 * 1e-6, c));
            }
        }
    }
    if series.iter().any(|s| s.points.len() < 2) {
        bail!("sensor 0 of a board has fewer than two valid records: nothing to plot");
    }
    let panel = Panel {
        title: "sensor 0 of each board, placed by its board's clock fit".into(),
        x_label: "the skin's time [s]".into(),
        y_label: "C [pF]".into(),
        log_x: false,
        series,
    };
    figure(
        &out.join("skin_axis.svg"),
        "Four boards on one time axis (QEMU, clocks offset and drifting)",
        &[panel],
    )
    .context("plot")
}

/// When the dashboard is photographed, s into the session.
const SHOT_AT_S: u64 = 8;

/// The dashboard at `url` in headless Chromium: sensor 0 selected (its
/// charts and its group's), photographed [`SHOT_AT_S`] s into the
/// session to `path`.
fn screenshot(url: &str, path: &Path) -> Result<()> {
    use std::time::Duration;
    let t0 = std::time::Instant::now();
    let mut browser = live::devtools::Browser::open(url, &[])?;
    let page = &mut browser.page;
    page.until(
        "document.querySelectorAll('#skin [data-sensor]').length === 64",
        Duration::from_secs(60),
    )?;
    page.until("bySensor.has(0)", Duration::from_secs(60))?;
    page.eval("document.querySelector('#taxel-0').dispatchEvent(new MouseEvent('click', {bubbles: true}))")?;
    if let Some(wait) = Duration::from_secs(SHOT_AT_S).checked_sub(t0.elapsed()) {
        std::thread::sleep(wait);
    }
    page.screenshot(path, 1400, 1500)
}
