//! The record wire format, written and parsed here and nowhere else.
//!
//! The firmware logs one line per block (defmt: `defmt::println!("{}",
//! record)` with the `defmt` feature), and in QEMU one truth line per block
//! beside it; the host reads them back with [`parse`]:
//!
//! ```text
//! rec   t_us sensor freq_hz cs_pF rs_ohm c_pF r_ohm stretch_mm flags
//! truth t_us sensor c_pF r_line_ohm stretch_mm r_top_ohm r_bottom_ohm
//! tone  t_us sensor f_lo_hz re_lo_ohm im_lo_ohm f_hi_hz re_hi_ohm im_hi_ohm c_pF r_ohm chi2 sigma_ln_c stretch_mm flags
//! ```
//!
//! A `tone` line is one record of the array ([`crate::tones`]): the two
//! tones' measured impedances, the line both fit, its χ² and the 1σ
//! relative error of C.
//!
//! `t_us` is the middle of the block in µs since start (an integer, exact
//! for 584 000 years); a truth line belongs to the record with the same
//! `t_us` and `sensor`. Capacitances are in pF on the wire, F in
//! [`Record`]. `flags` are the bits of [`crate::faults::Flags`].

use crate::channel::Record;
use crate::faults::Flags;
use crate::tones::ToneRecord;
use dsp_core::Complex32;

/// The first word of a record line.
pub const REC: &str = "rec";
/// The first word of an array record line.
pub const TONE: &str = "tone";

pub use skin_spec::truth::{TruthLine, TRUTH};

/// One parsed line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Line {
    /// A `rec` line.
    Rec(Record),
    /// A `truth` line.
    Truth(TruthLine),
    /// A `tone` line.
    Tone(ToneRecord),
}

/// Why a line is not a record or truth line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireError {
    /// Not a `rec`, `truth` or `tone` line (other log output).
    NotARecord,
    /// The number of fields differs from the format's.
    FieldCount {
        /// Fields the line has, its keyword included.
        found: usize,
        /// Fields the format has.
        expected: usize,
    },
    /// Field `index` (0 = the keyword) does not parse, or is not finite.
    Field(usize),
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WireError::NotARecord => write!(f, "not a '{REC}', '{TRUTH}' or '{TONE}' line"),
            WireError::FieldCount { found, expected } => {
                write!(f, "{found} fields where the format has {expected}")
            }
            WireError::Field(i) => write!(f, "field {} is not a finite number of its type", i + 1),
        }
    }
}

impl core::error::Error for WireError {}

/// Fields of a `rec` line, its keyword included.
pub const REC_FIELDS: usize = 10;
/// Fields of a `truth` line, its keyword included.
pub const TRUTH_FIELDS: usize = 8;
/// Fields of a `tone` line, its keyword included.
pub const TONE_FIELDS: usize = 15;

/// Parse one line (surrounding text before the keyword, such as a probe's
/// timestamp, must be cut by the caller).
pub fn parse(line: &str) -> Result<Line, WireError> {
    let mut words = line.split_whitespace();
    let kind = words.next().ok_or(WireError::NotARecord)?;
    let expected = match kind {
        REC => REC_FIELDS,
        TRUTH => TRUTH_FIELDS,
        TONE => TONE_FIELDS,
        _ => return Err(WireError::NotARecord),
    };
    let mut w = [""; TONE_FIELDS];
    let mut found = 1;
    for word in words {
        if found < TONE_FIELDS {
            w[found] = word;
        }
        found += 1;
    }
    if found != expected {
        return Err(WireError::FieldCount { found, expected });
    }
    let int = |i: usize| w[i].parse::<u64>().map_err(|_| WireError::Field(i));
    let byte = |i: usize| w[i].parse::<u8>().map_err(|_| WireError::Field(i));
    let flags = |i: usize| w[i].parse::<u16>().map(Flags).map_err(|_| WireError::Field(i));
    let num = |i: usize| match w[i].parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(WireError::Field(i)),
    };
    Ok(match kind {
        REC => Line::Rec(Record {
            t_us: int(1)?,
            sensor: byte(2)?,
            freq_hz: num(3)?,
            cs_farad: num(4)? * 1e-12,
            rs_ohm: num(5)?,
            c_farad: num(6)? * 1e-12,
            r_ohm: num(7)?,
            stretch_mm: num(8)?,
            flags: flags(9)?,
            // Not on the log's line: the link's frames carry them.
            ..Record::default()
        }),
        TONE => Line::Tone(ToneRecord {
            t_us: int(1)?,
            sensor: byte(2)?,
            f_hz: [num(3)?, num(6)?],
            z: [Complex32::new(num(4)?, num(5)?), Complex32::new(num(7)?, num(8)?)],
            c_farad: num(9)? * 1e-12,
            r_ohm: num(10)?,
            chi2: num(11)?,
            sigma_ln_c: num(12)?,
            stretch_mm: num(13)?,
            flags: flags(14)?,
        }),
        _ => Line::Truth(TruthLine {
            t_us: int(1)?,
            sensor: byte(2)?,
            c_farad: num(3)? * 1e-12,
            r_line_ohm: num(4)?,
            stretch_mm: num(5)?,
            r_top_ohm: num(6)?,
            r_bottom_ohm: num(7)?,
        }),
    })
}

#[cfg(feature = "defmt")]
impl defmt::Format for Record {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "rec {=u64} {=u8} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=u16}",
            self.t_us,
            self.sensor,
            self.freq_hz,
            self.cs_farad * 1e12,
            self.rs_ohm,
            self.c_farad * 1e12,
            self.r_ohm,
            self.stretch_mm,
            self.flags.0
        )
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ToneRecord {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "tone {=u64} {=u8} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=u16}",
            self.t_us,
            self.sensor,
            self.f_hz[0],
            self.z[0].re,
            self.z[0].im,
            self.f_hz[1],
            self.z[1].re,
            self.z[1].im,
            self.c_farad * 1e12,
            self.r_ohm,
            self.chi2,
            self.sigma_ln_c,
            self.stretch_mm,
            self.flags.0
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_parse_and_bad_ones_say_why() {
        let Ok(Line::Rec(r)) = parse("rec 2560 3 1953.125 201.5 123456 209.9 700000 -0.1 32") else {
            panic!("not a record")
        };
        assert_eq!((r.t_us, r.sensor, r.flags), (2560, 3, Flags(32)));
        assert!((r.cs_farad - 201.5e-12).abs() < 1e-16 && (r.c_farad - 209.9e-12).abs() < 1e-16);
        assert_eq!((r.rs_ohm, r.r_ohm, r.stretch_mm), (123456.0, 700000.0, -0.1));
        let Ok(Line::Truth(t)) = parse("truth 2560 3 210 711000 0 355500 355500") else {
            panic!("not a truth line")
        };
        assert_eq!((t.t_us, t.sensor, t.r_top_ohm), (2560, 3, 355500.0));
        assert_eq!(parse("start 8 channels"), Err(WireError::NotARecord));
        assert_eq!(parse(""), Err(WireError::NotARecord));
        assert_eq!(
            parse("rec 1 2 3 4 5 6 7 8 9 10"),
            Err(WireError::FieldCount {
                found: 11,
                expected: 10
            })
        );
        assert_eq!(
            parse("truth 1 2 3"),
            Err(WireError::FieldCount {
                found: 4,
                expected: 8
            })
        );
        assert_eq!(parse("rec 1 2 NaN 4 5 6 7 8 9"), Err(WireError::Field(3)));
        let Ok(Line::Tone(t)) =
            parse("tone 2000 15 500 812000 -1.9e6 2000 400000 -520000 205.1 1.01e6 1.7 0.0004 0.2 256")
        else {
            panic!("not a tone line")
        };
        assert_eq!(
            (t.t_us, t.sensor, t.f_hz, t.flags),
            (2000, 15, [500.0, 2000.0], Flags(Flags::MODEL))
        );
        assert_eq!(t.z[1], Complex32::new(400000.0, -520000.0));
        assert!((t.c_farad - 205.1e-12).abs() < 1e-16 && t.chi2 == 1.7 && t.sigma_ln_c == 0.0004);
        assert_eq!(
            parse("tone 1 2 3"),
            Err(WireError::FieldCount {
                found: 4,
                expected: 15
            })
        );
        assert_eq!(
            parse("tone 1 2 3 4 5 6 7 8 9 10 11 12 13 70000"),
            Err(WireError::Field(14))
        );
        assert_eq!(parse("rec -1 2 3 4 5 6 7 8 9"), Err(WireError::Field(1)));
        assert_eq!(parse("rec 1 300 3 4 5 6 7 8 9"), Err(WireError::Field(2)));
    }
}
