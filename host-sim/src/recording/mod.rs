//! Firmware recordings: the `rec`, `tone` and `truth` lines of
//! [`instrument::wire`] (from a decoded log, or raw defmt bytes with the
//! firmware's ELF) turned into a data set of the project's format
//! (`docs/data-format.md`) that `residual` and `identify` read. An array
//! recording's `tone` record becomes a record per tone
//! ([`LoggedToneRecord::per_tone`]).
//!
//! A data set from a recording:
//! * `trace_ch{C}_{F}hz.csv`: one file per moving channel and excitation
//!   frequency (a trace holds one frequency; the firmware's policy changes
//!   it), every record with a lumped measurement: `time_s` (the block's
//!   middle), `stretch_mm`, `freq_hz`, `cs_pf`, `rs_ohm`, the firmware's own
//!   `c_line_pf`, `r_line_ohm` and `flags`; with a truth line (QEMU), the
//!   rig's view too: the true stretch and the end-to-end electrode
//!   resistances `r_top_ohm`, `r_bottom_ohm`, and `*_true` columns.
//! * `calibration.csv`: one point per static channel (stretch spread below
//!   [`STATIC_SPREAD_MM`]), the mean of its valid records at the frequency
//!   it was read at most.
//! * `fragment_ch{C}_{F}hz.csv`: a run too short to be modelled as a trace
//!   (fewer than [`crate::model::prepared::MIN_TRACE_ROWS`] records, such as the one start-up block
//!   at the lowest frequency), same columns: kept, but not a trace.
//! * `faults.csv`: every record flagged invalid, with its flags.
//! * `dataset.json`: what the columns hold, each trace's sensor,
//!   frequency, segment and rows, and what was left out and why (the CSV
//!   files hold no comments: any CSV reader takes them as they are).
//!
//! A value a record lacks is an empty field: the line's `c_line_pf` and
//! `r_line_ohm` of a record the model check failed (it keeps its flag,
//! [`Flags::MODEL`], and its lumped reading) or that has no line.
//!
//! Without truth lines (a board) the stretch is the firmware's calibrated
//! one and the resistance its line estimate `r_line_ohm`: the analyses say
//! so ([`crate::dataset::Table::resistance`]).
//!
//! Reading is the module `decode` (log lines, raw defmt, the wire format's records
//! and truth lines paired), writing the modules `writer` (a data set
//! appended to as records arrive) and `write` (a whole recording's, put
//! in place of the last).

mod decode;
mod write;
mod writer;

pub use decode::{decode_defmt, log_lines, parse, parse_tones, read, read_recording, END};
pub use write::{is_dataset_file, unusable, write_dataset, Written, DATASET_JSON, INCOMPLETE, MANIFEST};
pub use writer::{DatasetWriter, LineFile};

use instrument::faults::Flags;

/// A channel whose stretch moves less than this (mm) is static: a
/// calibration point.
pub const STATIC_SPREAD_MM: f64 = 0.5;

/// The simulated truth of one block (QEMU), in the units of the data sets.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockTruth {
    /// True line capacitance, pF.
    pub c_pf: f64,
    /// True line resistance, Ω.
    pub r_ohm: f64,
    /// True stretch, mm.
    pub stretch_mm: f64,
    /// End-to-end top electrode resistance, as the rig's ohmmeter reads it
    /// through the tabs, Ω.
    pub r_top_ohm: f64,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom_ohm: f64,
}

impl BlockTruth {
    /// What a series-R-C meter at `f_hz` reads on the true sensor, pF:
    /// its line (`r_ohm`, `c_pf`) through the tab leads and contacts, the
    /// part of the end-to-end resistances outside the line
    /// (`r_top_ohm + r_bottom_ohm − r_ohm`, in series at the read end).
    pub fn series_meter_pf(&self, f_hz: f64) -> Option<f64> {
        let w = std::f64::consts::TAU * f_hz;
        let g = num_complex::Complex64::new(0.0, w * self.r_ohm * self.c_pf * 1e-12).sqrt();
        if g.norm().is_nan() || g.norm() <= 0.0 {
            return None;
        }
        // Open-ended R-C line: Z = R·coth(γ)/γ, γ = √(jωRC).
        let z = self.r_ohm * (g.cosh() / g.sinh()) / g
            + (self.r_top_ohm + self.r_bottom_ohm - self.r_ohm).max(0.0);
        (z.im < 0.0).then(|| -1e12 / (w * z.im))
    }
}

/// One record, with the truth of its block when the recording has one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoggedRecord {
    /// Middle of the block, s since start.
    pub t_s: f64,
    /// Sensor.
    pub sensor: u8,
    /// Excitation frequency, Hz.
    pub freq_hz: f64,
    /// Lumped Cs, pF (0: not measured).
    pub cs_pf: f64,
    /// Lumped Rs, Ω.
    pub rs_ohm: f64,
    /// Line-corrected C, pF (0 or NaN: no value).
    pub c_pf: f64,
    /// Line-corrected R (both electrodes), Ω (0 or NaN: no value).
    pub r_ohm: f64,
    /// Stretch from the firmware's calibration, mm.
    pub stretch_mm: f64,
    /// Flags.
    pub flags: Flags,
    /// The simulated truth of the same block (QEMU only).
    pub truth: Option<BlockTruth>,
}

impl LoggedRecord {
    /// True if C can be trusted.
    pub fn valid(&self) -> bool {
        self.flags.valid()
    }

    /// The record carries a lumped measurement (not open, shorted,
    /// settling or clipped).
    pub fn measured(&self) -> bool {
        self.cs_pf > 0.0
            && !(self.flags.has(Flags::OPEN)
                || self.flags.has(Flags::SHORTED)
                || self.flags.has(Flags::SETTLING)
                || self.flags.has(Flags::CLIPPED))
    }

    /// The record as a data set's row holds it: one that failed the
    /// model check ([`Flags::MODEL`]: the block's two tones disagree on
    /// the line) still carries a good lumped reading, which is what
    /// `identify` looks at to find what the line lacks: it keeps its
    /// flags, and the line the check could not vouch for has no value
    /// (C and R NaN, written as empty fields). Any other record is as it
    /// was.
    pub fn as_row(&self) -> Self {
        if !self.flags.has(Flags::MODEL) {
            return *self;
        }
        Self {
            c_pf: f64::NAN,
            r_ohm: f64::NAN,
            ..*self
        }
    }

    /// True if its lumped reading (Cs, Rs) can be trusted: valid, or
    /// flagged only by the model check, which judges the line.
    pub fn lumped_valid(&self) -> bool {
        Flags(self.flags.0 & !Flags::MODEL).valid()
    }

    /// The stretch the rig saw (truth) or else the firmware's, mm.
    pub fn stretch(&self) -> f64 {
        self.truth.map_or(self.stretch_mm, |t| t.stretch_mm)
    }
}

/// One array record ([`instrument::tones::ToneRecord`]) with the truth of
/// its block, if the recording has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoggedToneRecord {
    /// The record as the firmware wrote it.
    pub rec: instrument::tones::ToneRecord,
    /// The rig's view of its sensor during the block.
    pub truth: Option<BlockTruth>,
}

impl LoggedToneRecord {
    /// Time of the block's middle, s.
    pub fn t_s(&self) -> f64 {
        self.rec.t_us as f64 * 1e-6
    }

    /// Relative error of C against the truth, if both are there.
    pub fn c_error(&self) -> Option<f64> {
        let t = self.truth?;
        (self.rec.c_farad > 0.0).then(|| self.rec.c_farad as f64 * 1e12 / t.c_pf - 1.0)
    }

    /// The record as one single-tone record per tone, for the data sets
    /// (a trace per sensor and frequency): each with its tone's lumped
    /// Cs–Rs (0 when its impedance was not measured or is not a lossy
    /// capacitor) and the joint line, flags and truth of the record.
    ///
    /// A record that failed the model check ([`Flags::MODEL`]) keeps its
    /// flags and its two lumped readings, without a line
    /// ([`LoggedRecord::as_row`]).
    pub fn per_tone(&self) -> [LoggedRecord; 2] {
        let r = &self.rec;
        core::array::from_fn(|k| {
            let lumped = dsp_core::lumped::SeriesRc::from_impedance(r.z[k], r.f_hz[k]).ok();
            LoggedRecord {
                t_s: self.t_s(),
                sensor: r.sensor,
                freq_hz: r.f_hz[k] as f64,
                cs_pf: lumped.map_or(0.0, |m| m.cs_farad as f64 * 1e12),
                rs_ohm: lumped.map_or(0.0, |m| m.rs_ohm as f64),
                c_pf: r.c_farad as f64 * 1e12,
                r_ohm: r.r_ohm as f64,
                stretch_mm: r.stretch_mm as f64,
                flags: r.flags,
                truth: self.truth,
            }
            .as_row()
        })
    }
}

/// Which channels a recording's data set uses.
#[derive(Clone, Debug, Default)]
pub struct Roles {
    /// Channels whose records become traces (None: the moving ones).
    pub traces: Option<Vec<u8>>,
    /// Channels whose records become calibration points (None: the
    /// static ones).
    pub statics: Option<Vec<u8>>,
}

#[cfg(test)]
mod tests {

    #[test]
    fn an_array_recording_reads_as_a_record_per_tone() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("array.log");
        // Sensor 3: a clean record, then one the model check flagged.
        std::fs::write(
            &log,
            "start array\n\
             truth 2000 3 205 1000000 0 1300000 1300000\n\
             tone 2000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 1.2 0.0004 0.1 0\n\
             12:00:01 INFO tone 6000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 40 0.0004 0.1 256\n",
        )
        .unwrap();
        let recs = read(&log, None).unwrap();
        assert_eq!(recs.len(), 4);
        assert_eq!(
            recs.iter().map(|r| r.freq_hz).collect::<Vec<_>>(),
            [500.0, 2000.0, 500.0, 2000.0]
        );
        // Each tone's lumped reading from its own impedance.
        let cs = -1e12 / (std::f64::consts::TAU * 2000.0 * -390000.0);
        assert!((recs[1].cs_pf - cs).abs() < 1e-3 * cs && recs[1].rs_ohm == 200000.0);
        assert!(recs[0].truth.is_some() && recs[2].truth.is_none());
        assert!((recs[0].c_pf - 205.1).abs() < 1e-3 && recs[0].valid());
        // The flagged record keeps its flag and its lumped readings,
        // without a line.
        assert!(!recs[2].valid() && recs[2].lumped_valid());
        assert!(recs[2].c_pf.is_nan() && recs[2].cs_pf > 0.0);
        // A `rec` line among them says what is wrong, with its line.
        std::fs::write(
            &log,
            "tone 2000 3 500 400000 -1600000 2000 200000 -390000 205.1 1000000 1.2 0.0004 0.1 0\nrec 1 2 3 4 5 6 7 8 9\n",
        )
        .unwrap();
        let e = read(&log, None).unwrap_err().to_string();
        assert!(e.contains(":2: a single-tone record"), "{e}");
    }
    use super::*;

    fn lines(s: &str) -> Vec<(usize, String)> {
        log_lines(s)
    }

    /// The series meter on the truth: the open line alone against
    /// dsp-core's line model (f32); tab leads are a pure series
    /// resistance, which a series meter's Cs does not see.
    #[test]
    fn series_meter_on_the_truth_is_the_line_through_its_leads() {
        use dsp_core::lumped::SeriesRc;
        use dsp_core::tline::LineModel;
        for (r, c, f) in [
            (712e3, 210.0, 585.9375),
            (712e3, 210.0, 5859.375),
            (2.8e6, 230.0, 1953.125),
        ] {
            let t = BlockTruth {
                c_pf: c,
                r_ohm: r,
                r_top_ohm: r / 2.0,
                r_bottom_ohm: r / 2.0,
                ..BlockTruth::default()
            };
            let z = LineModel::Continuous
                .impedance(r as f32, (c * 1e-12) as f32, f as f32)
                .unwrap();
            let cs = SeriesRc::from_impedance(z, f as f32).unwrap().cs_farad as f64 * 1e12;
            let got = t.series_meter_pf(f).unwrap();
            assert!((got - cs).abs() < 1e-4 * c, "{got} vs {cs}");
            // Leads of 1.8× the line: in series, the imaginary part (and
            // so Cs) is the line's.
            let leads = BlockTruth {
                r_top_ohm: 1.4 * r,
                r_bottom_ohm: 1.4 * r,
                ..t
            };
            assert!((leads.series_meter_pf(f).unwrap() - got).abs() < 1e-9 * c);
        }
        assert_eq!(BlockTruth::default().series_meter_pf(1e3), None);
    }

    #[test]
    fn parses_pairs_and_splits_by_channel_and_frequency() {
        let log = "start 8 channels\n\
             truth 2880 0 210.0 712000 0.0 350000 362000\n\
             rec 2880 0 585.9375 0 0 0 0 0 16\n\
             truth 8320 1 214.2 712000 2.0 350000 362000\n\
             rec 8320 1 585.9375 213.3 240000 214.21 711000 2.01 0\n\
             12:00:01 INFO truth 13760 1 214.2 712000 4.0 350000 362000\n\
             12:00:01 INFO rec 13760 1 1953.125 200.1 230000 214.25 712500 4.02 0\n\
             truth 19200 2 214.2 712000 0.0 350000 362000\n\
             rec 19200 2 585.9375 0 0 0 0 0 2\n";
        let recs = parse("log", &lines(log)).unwrap();
        assert_eq!(recs.len(), 4);
        assert!((recs[1].truth.unwrap().c_pf - 214.2).abs() < 1e-4);
        assert!((recs[1].t_s - 8.32e-3).abs() < 1e-12);
        assert!(recs[1].valid() && recs[2].valid() && !recs[3].valid() && !recs[0].valid());
        // A held C (flag 32) is no new reading: not valid.
        assert!(!Flags(Flags::HELD).valid());
        let dir = tempfile::tempdir().unwrap();
        let w = write_dataset(dir.path(), &recs, &Roles::default()).unwrap();
        let names: Vec<String> = w
            .fragments
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        // Channel 1 moves (one record at each of two frequencies: runs too
        // short for a trace, kept as fragments); channel 0 (settling only)
        // and channel 2 (open) have no valid record: channel 0 is no
        // calibration point, and the open one is listed as a fault.
        assert!(w.traces.is_empty() && w.rows == 0);
        assert_eq!(names, ["fragment_ch1_586hz.csv", "fragment_ch1_1953hz.csv"]);
        let text = std::fs::read_to_string(&w.fragments[0]).unwrap();
        let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
        assert_eq!(
            (row[0], row[4], row[5], row[7]),
            ("0.008320", "585.9375", "213.3000", "214.2100")
        );
        let faults = std::fs::read_to_string(dir.path().join("faults.csv")).unwrap();
        assert_eq!(faults.lines().count(), 3, "{faults}");
        assert_eq!(w.faults, 2);
    }

    /// A board's log without truth: channel 0 moves, channels 1-3 are
    /// held at 0, 10, 20 mm; channel ch's records carry `flags(ch)`.
    fn board_log(flags: impl Fn(u64) -> u32) -> String {
        let mut log = String::new();
        for k in 0..40u64 {
            for ch in 0..4u64 {
                let t = (k * 4 + ch) * 5440 + 2880;
                let s = if ch == 0 {
                    0.5 * k as f64
                } else {
                    10.0 * (ch - 1) as f64
                };
                let c = 210.0 * (1.0 + s / 100.0);
                log += &format!(
                    "rec {t} {ch} 1953.125 {:.3} 90000 {c:.3} 712000 {s:.3} {}\n",
                    c - 2.0,
                    flags(ch)
                );
            }
        }
        log
    }

    #[test]
    fn a_board_recording_without_truth_reads_back_with_the_line_estimate() {
        let log = board_log(|_| 0);
        let recs = parse("board.log", &lines(&log)).unwrap();
        assert!(recs.iter().all(|r| r.truth.is_none()));
        let dir = tempfile::tempdir().unwrap();
        let w = write_dataset(dir.path(), &recs, &Roles::default()).unwrap();
        assert_eq!((w.calibration_points, w.traces.len(), w.rows), (3, 1, 40));
        // dataset.json names the trace that stays, not the held sensors'.
        let about: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join(DATASET_JSON)).unwrap()).unwrap();
        let named: Vec<&str> = about["traces"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["file"].as_str().unwrap())
            .collect();
        assert_eq!(named, ["trace_ch0_1953hz.csv"], "{about}");
        let ds = crate::dataset::read_dir(dir.path()).unwrap();
        use crate::dataset::Resistance;
        assert_eq!(ds.calibration.resistance, Resistance::InstrumentLine);
        assert_eq!(ds.traces[0].resistance, Resistance::InstrumentLine);
        assert_eq!(ds.traces[0].rows[3].r_rec(), 712000.0);
        assert_eq!(ds.calibration.rows[2].stretch_mm(), 20.0);
    }

    #[test]
    fn a_held_sensor_with_no_usable_record_is_left_out_not_the_whole_set() {
        // Every record of channel 3 (held at 20 mm) failed the model
        // check (MODEL, 256), as an uncalibrated device's may.
        let log = board_log(|ch| if ch == 3 { 256 } else { 0 });
        let recs = parse("board.log", &lines(&log)).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let w = write_dataset(dir.path(), &recs, &Roles::default()).unwrap();
        assert_eq!((w.calibration_points, w.traces.len()), (2, 1));
        assert_eq!(w.left_out.len(), 1, "{:?}", w.left_out);
        assert!(w.left_out[0].starts_with("sensor 3,"), "{:?}", w.left_out);
        let about: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join(DATASET_JSON)).unwrap()).unwrap();
        assert!(
            about["left_out"][0]
                .as_str()
                .is_some_and(|w| w.starts_with("sensor 3, held still, has no calibration point")),
            "{about}"
        );
        let ds = crate::dataset::read_dir(dir.path()).unwrap();
        assert_eq!(ds.calibration.rows.len(), 2);
        // Listed with the flag each record carries.
        let faults = std::fs::read_to_string(dir.path().join("faults.csv")).unwrap();
        assert_eq!(faults.lines().count(), 41, "{faults}");
        assert!(
            faults.lines().skip(1).all(|l| l.split(',').nth(3) == Some("256")),
            "{faults}"
        );
    }

    #[test]
    fn malformed_records_are_errors_with_their_position() {
        let err = parse("log", &lines("rec 0 0 585.9 1 2 3\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("7 fields"), "{err}");
        let err = parse("log", &lines("start\nrec 0 0 585.9 1 2 3 4 x 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:2") && err.contains("field 9"), "{err}");
        let err = parse("log", &lines("rec 9 0 1 1 2 3 4 5 0\nrec 9 0 1 1 2 3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:2") && err.contains("back in time"), "{err}");
        let err = parse("log", &lines("rec 9 0 -585.9 1 2 3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("not positive"), "{err}");
        let err = parse("log", &lines("rec 9 0 585.9 1 2 -3 4 5 0\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("log:1") && err.contains("negative"), "{err}");
        // Not a keyword inside a word.
        assert!(lines("prec 0 0\n").is_empty());
    }
}
