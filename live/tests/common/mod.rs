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
            stretch_mm: 0.1 * k as f32,
            flags: u16::from(k == 3) * 16,
            ..single_tone(2560 + 5440 * u64::from(k), (k % 2) as u8)
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

/// A multiplexed device's record of `sensor` at `t_us`: one tone, C and
/// R, no flags.
#[allow(dead_code)]
pub fn single_tone(t_us: u64, sensor: u8) -> Record {
    Record {
        t_us,
        sensor,
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
        chosen_hz: 1953.125,
        ..Record::default()
    }
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

/// `live --tcp` reading a device the test plays, its dashboard served:
/// the process, its stdout past the dashboard's address, the
/// dashboard's `HOST:PORT`, and the device's end of the socket.
#[allow(dead_code)]
pub struct Served {
    /// The `live` process.
    pub child: std::process::Child,
    /// Its stdout, after the first line.
    pub said: std::io::BufReader<std::process::ChildStdout>,
    /// The dashboard's address, `HOST:PORT`.
    pub page: String,
    /// The device's end of the link.
    pub sock: std::net::TcpStream,
}

#[allow(dead_code)]
impl Served {
    /// The dashboard's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.page)
    }

    /// Wait for `live` to end: its exit status, the rest of its stdout
    /// and its stderr.
    pub fn wait(mut self) -> (std::process::ExitStatus, String, String) {
        use std::io::Read;
        drop(self.sock);
        let mut out = String::new();
        self.said.read_to_string(&mut out).unwrap();
        let mut err = String::new();
        if let Some(mut e) = self.child.stderr.take() {
            e.read_to_string(&mut err).unwrap();
        }
        (self.child.wait().unwrap(), out, err)
    }
}

/// `live --tcp ADDR --serve 127.0.0.1:0 ARGS…` on a socket this test
/// plays the device on, with `stdin`.
#[allow(dead_code)]
pub fn serve_tcp(args: &[&str], stdin: std::process::Stdio) -> Served {
    use std::io::BufRead;
    use std::process::Stdio;
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_live"))
        .args(["--tcp", &addr, "--serve", "127.0.0.1:0"])
        .args(args)
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut said = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    said.read_line(&mut first).unwrap();
    let page = first
        .trim()
        .strip_prefix("dashboard: http://")
        .unwrap_or_else(|| panic!("no dashboard address: {first:?}"))
        .trim_end_matches('/')
        .to_string();
    let (sock, _) = listener.accept().unwrap();
    Served {
        child,
        said,
        page,
        sock,
    }
}

/// POST `body` (of `content_type`) to `path` of the dashboard at `page`
/// (`HOST:PORT`): the status code and the body of the answer.
#[allow(dead_code)]
pub fn post(page: &str, path: &str, content_type: &str, body: &str) -> (u16, String) {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(page).unwrap();
    write!(
        s,
        "POST {path} HTTP/1.1\r\nHost: {page}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut answer = String::new();
    s.read_to_string(&mut answer).unwrap();
    let code = answer.split(' ').nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
    (
        code,
        answer.split_once("\r\n\r\n").map_or("", |(_, b)| b).to_string(),
    )
}

/// What the repository's Python reader (`python/`, with pandas) prints
/// running `script` on `arg`; the test fails with its errors where it
/// fails.
#[allow(dead_code)]
pub fn python_says(script: &str, arg: &std::path::Path) -> String {
    let python = format!("{}/../python", env!("CARGO_MANIFEST_DIR"));
    let run = std::process::Command::new(python_with("pandas"))
        .env("PYTHONPATH", &python)
        .arg("-c")
        .arg(script)
        .arg(arg)
        .output()
        .expect("python3 with pandas (`cargo xtask setup` installs it)");
    let said = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(
        run.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    said
}
