//! The host's end of the record link ([`link`]): a session reads a
//! stream's bytes as they arrive, keeps them, turns its frames into
//! records and writes them down as they come: `records.csv`, and the data
//! set ([`host_sim::recording::DatasetWriter`], the format of
//! `docs/data-format.md`), every file appended to and flushed at least
//! once a second. What a session holds in memory does not grow with its
//! length: the records not yet written, and a few counts per sensor.
//!
//! A session writes nothing until its stream's start frame has arrived,
//! and never over another session's files: a folder that holds files
//! already is refused unless the user asks to replace them
//! ([`Earlier::Overwrite`]). From its first write to its clean end the
//! folder carries an `INCOMPLETE` file; a session that ends writes its
//! manifest (`session.json`: its segments, counts and how it ended), and
//! takes the marker away only when the stream ended with its end frame.
//! A folder without a manifest, or with the marker, is incomplete: the
//! session was killed, crashed, or its disk filled, and its files hold
//! every record up to its last flush.

pub mod boards;
pub mod calibrate;
pub mod clock;
pub mod config;
pub mod dashboard;
pub mod devtools;
mod follow;
mod interpolated;
mod manifest;
pub mod markers;
mod recorder;
mod records_csv;
pub mod self_test;
mod session;
pub mod skin;
mod skin_records;
pub mod skin_view;
mod summary;
pub mod synthetic;

pub use follow::{follow, replay, replay_from, Arrivals, Stopped};
pub use interpolated::INTERPOLATED_CSV;
pub use manifest::MANIFEST;
pub use markers::MARKERS_CSV;
pub use recorder::{Command, Folders, Sink};
pub use records_csv::RECORDS_CSV;
pub use session::{
    Arrived, Earlier, Finished, Outcome, Segment, Session, ARRIVALS_CSV, BEFORE_START_MAX, REFUSED_SHOWN,
};
pub use summary::{Cpu, SetAside, Summary};

/// The raw stream, every byte as it arrived from the start frame's on.
pub const STREAM_BIN: &str = "stream.bin";
/// The marker of a session that did not end cleanly: written when the
/// session starts writing, taken away at an end with the end frame.
pub const INCOMPLETE: &str = "INCOMPLETE";
