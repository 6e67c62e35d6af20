//! `interpolated.csv`: a value for each record the instrument could not
//! vouch for, from its sensor's valid neighbours
//! ([`host_sim::interpolate`]: at most 100 ms apart, straight between
//! their lines), never as a measurement: `records.csv` keeps the record
//! as measured, with its flags. A row is written when the record's
//! later neighbour arrives.

use host_sim::interpolate::{Anchor, Filled, Interpolator};
use instrument::faults::Flags;
use link::Record;
use std::collections::BTreeMap;

/// The interpolated values, appended to as their later neighbours arrive.
pub const INTERPOLATED_CSV: &str = "interpolated.csv";

/// The header of [`INTERPOLATED_CSV`]: the record's segment, frame and
/// time (as in `records.csv`), its sensor, the interpolated line and
/// stretch (empty where a neighbour's stretch is not valid), the time
/// between its neighbours and the record's own flags.
pub(crate) const HEADER: &str = "segment,seq,t_us,sensor,c_pf,r_ohm,stretch_mm,gap_us,flags\n";

/// Every sensor's gap in the segment running.
#[derive(Clone, Debug, Default)]
pub(crate) struct Gaps {
    /// The records waiting: their frame and flags.
    inner: Interpolator<(u32, u16)>,
}

impl Gaps {
    /// A device restart: no gap spans it.
    pub fn restart(&mut self) {
        self.inner.restart();
    }

    /// Values given per sensor.
    pub fn given(&self) -> &BTreeMap<u8, u64> {
        &self.inner.given
    }

    /// Take record `r` (frame `seq` of `segment`, later than its
    /// sensor's last): the rows of the gap it closes, appended to `out`.
    pub fn record(&mut self, segment: u32, seq: u32, r: &Record, out: &mut Vec<u8>) {
        let line = Anchor::of(r.t_us, Flags(r.flags), r.c_farad, r.r_ohm, r.stretch_mm);
        self.inner.take(r.sensor, r.t_us, line, (seq, r.flags), |f| {
            row(out, segment, r.sensor, &f)
        });
    }
}

/// The row of value `f` of `sensor`'s record.
fn row(out: &mut Vec<u8>, segment: u32, sensor: u8, f: &Filled<(u32, u16)>) {
    use host_sim::numfmt::{fixed, int};
    let (seq, flags) = f.key;
    int(out, segment);
    out.push(b',');
    int(out, seq);
    out.push(b',');
    int(out, f.t_us);
    out.push(b',');
    int(out, sensor);
    out.push(b',');
    fixed(out, f.c_farad * 1e12, 4);
    out.push(b',');
    fixed(out, f.r_ohm, 0);
    out.push(b',');
    if let Some(s) = f.stretch_mm {
        fixed(out, s, 4);
    }
    out.push(b',');
    int(out, f.gap_us);
    out.push(b',');
    int(out, flags);
    out.push(b'\n');
}
