//! The command line: results, round trips and clear errors.

mod common;
use common::run;

#[test]
fn a_reader_that_stops_early_is_no_panic() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    // A long table; the reader takes one line and closes the pipe.
    let freqs: Vec<String> = (1..=2000).map(|k| format!("{}", 100 + 20 * k)).collect();
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "model",
            "--r",
            "700k",
            "--c",
            "200p",
            "--csv",
            "--f",
            &freqs.join(","),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with("model"), "{first}");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn model_then_invert_round_trips() {
    let (ok, out, err) = run(&[
        "model",
        "--r",
        "700k",
        "--c",
        "200p",
        "--f",
        "6k",
        "--model",
        "continuous",
        "--csv",
    ]);
    assert!(ok, "{err}");
    let row: Vec<&str> = out.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[0], "continuous");
    let (cs, rs): (f64, f64) = (row[3].parse().unwrap(), row[4].parse().unwrap());
    assert!(cs < 140.0 && cs > 130.0, "{cs}");
    let (ok, out, err) = run(&[
        "invert",
        "--cs",
        &format!("{cs}p"),
        "--rs",
        &format!("{rs}"),
        "--f",
        "6k",
        "--c-hint",
        "200p",
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("C   = 200.0"), "{out}");
    assert!(
        out.contains("R   = 700.0") || out.contains("R   = 699.9"),
        "{out}"
    );
}

#[test]
fn lumped_meter_underreads_more_at_higher_frequency() {
    let (ok, out, _) = run(&[
        "model",
        "--r",
        "700k",
        "--c",
        "200p",
        "--f",
        "500,2k,6k",
        "--model",
        "30",
        "--csv",
    ]);
    assert!(ok);
    let errs: Vec<f64> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(6).unwrap().parse().unwrap())
        .collect();
    assert_eq!(errs.len(), 3);
    assert!(errs[0] > -1.0 && errs[1] < -5.0 && errs[2] < -30.0, "{errs:?}");
}

#[test]
fn clear_errors() {
    let (ok, _, err) = run(&["model", "--r", "700x", "--c", "200p", "--f", "6k"]);
    assert!(!ok && err.contains("unknown SI prefix"), "{err}");
    let (ok, _, err) = run(&[
        "model", "--r", "700k", "--c", "200p", "--f", "6k", "--model", "65",
    ]);
    assert!(!ok && err.contains("ladder size 1..=64"), "{err}");
    let (ok, _, err) = run(&["model", "--r", "700k", "--c", "200p", "--f", "80k"]);
    assert!(!ok && err.contains("supported"), "{err}");
    let (ok, _, err) = run(&["invert", "--cs", "150p", "--rs", "200k", "--f", "6k"]);
    assert!(!ok && err.contains("lower the frequency"), "{err}");
    assert!(!err.contains("backtrace"), "{err}");
}

#[test]
fn identify_writes_the_reports_and_rejects_bad_data_with_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    let out = tmp.path().join("id");
    let d = ds.to_str().unwrap();
    let (ok, _, err) = run(&["dataset", "--out", d, "--seed", "3", "--meter-lag", "60m"]);
    assert!(ok, "{err}");
    let (ok, stdout, err) = run(&["identify", d, "--out", out.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(stdout.contains("explained by meter_lag"), "{stdout}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(j["effects"][0]["id"], "meter_lag");
    let w = j["effects"][0]["params"]["window_ms"].as_f64().unwrap();
    assert!((w - 60.0).abs() < 1.0, "{w}");
    assert_eq!(j["unexplained"], false);
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| **all** |") && md.contains("residuals.svg"), "{md}");
    assert!(std::fs::metadata(out.join("residuals.svg")).unwrap().len() > 10_000);
    // A malformed row: file, line, column and reason; nothing written.
    let trace = ds.join("trace_20mmps_2000hz.csv");
    let text = std::fs::read_to_string(&trace).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<&str> = lines[7].split(',').collect();
    fields[1] = "1.2.3";
    lines[7] = fields.join(",");
    std::fs::write(&trace, lines.join("\n")).unwrap();
    let bad = tmp.path().join("bad");
    let (ok, _, err) = run(&["identify", d, "--out", bad.to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("trace_20mmps_2000hz.csv:8:"), "{err}");
    assert!(!bad.exists());
    // A missing data set.
    let (ok, _, err) = run(&["identify", tmp.path().join("nothing").to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("nothing"), "{err}");
}

/// A report that cannot be written leaves no reports behind: neither
/// half-written ones nor those of an earlier run.
#[test]
fn identify_writes_all_its_reports_or_none() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let (ok, _, err) = run(&["dataset", "--out", data.to_str().unwrap(), "--seed", "2"]);
    assert!(ok, "{err}");
    let out = tmp.path().join("report");
    let (ok, _, err) = run(&["identify", data.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(ok, "{err}");
    for f in ["report.md", "report.json", "residuals.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // report.json cannot be replaced (a folder stands in its way).
    std::fs::remove_file(out.join("report.json")).unwrap();
    std::fs::create_dir(out.join("report.json")).unwrap();
    let (ok, _, err) = run(&["identify", data.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!ok && err.contains("report.json"), "{err}");
    let left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "report.json")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// `docs/host-tools.md` shows what sizing a sensor prints.
#[test]
fn the_docs_show_what_model_and_invert_print() {
    let model = [
        "model",
        "--r",
        "700k",
        "--c",
        "200p",
        "--f",
        "500,6k",
        "--model",
        "1,30,continuous",
    ];
    let invert = [
        "invert", "--cs", "134.12p", "--rs", "201.1k", "--f", "6k", "--c-hint", "200p",
    ];
    let mut md = String::from("```console\n");
    for args in [&model[..], &invert[..]] {
        let (ok, out, err) = run(args);
        assert!(ok, "{err}");
        md += &format!(
            "$ cargo run -q --release -p host-sim -- {}\n{out}",
            args.join(" ")
        );
        if args[0] == "model" {
            md += "\n";
        }
    }
    md += "```\n";
    figures::check("docs/host-tools.md", "cli-sizing", &md).unwrap();
}

/// The paper's sensor (its tab leads: `lead_resistance` 0.6415) read by a
/// series meter at 2 kHz: `invert` without its leads finds no line (or
/// one far off); with them, its true 205 pF.
#[test]
fn invert_takes_the_tab_leads() {
    let p = skin_sim::sensor::SensorParams::PAPER;
    let z = skin_sim::sensor::Sensor::settled(p).impedance(2000.0);
    let w = std::f64::consts::TAU * 2000.0;
    let (cs, rs) = (format!("{:e}", -1.0 / (w * z.im)), format!("{:e}", z.re));
    let c_true = p.capacitance(0.0) * 1e12;
    let read = |extra: &[&str]| -> Option<f64> {
        let mut args = vec![
            "invert", "--cs", &cs, "--rs", &rs, "--f", "2k", "--c-hint", "205p",
        ];
        args.extend_from_slice(extra);
        let (ok, out, _) = run(&args);
        let c = out.lines().find(|l| l.starts_with("C "))?;
        assert!(c.contains("pF"), "{c}");
        ok.then(|| c.split_whitespace().nth(2)?.parse().ok()).flatten()
    };
    let without = read(&[]);
    let with = read(&["--lead-resistance", "0.6415"]).expect("a line with the leads");
    println!("C true {c_true:.2} pF: without leads {without:?} pF, with {with:.2} pF");
    assert!((with / c_true - 1.0).abs() < 2e-3, "{with} against {c_true}");
    assert!(
        without.is_none_or(|c| (c / c_true - 1.0).abs() > 0.05),
        "{without:?}"
    );
    let (ok, _, err) = run(&[
        "invert",
        "--cs",
        "150p",
        "--rs",
        "200k",
        "--f",
        "6k",
        "--lead-resistance",
        "1.5",
    ]);
    assert!(!ok && err.contains("within 0..1"), "{err}");
}

/// `decode` of a log cut short (no `end` line: a crash, a hang, a
/// recording stopped by hand) writes what it holds, marks it INCOMPLETE
/// and exits with status 3; the whole log exits 0 and takes the mark
/// away.
#[test]
fn a_recording_cut_short_is_decoded_marked_and_not_passed_as_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let mut log = String::from("start array\n");
    for k in 0..60u64 {
        log.push_str(&format!(
            "tone {} 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 1.2 0.0004 0.1 0\n",
            2000 + 4000 * k
        ));
    }
    let (cut, whole) = (tmp.path().join("cut.log"), tmp.path().join("whole.log"));
    std::fs::write(&cut, &log).unwrap();
    std::fs::write(
        &whole,
        format!("{log}stack 100 bytes used, 900 never touched\nend\n"),
    )
    .unwrap();
    let out = tmp.path().join("set");
    let decode = |input: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
            .arg("decode")
            .arg(input)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap()
    };
    let o = decode(&cut);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("incomplete: ") && err.contains("no 'end' line"),
        "{err}"
    );
    let mark = std::fs::read_to_string(out.join("INCOMPLETE")).unwrap();
    assert!(mark.contains("cut.log"), "{mark}");
    assert!(out.join("faults.csv").exists() || out.join("calibration.csv").exists());
    let o = decode(&whole);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !out.join("INCOMPLETE").exists(),
        "the mark of the earlier run taken away"
    );
}

/// `decode` replaces the data set in its folder whole: the files of an
/// earlier recording's channels are gone, files that are not the data
/// set's stay, and no staging folder is left behind.
#[test]
fn a_data_set_written_again_holds_nothing_stale() {
    let tmp = tempfile::tempdir().unwrap();
    let log = |ch: u8| {
        let mut s = String::new();
        for k in 0..60u64 {
            s.push_str(&format!(
                "tone {} {ch} 500 400000 -1600000 2000 200000 -390000 {} 1000000 1.2 0.0004 {} 0\n",
                2000 + 4000 * k,
                205.0 + k as f64 * 0.5,
                k as f64 * 0.2
            ));
        }
        s + "end\n"
    };
    let out = tmp.path().join("set");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let decode = |ch: u8| {
        let path = tmp.path().join(format!("ch{ch}.log"));
        std::fs::write(&path, log(ch)).unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
            .arg("decode")
            .arg(&path)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let mut names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    let first = decode(3);
    assert!(first.iter().any(|n| n.starts_with("trace_ch3_")), "{first:?}");
    let second = decode(4);
    assert!(second.iter().any(|n| n.starts_with("trace_ch4_")), "{second:?}");
    assert!(!second.iter().any(|n| n.contains("ch3")), "stale: {second:?}");
    assert!(second.contains(&"notes.txt".to_string()), "{second:?}");
    assert!(
        !second
            .iter()
            .any(|n| n.starts_with(".dataset-") || n == "INCOMPLETE"),
        "{second:?}"
    );
}

/// Every record of a recording is in the data set or in `faults.csv`
/// with why: a flagged one by its flags' names, one whose tone is not a
/// lossy capacitor (inductive) by that reason.
#[test]
fn no_record_is_left_out_without_a_word() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("r.log");
    // Sensor 2: its second tone inductive (Im Z > 0), flags 0; sensor 5
    // flagged MODEL and UNCERTAIN (384); then the end.
    std::fs::write(
        &log,
        "tone 2000 2 500 400000 -1600000 2000 200000 390000 205.1 1000000 1.2 0.0004 0.1 0\n\
         tone 2000 5 500 400000 -1600000 2000 200000 -390000 205.1 1000000 40 0.0004 0.1 384\n\
         end\n",
    )
    .unwrap();
    let out = tmp.path().join("set");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("decode")
        .arg(&log)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let faults = std::fs::read_to_string(out.join("faults.csv")).unwrap();
    assert!(
        faults.starts_with("time_s,sensor,freq_hz,flags,reason\n"),
        "{faults}"
    );
    assert!(
        faults.contains(",2,2000,0,\"no lumped reading: the tone's impedance is not a lossy capacitor's\""),
        "{faults}"
    );
    // The flagged record's two tones, each with its flags, named.
    assert_eq!(faults.matches(",5,").count(), 2, "{faults}");
    assert!(faults.contains(",5,500,384,\"UNCERTAIN MODEL\""), "{faults}");
}

/// A real recording (no truth, so no ohmmeter): a record whose two tones
/// failed the model check has no line resistance to be modelled with; it
/// goes to `faults.csv` with that reason instead of into a trace with
/// r_line 0, which the reader (rightly) refuses, and the data set decoded
/// is one `residual` reads.
#[test]
fn a_record_without_its_line_is_listed_not_written_as_a_row_nobody_can_read() {
    let tmp = tempfile::tempdir().unwrap();
    let mut log = String::new();
    let tone = |t: u64, ch: u8, c: f64, r: f64, s: f64, flags: u16| {
        // The measured tones of a 210 pF, 700 kΩ line at 500 and 2000 Hz,
        // near enough for a data set.
        format!("tone {t} {ch} 500 260000 -1500000 2000 130000 -360000 {c} {r} 1.2 0.0004 {s} {flags}\n")
    };
    for k in 0..60u64 {
        let t = 2000 + 4000 * k;
        // Channel 3 moves; one record failed the model check (MODEL); one
        // holds an impossible C (3e38 pF, a corrupted record marked
        // valid), one an impossible tone (1e30 Hz).
        let flags = if k == 30 { 256 } else { 0 };
        let c = if k == 40 { 3e38 } else { 210.0 + k as f64 * 0.5 };
        let line = tone(t, 3, c, 700e3, k as f64 * 0.2, flags);
        log.push_str(&if k == 50 {
            line.replacen(" 2000 ", " 1e30 ", 1)
        } else {
            line
        });
        // Channels 4-6 are held at 0, 10 and 20 mm.
        for (ch, s) in [(4u8, 0.0), (5, 10.0), (6, 20.0)] {
            log.push_str(&tone(t, ch, 210.0 * (1.0 + s / 100.0), 700e3, s, 0));
        }
    }
    log.push_str("end\n");
    let path = tmp.path().join("r.log");
    std::fs::write(&path, log).unwrap();
    let set = tmp.path().join("set");
    let run = |args: &[&std::ffi::OsStr]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&[
        "decode".as_ref(),
        path.as_os_str(),
        "--out".as_ref(),
        set.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let faults = std::fs::read_to_string(set.join("faults.csv")).unwrap();
    assert_eq!(
        faults.matches("no line resistance to model it with").count(),
        2,
        "{faults}"
    );
    // The impossible values: both tones of the 3e38 pF record, the 1e30 Hz
    // tone (its 500 Hz tone is a good reading).
    assert_eq!(
        faults.matches("a value outside what any sensor").count(),
        3,
        "{faults}"
    );
    for (f, rows) in [("trace_ch3_500hz.csv", 58), ("trace_ch3_2000hz.csv", 57)] {
        let trace = std::fs::read_to_string(set.join(f)).unwrap();
        let n = trace
            .lines()
            .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
            .count();
        assert_eq!(n, rows, "{f}");
    }
    let o = run(&["residual".as_ref(), set.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A `live` session's folder without its manifest (the session never
/// ended) is said to be incomplete by the readers, marker or not.
#[test]
fn a_session_folder_without_its_manifest_is_said_incomplete() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("records.csv"), "segment,seq\n").unwrap();
    for cmd in ["residual", "identify"] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
            .arg(cmd)
            .arg(tmp.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("without its session.json"), "{cmd}: {err}");
    }
    std::fs::write(tmp.path().join(host_sim::recording::MANIFEST), "{}").unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("residual")
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&o.stderr).contains("incomplete"));
}
