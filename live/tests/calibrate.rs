//! `live calibrate` on a recorded stream: two sensors held at five
//! stretches, their impedances from a fine R-C ladder (not the fit's
//! closed form) behind known leads, contact and cable capacitance; the
//! set stored in a flash image is read back by `live config get`; a bad
//! holds file is refused with its line and column, and nothing stored.

use num_complex::Complex64;
use std::f64::consts::TAU;
mod common;
use common::live;

/// A ladder of 400 elements (series R/n, shunt C/n), open at its far
/// end, behind series `rs` and with `cp` across the meter.
fn ladder(f: f64, r: f64, c: f64, rs: f64, cp: f64) -> Complex64 {
    let n = 400;
    let w = TAU * f;
    let (rn, yn) = (
        Complex64::new(r / n as f64, 0.0),
        Complex64::new(0.0, w * c / n as f64),
    );
    let mut z = yn.inv();
    for _ in 1..n {
        z = (yn + (z + rn).inv()).inv();
    }
    let z = z + rn + rs;
    (z.inv() + Complex64::new(0.0, w * cp)).inv()
}

/// The sensors: (line R at rest Ω, C at rest F, leads as a share of R,
/// contact Ω, cable F).
const SENSORS: [(f64, f64, f64, f64, f64); 2] = [
    (700e3, 210e-12, 0.4, 0.0, 8e-12),
    (1.2e6, 180e-12, 0.0, 15e3, 3e-12),
];

/// Stretches held, mm.
const HOLDS: [f64; 5] = [0.0, 5.0, 10.0, 20.0, 30.0];

/// The two tones of the recorded device, Hz.
const TONES_HZ: [f32; 2] = [1000.0, 2000.0];

/// A record of sensor `sensor` at `t` s with the impedances of `tones`
/// (Hz, Ω) and `flags`; no line.
fn record(t: f64, sensor: usize, tones: [(f32, Complex64); 2], flags: u16) -> link::Record {
    link::Record {
        t_us: (t * 1e6) as u64,
        sensor: sensor as u8,
        tones: tones.map(|(f, z)| link::Tone {
            f_hz: f,
            z_re_ohm: z.re as f32,
            z_im_ohm: z.im as f32,
        }),
        flags,
        ..Default::default()
    }
}

fn stream() -> Vec<u8> {
    stream_with([1.0, 1.0])
}

/// [`stream`] with each sensor stretched `gain` times the stretch held
/// (a skin on a curved body, a glove: sensors stretch differently).
fn stream_with(gain: [f64; 2]) -> Vec<u8> {
    let mut enc = link::Encoder::new();
    let mut out = [0u8; link::MAX_FRAME];
    let mut bytes = vec![];
    let mut seed = 7u64;
    let mut noise = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 3e-4
    };
    for (k, &s) in HOLDS.iter().enumerate() {
        for i in 0..150 {
            let t = k as f64 + 0.004 * i as f64;
            for (sensor, &(r0, c0, lead, rs, cp)) in SENSORS.iter().enumerate() {
                // C grows with stretch; R falls a little, and recovers
                // from the move during the hold.
                let s = s * gain[sensor];
                let c = c0 * (1.0 + s / 100.0);
                let r = r0 * (1.0 - 0.003 * s) * (1.0 + 0.04 * (-(t - k as f64) / 0.3).exp());
                let tones = TONES_HZ.map(|f| {
                    let z =
                        ladder(f as f64, r, c, rs + lead * r, cp) * Complex64::new(1.0 + noise(), noise());
                    (f, z)
                });
                let rec = link::Record {
                    c_farad: c as f32,
                    r_ohm: r as f32,
                    ..record(t, sensor, tones, instrument::faults::Flags::UNCALIBRATED)
                };
                bytes.extend_from_slice(enc.record(&rec, &mut out).unwrap());
            }
        }
    }
    // Then an open fixture (OPEN_AT): each sensor unplugged, its cable
    // left on; the device flags the records open and keeps both tones.
    for i in 0..150 {
        let t = OPEN_AT.0 + 0.004 * i as f64;
        for (sensor, &(_, _, _, _, cp)) in SENSORS.iter().enumerate() {
            let tones = TONES_HZ.map(|f| {
                let y = Complex64::new(0.0, TAU * f as f64 * cp);
                (f, y.inv() * Complex64::new(1.0 + 10.0 * noise(), 10.0 * noise()))
            });
            use instrument::faults::Flags;
            let rec = record(t, sensor, tones, Flags::UNCALIBRATED | Flags::OPEN);
            bytes.extend_from_slice(enc.record(&rec, &mut out).unwrap());
        }
    }
    bytes
}

/// A folder holding the recording (`stream.bin`) and its holds file
/// (`holds.csv`: each stretch from 0.1 to 0.6 s of its second).
fn recording() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("stream.bin"), stream()).unwrap();
    let mut holds = String::from("stretch_mm,from_s,to_s\n");
    for (k, s) in HOLDS.iter().enumerate() {
        holds.push_str(&format!("{s},{},{}\n", k as f64 + 0.1, k as f64 + 0.6));
    }
    std::fs::write(tmp.path().join("holds.csv"), &holds).unwrap();
    tmp
}

/// The open fixture's span in [`stream`], s.
const OPEN_AT: (f64, f64) = (5.0, 5.6);

#[test]
fn a_recorded_calibration_is_fitted_stored_and_read_back() {
    let tmp = recording();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    // Eight sensors in use on a new device: two with records.
    let (code, _, err) = live(&[
        "config",
        "set",
        "--flash",
        &p("flash.bin"),
        "sensor.0.in_use=true",
    ]);
    assert_eq!(code, Some(0), "{err}");
    // The recording fitted into the image, with `more` options.
    let (stream, flash) = (p("stream.bin"), p("flash.bin"));
    let calibrate = |holds: &str, more: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--replay",
            &stream,
            "--holds",
            holds,
            "--flash",
            &flash,
        ];
        args.extend_from_slice(more);
        live(&args)
    };
    let (code, out, err) = calibrate(&p("holds.csv"), &["--report", &p("report.md")]);
    assert_eq!(code, Some(0), "{err}\n{out}");
    assert!(out.contains("stored: generation 2"), "{out}");
    assert!(out.contains("sensor 2 refused: no usable records"), "{out}");
    assert_eq!(
        std::fs::read_to_string(p("report.md")).unwrap().trim(),
        out.lines().skip(1).collect::<Vec<_>>().join("\n").trim()
    );
    let (code, got, _) = live(&["config", "get", "--flash", &p("flash.bin")]);
    assert_eq!(code, Some(0));
    let value = |name: &str| -> f64 {
        let line = got
            .lines()
            .find(|l| l.starts_with(&format!("{name} = ")))
            .unwrap_or_else(|| panic!("{name}: {got}"));
        line.rsplit(" = ").next().unwrap().parse().unwrap()
    };
    for (s, &(_, c0, lead, rs, cp)) in SENSORS.iter().enumerate() {
        assert!(
            got.lines().any(|l| l == format!("sensor.{s}.calibrated = true")),
            "{got}"
        );
        let l = value(&format!("sensor.{s}.lead_ratio"));
        let contact = value(&format!("sensor.{s}.contact_ohm"));
        let para = value(&format!("sensor.{s}.parasitic_farad"));
        let c = value(&format!("sensor.{s}.nominal_c_farad"));
        assert!((l - lead).abs() < 0.01, "sensor {s}: ℓ {l}");
        assert!((contact - rs).abs() < 3e3, "sensor {s}: contact {contact}");
        assert!((para - cp).abs() < 0.2e-12, "sensor {s}: C_p {para}");
        assert!((c / c0 - 1.0).abs() < 5e-4, "sensor {s}: C {c}");
    }
    assert!(got.lines().any(|l| l == "sensor.2.calibrated = false"), "{got}");

    // A holds file with a bad number: refused where, nothing stored.
    let before = std::fs::read(p("flash.bin")).unwrap();
    std::fs::write(p("bad.csv"), "stretch_mm,from_s,to_s\n0,0.1,0.6\n5,1.1,x\n").unwrap();
    let (code, _, err) = calibrate(&p("bad.csv"), &[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("bad.csv:3:7: 'x' is not a finite number"), "{err}");
    assert_eq!(std::fs::read(p("flash.bin")).unwrap(), before);
    // --dry-run stores nothing.
    let (code, out, err) = calibrate(&p("holds.csv"), &["--dry-run"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(!out.contains("stored: generation"), "{out}");
    assert_eq!(std::fs::read(p("flash.bin")).unwrap(), before);
}

/// `--verify` on a recording of a calibrated device held at the same
/// stretches: each sensor's stretch against the stretch held; a sensor
/// whose stretch the device did not vouch for is named so.
#[test]
fn a_device_measured_again_is_judged_by_its_stretch_at_each_hold() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    let mut enc = link::Encoder::new();
    let mut out = [0u8; link::MAX_FRAME];
    let mut bytes = vec![];
    let mut holds = String::from("stretch_mm,from_s,to_s\n");
    for (k, s) in HOLDS.iter().enumerate() {
        holds.push_str(&format!("{s},{},{}\n", k as f64 + 0.1, k as f64 + 0.6));
        for i in 0..150 {
            let t = k as f64 + 0.004 * i as f64;
            // Sensor 0 reads 0.02 mm long; sensor 1 1 % long; sensor 2
            // is not calibrated.
            for (sensor, stretch, flags) in [
                (0u8, s + 0.02, 0),
                (1, s * 1.01, 0),
                (2, 0.0, instrument::faults::Flags::UNCALIBRATED),
            ] {
                let rec = link::Record {
                    t_us: (t * 1e6) as u64,
                    sensor,
                    stretch_mm: stretch as f32,
                    c_farad: 200e-12,
                    flags,
                    ..Default::default()
                };
                bytes.extend_from_slice(enc.record(&rec, &mut out).unwrap());
            }
        }
    }
    std::fs::write(p("again.bin"), bytes).unwrap();
    std::fs::write(p("holds.csv"), holds).unwrap();
    let (code, out, err) = live(&[
        "calibrate",
        "--verify",
        "--replay",
        &p("again.bin"),
        "--holds",
        &p("holds.csv"),
        "--flash",
        &p("unused.bin"),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let row = |s: u8| {
        out.lines()
            .find(|l| l.starts_with(&format!("| {s} |")))
            .unwrap_or_default()
    };
    assert!(row(0).starts_with("| 0 | 0.020 mm | +0.020 mm at "), "{out}");
    let rms1 = (HOLDS.iter().map(|s| (0.01 * s) * (0.01 * s)).sum::<f64>() / 5.0).sqrt();
    assert!(
        row(1).starts_with(&format!("| 1 | {rms1:.3} mm | +0.300 mm at 30 mm |")),
        "{out}"
    );
    assert!(
        row(2).starts_with("| 2 | not vouched for at every hold |  | 0 of "),
        "{out}"
    );
    // Every record in the holds counted, all vouched for on sensor 0.
    let counts = row(0).split('|').nth(4).unwrap().trim().to_string();
    let (vouched, of) = counts.split_once(" of ").unwrap();
    assert_eq!(vouched, of, "{out}");
    assert!(!tmp.path().join("unused.bin").exists(), "nothing stored");
}

/// An open fixture measures each cable's capacitance: with `--open-at`
/// the report gives it alone (within 1 % here, where the records' noise
/// is 10× the holds') and the fit's C_p, fitted with it, is as close
/// and no less certain; a span with no records is refused by name.
#[test]
fn an_open_fixture_measures_the_cables() {
    let tmp = recording();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    let run = |more: &[&str]| {
        let (stream, holds, flash) = (p("stream.bin"), p("holds.csv"), p("flash.bin"));
        let mut args = vec![
            "calibrate",
            "--replay",
            &stream,
            "--holds",
            &holds,
            "--flash",
            &flash,
            "--dry-run",
        ];
        args.extend_from_slice(more);
        live(&args)
    };
    // Per sensor: the parasitic column (value, σ) and the open column.
    type PlusMinus = (f64, f64);
    let table = |out: &str| -> Vec<(PlusMinus, Option<PlusMinus>)> {
        let pm = |c: &str| {
            let mut v = c.split('±').map(|x| x.trim().parse::<f64>().unwrap());
            (v.next().unwrap(), v.next().unwrap())
        };
        out.lines()
            .filter(|l| l.starts_with("| 0 |") || l.starts_with("| 1 |"))
            .map(|l| {
                // | sensor | records | ℓ | contact | parasitic | tan δ | C rest
                // | R rest | χ²/dof | C off | stretch | outcome | open |
                let c: Vec<&str> = l.split('|').map(str::trim).collect();
                (pm(c[5]), (c.len() > 14).then(|| pm(c[13])))
            })
            .collect()
    };
    let (code, without, err) = run(&[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(!without.contains("open fixture"), "{without}");
    let at = format!("{},{}", OPEN_AT.0, OPEN_AT.1);
    let (code, with, err) = run(&["--open-at", &at]);
    assert_eq!(code, Some(0), "{err}");
    assert!(with.contains("With an open fixture"), "{with}");
    let (a, b) = (table(&without), table(&with));
    assert_eq!((a.len(), b.len()), (2, 2), "{without}\n{with}");
    for (s, &(_, _, _, _, cp)) in SENSORS.iter().enumerate() {
        let cp = cp * 1e12;
        let (alone, sigma) = b[s].1.expect("an open column");
        assert!(
            (alone - cp).abs() < 0.01 * cp && sigma < 0.01 * cp,
            "sensor {s}: {alone} ± {sigma} pF"
        );
        let ((fit, fit_sigma), (old, old_sigma)) = (b[s].0, a[s].0);
        assert!(
            (fit - cp).abs() <= (old - cp).abs() + 0.005,
            "sensor {s}: {fit} against {old} pF"
        );
        assert!(
            fit_sigma <= old_sigma,
            "sensor {s}: ± {fit_sigma} against ± {old_sigma} pF"
        );
    }
    // A span with no records: refused for every sensor, so nothing fits.
    let (code, _, err) = run(&["--open-at", "20,21"]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("no usable records in the open fixture's span (20.00–21.00 s)"),
        "{err}"
    );
    let (code, _, err) = run(&["--open-at", "3,1"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("--open-at"), "{err}");
}

/// Each sensor held at its own stretches (named through the skin's
/// groups): each gets the table of its own stretches, not the other's.
#[test]
fn each_sensor_is_calibrated_at_its_own_stretches() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |n: &str| tmp.path().join(n).to_str().unwrap().to_string();
    // Sensor 1 stretches half as much as sensor 0.
    std::fs::write(p("stream.bin"), stream_with([1.0, 0.5])).unwrap();
    std::fs::write(
        p("skin.toml"),
        "[skin]\nname = \"arm\"\n[[sensor]]\nname = \"elbow\"\nindex = 0\ngroup = \"outer\"\nplace = [0, 0]\n\
         [[sensor]]\nname = \"forearm\"\nindex = 1\ngroup = \"inner\"\nplace = [0, 10]\n",
    )
    .unwrap();
    let mut holds = String::from("sensor,stretch_mm,from_s,to_s\n");
    for (k, s) in HOLDS.iter().enumerate() {
        let (a, b) = (k as f64 + 0.1, k as f64 + 0.6);
        holds.push_str(&format!("outer,{s},{a},{b}\nforearm,{},{a},{b}\n", s * 0.5));
    }
    std::fs::write(p("holds.csv"), &holds).unwrap();
    let (code, out, err) = live(&[
        "calibrate",
        "--replay",
        &p("stream.bin"),
        "--holds",
        &p("holds.csv"),
        "--skin",
        &p("skin.toml"),
        "--flash",
        &p("flash.bin"),
    ]);
    assert_eq!(code, Some(0), "{err}\n{out}");
    assert!(out.contains("each sensor at its own stretches"), "{out}");
    let (code, got, _) = live(&["config", "get", "--flash", &p("flash.bin")]);
    assert_eq!(code, Some(0));
    // Each table's last point: the sensor's own largest stretch, at the
    // C it had there.
    for (s, top) in [(0usize, 30.0), (1, 15.0)] {
        let line = got
            .lines()
            .find(|l| l.starts_with(&format!("sensor.{s}.table = ")))
            .unwrap();
        let last = line.rsplit(' ').next().unwrap();
        let (c, mm) = last.split_once(':').unwrap();
        let (c, mm): (f64, f64) = (c.parse().unwrap(), mm.parse().unwrap());
        assert!((mm - top).abs() < 1e-3, "sensor {s}: {line}");
        let c0 = SENSORS[s].1;
        assert!(
            (c / (c0 * (1.0 + top / 100.0)) - 1.0).abs() < 1e-3,
            "sensor {s}: {line}"
        );
    }
    // A name the holds give that the skin does not have: refused, where.
    std::fs::write(p("bad.csv"), "sensor,stretch_mm,from_s,to_s\nwrist,0,0.1,0.6\n").unwrap();
    let (code, _, err) = live(&[
        "calibrate",
        "--replay",
        &p("stream.bin"),
        "--holds",
        &p("bad.csv"),
        "--skin",
        &p("skin.toml"),
        "--flash",
        &p("flash.bin"),
        "--dry-run",
    ]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("bad.csv:2:1: 'wrist' is no sensor's index, name or group in skin 'arm'"),
        "{err}"
    );
}
