//! Markers: the user's notes on a recording ("grasp starts", "stage at
//! 20 mm"), from `live`'s standard input or the dashboard, written to
//! `markers.csv` with both clocks: the host's UTC when it was made, and
//! the device's time the segment's clock fit puts there.

use anyhow::Result;

/// The markers file.
pub const MARKERS_CSV: &str = "markers.csv";

/// The header of [`MARKERS_CSV`].
pub(crate) const HEADER: &str = "host_utc_us,segment,device_t_us,source,text\n";

/// The most characters a marker's text keeps.
pub const TEXT_MAX: usize = 500;

/// A marker as written.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Marker {
    /// The host's UTC when it was made, µs since the Unix epoch.
    pub host_utc_us: i64,
    /// The device's run it falls in (as `records.csv`'s `segment`).
    pub segment: u32,
    /// The device's time there, µs since its start (none before its
    /// clock could be fitted: two reads of records).
    pub device_t_us: Option<i64>,
    /// Where it came from: `stdin`, `dashboard`.
    pub source: String,
    /// The user's text, on one line.
    pub text: String,
}

impl Marker {
    /// Its line of [`MARKERS_CSV`], appended to `out` (the text quoted
    /// where it needs to be).
    pub(crate) fn line(&self, out: &mut Vec<u8>) -> Result<()> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(out);
        w.serialize(self)?;
        w.flush()?;
        Ok(())
    }
}

/// A marker asked for while a session runs, and where to say how it
/// went (the dashboard's request waits for it).
#[derive(Debug)]
pub struct Mark {
    /// The host's UTC when it was asked, µs since the Unix epoch.
    pub host_utc_us: i64,
    /// Where: `stdin`, `dashboard`, a client's name.
    pub source: String,
    /// The text, [`clean`]ed.
    pub text: String,
    /// Told the marker written, or why not.
    pub reply: Option<tokio::sync::oneshot::Sender<Result<Marker, String>>>,
}

impl Mark {
    /// A marker of `text` from `source`, asked now.
    pub fn now(source: &str, text: &str) -> Self {
        Self {
            host_utc_us: chrono::Utc::now().timestamp_micros(),
            source: source.to_string(),
            text: clean(text),
            reply: None,
        }
    }
}

/// `text` as a marker keeps it: one line (line breaks and controls as
/// spaces), trimmed, at most [`TEXT_MAX`] characters.
pub fn clean(text: &str) -> String {
    let one: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(TEXT_MAX)
        .collect();
    one.trim().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_marker_with_commas_and_quotes_reads_back_as_written() {
        let m = Marker {
            host_utc_us: 1_796_300_000_123_456,
            segment: 2,
            device_t_us: None,
            source: "stdin".into(),
            text: clean("grasp, \"firm\"\r\n then let go"),
        };
        assert_eq!(m.text, "grasp, \"firm\"   then let go");
        let mut out = HEADER.as_bytes().to_vec();
        m.line(&mut out).unwrap();
        let mut r = csv::Reader::from_reader(out.as_slice());
        let row = r.records().next().unwrap().unwrap();
        assert_eq!(&row[0], "1796300000123456");
        assert_eq!(&row[2], "");
        assert_eq!(&row[4], m.text);
    }
}
