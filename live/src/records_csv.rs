//! `records.csv`: every record as it arrived, one line each, and a
//! link record as the data set's writer takes it.

use dsp_core::lumped::SeriesRc;
use dsp_core::Complex32;
use host_sim::recording::{LoggedRecord, LoggedToneRecord};
use link::Record;

/// The records file, appended to as records arrive.
pub const RECORDS_CSV: &str = "records.csv";

/// The header of [`RECORDS_CSV`]: the segment (1, then one more after
/// each restart of the device), the frame's sequence number, then the
/// record's fields (a value the record lacks, NaN on the device, is an
/// empty field), then the host's UTC at its arrival (µs since the Unix
/// epoch; empty in a replay without its arrivals).
pub(crate) const HEADER: &str = "segment,seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags,host_utc_us\n";

/// Record `r`'s line (segment `segment`, frame `seq`, arrived at
/// `host_utc_us`), appended to `line`.
pub(crate) fn line(line: &mut Vec<u8>, segment: u32, seq: u32, r: &Record, host_utc_us: Option<i64>) {
    // Through `numfmt`: `{}` on eleven floats was most of a replay.
    use host_sim::numfmt::{fixed, int, shortest_f32};
    int(line, segment);
    line.push(b',');
    int(line, seq);
    line.push(b',');
    int(line, r.t_us);
    line.push(b',');
    int(line, r.sensor);
    // No value (NaN or infinite on the device): an empty field.
    let value = |line: &mut Vec<u8>, x: f32| {
        line.push(b',');
        if x.is_finite() {
            shortest_f32(line, x);
        }
    };
    for t in r.tones {
        for x in [t.f_hz, t.z_re_ohm, t.z_im_ohm] {
            value(line, x);
        }
    }
    line.push(b',');
    if r.c_farad.is_finite() {
        fixed(line, r.c_farad as f64 * 1e12, 4);
    }
    for x in [r.r_ohm, r.stretch_mm, r.chosen_hz, r.chi2, r.sigma_ln_c] {
        value(line, x);
    }
    line.push(b',');
    int(line, r.flags);
    line.push(b',');
    if let Some(us) = host_utc_us {
        int(line, us);
    }
    line.push(b'\n');
}

/// Record `r` as the data set's writer takes it: an array record (two
/// tones) as a record per tone, a multiplexed one as it is.
pub(crate) fn rows(r: &Record) -> heapless::Vec<LoggedRecord, 2> {
    let mut out = heapless::Vec::new();
    if r.measured().count() == 2 {
        let tone = LoggedToneRecord {
            rec: instrument::frames::to_tone_record(r),
            truth: None,
        };
        return heapless::Vec::from_slice(&tone.per_tone()).unwrap_or_default();
    }
    let t = r.tones[0];
    // The lumped reading of its one tone, as `per_tone` takes an array
    // record's (none where the tone has no capacitive Z).
    let lumped = SeriesRc::from_impedance(Complex32::new(t.z_re_ohm, t.z_im_ohm), t.f_hz).ok();
    // One row in room for two.
    let _ = out.push(LoggedRecord {
        t_s: r.t_us as f64 * 1e-6,
        sensor: r.sensor,
        freq_hz: t.f_hz as f64,
        cs_pf: lumped.map_or(0.0, |m| m.cs_farad as f64 * 1e12),
        rs_ohm: lumped.map_or(0.0, |m| m.rs_ohm as f64),
        c_pf: r.c_farad as f64 * 1e12,
        r_ohm: r.r_ohm as f64,
        stretch_mm: r.stretch_mm as f64,
        flags: instrument::faults::Flags(r.flags),
        truth: None,
    });
    out
}
