//! The ranges `identify` searches on one data set: the catalogue's for
//! the sensor's effects, and for the recording's time effects as far as
//! the traces can hold.
//!
//! A meter stamping its readings late by δ and averaging them over a
//! window T reads at t what the sensor did over [t + δ − T, t + δ]. How
//! far δ and T may reach is a property of the recording, not of the
//! meter: the rows whose reading would reach outside the recording are
//! left out of the statistics (nothing recorded says what the sensor did
//! there: a trace that rests at its last row may be cut from a cycle that
//! goes on), so the reach is what leaves [`EDGE_BUDGET`] of the shortest
//! trace out, at most the catalogue's physical limits:
//!
//! ```text
//! D = EDGE_BUDGET · T_min / 3
//! offset ∈ [−D, D], window ∈ [0, D], first-order τ ∈ [0, D/2]
//! left out: 2D at the start (the window, or 2τ, plus the largest
//! negative offset), D at the end (the largest positive offset)
//! ```
//!
//! For 30 s traces: offsets to ±2 s, windows to 2 s. 2τ: a first-order
//! filter started settled on the first row is within e⁻² of one that saw
//! the past.

use super::Effect;
use crate::dataset::{Kind, Row, Table};

/// The most of a trace left out of the statistics at its ends.
pub const EDGE_BUDGET: f64 = 0.2;

/// How far the time effects may reach on one trace of times `t` (s):
/// the reach D that leaves [`EDGE_BUDGET`] of it out (3D).
pub fn reach_of(t: &[f64]) -> f64 {
    EDGE_BUDGET * (t[t.len() - 1] - t[0]) / 3.0
}

/// The ranges searched on one data set (SI): the catalogue's, the time
/// effects' cut to the traces' reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Search {
    /// The time effects' reach D, s: offsets within ±D, windows to D,
    /// first-order time constants to D/2 (0: no trace).
    pub reach_s: f64,
    /// The shortest median row interval of the traces, s: the finest
    /// time the grids start from (0: no trace).
    pub row_s: f64,
}

impl Search {
    /// The ranges of a data set whose traces are `traces`.
    pub fn of<'a>(traces: impl IntoIterator<Item = &'a Table>) -> Self {
        let (mut reach, mut row) = (f64::INFINITY, f64::INFINITY);
        for tab in traces.into_iter().filter(|t| t.kind == Kind::Trace) {
            let t: Vec<f64> = tab.rows.iter().map(Row::time_s).collect();
            if t.len() < 2 {
                continue;
            }
            reach = reach.min(reach_of(&t));
            let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
            steps.sort_by(f64::total_cmp);
            row = row.min(steps[steps.len() / 2]);
        }
        if !reach.is_finite() {
            return Self {
                reach_s: 0.0,
                row_s: 0.0,
            };
        }
        Self {
            reach_s: reach.max(0.0),
            row_s: row,
        }
    }

    /// The range searched for `e` (SI).
    pub fn range(&self, e: Effect) -> (f64, f64) {
        let d = self.reach_s;
        let (lo, hi) = e.info().search;
        match e {
            Effect::TimeOffset => (lo.max(-d), hi.min(d)),
            Effect::MeterLag => (lo, hi.min(d)),
            Effect::MeterResponse => (lo, hi.min(0.5 * d)),
            // A running mean as long as a window may be, in rows; a
            // weighted mean whose time constant m/(1 − m) rows reaches as
            // far as a first-order τ.
            Effect::MeterMean if self.row_s > 0.0 => (lo, hi.min((d / self.row_s).max(1.0))),
            Effect::MeterEwma if self.row_s > 0.0 => {
                let rows = 0.5 * d / self.row_s;
                (lo, hi.min(rows / (1.0 + rows)))
            }
            _ => (lo, hi),
        }
    }

    /// The seconds a trace's reading may reach before its first row
    /// (window or 2τ, plus the largest negative offset) and after its
    /// last (the largest positive offset).
    pub fn edges_s(&self) -> (f64, f64) {
        let (lo, hi) = self.range(Effect::TimeOffset);
        let back = self
            .range(Effect::MeterLag)
            .1
            .max(2.0 * self.range(Effect::MeterResponse).1);
        (back - lo, hi)
    }

    /// The finest nonzero magnitude a time effect's grid reaches down to,
    /// s: half a row interval (0: no trace).
    pub fn finest_time_s(&self) -> f64 {
        0.5 * self.row_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_leave_a_fifth_of_the_shortest_trace_out() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        let t: Vec<f64> = (0..1500).map(|k| k as f64 * 0.02).collect();
        let d = reach_of(&t);
        assert!(close(d, 29.98 * 0.2 / 3.0), "{d}");
        let s = Search {
            reach_s: d,
            row_s: 0.02,
        };
        let (back, ahead) = s.edges_s();
        assert!(close(back + ahead, 0.2 * 29.98));
        let s = Search {
            reach_s: 3.0,
            row_s: 0.02,
        };
        assert_eq!(s.range(Effect::TimeOffset), (-3.0, 3.0));
        assert_eq!(s.range(Effect::MeterResponse), (0.0, 1.5));
        assert_eq!(s.edges_s(), (6.0, 3.0));
        assert_eq!(
            s.range(Effect::ContactResistance),
            Effect::ContactResistance.info().search
        );
        assert!(close(s.finest_time_s(), 0.01));
    }
}
