//! One file of a data set as the models see it: its columns (decimated
//! for long traces), the corners of its stretch profile, and the rows
//! that enter the statistics.

use super::search::Search;
use crate::dataset::{Kind, Row, Table};
use crate::numerics::corners;

/// The fewest rows a trace may have: its noise floor takes second
/// differences, its time effects interpolate between rows.
pub const MIN_TRACE_ROWS: usize = 8;

/// One modelled file.
#[derive(Clone, Debug)]
pub struct File {
    /// File name.
    pub name: String,
    /// A dynamic trace (time effects apply) or a static sweep.
    pub kind: Kind,
    /// Time, s (traces).
    pub t: Vec<f64>,
    /// Stretch, mm.
    pub s: Vec<f64>,
    /// R_top + R_bottom, Ω.
    pub r: Vec<f64>,
    /// Frequency, Hz.
    pub f: Vec<f64>,
    /// Measured Cs, pF.
    pub cs: Vec<f64>,
    /// Stated 1σ of Cs, pF (`cs_sigma_pf`; NaN where not given).
    pub sigma: Vec<f64>,
    /// Rows where the stretch profile turns (traces).
    pub corner: Vec<bool>,
    /// Rows of the file as read (before decimation).
    pub rows_read: usize,
    /// Decimation: every `stride`-th row read is kept (1: all).
    pub stride: usize,
    /// Rows that enter the statistics: all but those at a trace's ends
    /// whose reading, at the largest window and offset searched, would
    /// reach outside the recording (no model can predict them).
    pub used: Vec<bool>,
}

pub(super) fn file_of(t: &Table, max_rows: usize, search: &Search) -> File {
    let stride = match t.kind {
        Kind::Trace => t.rows.len().div_ceil(max_rows.max(MIN_TRACE_ROWS)).max(1),
        _ => 1,
    };
    let col = |g: fn(&Row) -> f64| t.rows.iter().step_by(stride).map(g).collect::<Vec<f64>>();
    File {
        name: t
            .path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned()),
        kind: t.kind,
        t: if t.kind == Kind::Trace {
            col(Row::time_s)
        } else {
            vec![]
        },
        s: col(Row::stretch_mm),
        r: t.rows.iter().step_by(stride).map(|r| r.r_rec()).collect(),
        f: col(Row::freq_hz),
        cs: col(Row::cs_pf),
        sigma: col(Row::cs_sigma_pf),
        corner: vec![],
        rows_read: t.rows.len(),
        stride,
        used: vec![],
    }
    .finish(search)
}

impl File {
    fn finish(mut self, search: &Search) -> Self {
        if self.kind == Kind::Trace {
            self.corner = corners(&self.t, &self.s);
            let (back, ahead) = search.edges_s();
            let (a, b) = (self.t[0] + back, self.t[self.t.len() - 1] - ahead);
            self.used = self.t.iter().map(|&t| t >= a && t <= b).collect();
        } else {
            self.used = vec![true; self.cs.len()];
        }
        self
    }
}
