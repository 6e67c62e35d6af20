//! What the tests of `live` share: streams as a device sends them, and
//! the binary run as a user runs it.

use link::{Body, Encoder, End, Record, Start, Tone, MAX_FRAME};

/// A stream of `n` single-tone records from two sensors, with its end
/// frame or not, of wire version `version`.
#[allow(dead_code)]
pub fn stream(n: u32, end: bool, version: u16) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = enc
        .frame(
            Body::Start(Start {
                version,
                firmware: Start::firmware_field("test"),
                sensors: 2,
                sample_rate_hz: 200_000,
                ..Start::default()
            }),
            &mut out,
        )
        .unwrap()
        .to_vec();
    for k in 0..n {
        let rec = Record {
            t_us: 2560 + 5440 * u64::from(k),
            sensor: (k % 2) as u8,
            tones: [
                Tone {
                    f_hz: 1953.125,
                    z_re_ohm: 2.3e5,
                    z_im_ohm: -4.0e5,
                },
                Tone::default(),
            ],
            c_farad: 205e-12,
            r_ohm: 7e5,
            stretch_mm: 0.1 * k as f32,
            chosen_hz: 1953.125,
            flags: u16::from(k == 3) * 16,
            ..Record::default()
        };
        bytes.extend_from_slice(enc.frame(Body::Record(rec), &mut out).unwrap());
    }
    if end {
        let e = End {
            records: n,
            dropped: 0,
        };
        bytes.extend_from_slice(enc.frame(Body::End(e), &mut out).unwrap());
    }
    bytes
}

/// Run the `live` binary with `args`: its exit code, stdout and stderr.
#[allow(dead_code)]
pub fn live(args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_live"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A Python that imports `modules` (comma separated): `python3` on PATH,
/// else the system's (where PATH leads to another, such as pyenv's,
/// without them).
#[allow(dead_code)]
pub fn python_with(modules: &str) -> &'static str {
    ["python3", "/usr/bin/python3"]
        .into_iter()
        .find(|py| {
            std::process::Command::new(py)
                .args(["-c", &format!("import {modules}")])
                .output()
                .is_ok_and(|o| o.status.success())
        })
        .unwrap_or("python3")
}
