//! A value for each record the instrument could not vouch for, from its
//! sensor's valid neighbours, never as a measurement (`live` writes them
//! to `interpolated.csv`; [`crate::availability`] states their error).
//!
//! A record not valid whose sensor has a valid record before it and one
//! after it, at most [`MAX_GAP_US`] apart, gets C and R straight between
//! the two neighbours' lines at its time, and the stretch too where both
//! neighbours' stretch is valid. Its value is known when the later
//! neighbour arrives. A longer gap, a gap at the start or the end, or a
//! restart between the neighbours ([`Interpolator::restart`]) gives
//! none: what the sensor did there is not known.

use instrument::faults::Flags;
use std::collections::BTreeMap;

/// The longest time between the valid neighbours of an interpolated
/// record, µs: 100 ms, 25 records at 250 records/s. The paper's fastest
/// stretching (50 mm/s) moves a sensor 5 mm in that time, straight on
/// its ramps; at a turn of the stretch the line between the neighbours
/// cuts the corner.
pub const MAX_GAP_US: u64 = 100_000;

/// The most records a sensor's gap holds while it waits for its later
/// neighbour (a stream of records closer than 100 µs apart is no
/// device's; beyond it the gap is given up).
const WAITING_MAX: usize = 1024;

/// A valid record's line, where a gap starts or ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// Its time, µs.
    pub t_us: u64,
    /// Line capacitance, F.
    pub c_farad: f64,
    /// Line resistance, Ω.
    pub r_ohm: f64,
    /// Stretch, mm, where it is valid.
    pub stretch_mm: Option<f64>,
}

impl Anchor {
    /// A record's line at `t_us`, if its `flags` vouch for it and it has
    /// one (C positive, R finite).
    pub fn of(t_us: u64, flags: Flags, c_farad: f32, r_ohm: f32, stretch_mm: f32) -> Option<Self> {
        let line = c_farad.is_finite() && c_farad > 0.0 && r_ohm.is_finite();
        (flags.valid() && line).then(|| Self {
            t_us,
            c_farad: f64::from(c_farad),
            r_ohm: f64::from(r_ohm),
            stretch_mm: (flags.stretch_valid() && stretch_mm.is_finite()).then_some(f64::from(stretch_mm)),
        })
    }
}

/// The value given to a record not vouched for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filled<K> {
    /// What the caller gave with the record.
    pub key: K,
    /// The record's time, µs.
    pub t_us: u64,
    /// Interpolated C, F.
    pub c_farad: f64,
    /// Interpolated R, Ω.
    pub r_ohm: f64,
    /// Interpolated stretch, mm (None where a neighbour's is not valid).
    pub stretch_mm: Option<f64>,
    /// Time between the neighbours, µs.
    pub gap_us: u64,
}

/// One sensor's gap: its last valid record, and the records since.
#[derive(Clone, Debug)]
struct Gap<K> {
    before: Option<Anchor>,
    waiting: Vec<(u64, K)>,
}

impl<K> Default for Gap<K> {
    fn default() -> Self {
        Self {
            before: None,
            waiting: vec![],
        }
    }
}

/// Every sensor's gap, and the values given so far.
#[derive(Clone, Debug)]
pub struct Interpolator<K> {
    gaps: BTreeMap<u8, Gap<K>>,
    /// Values given per sensor.
    pub given: BTreeMap<u8, u64>,
}

impl<K> Default for Interpolator<K> {
    fn default() -> Self {
        Self {
            gaps: BTreeMap::new(),
            given: BTreeMap::new(),
        }
    }
}

impl<K: Copy> Interpolator<K> {
    /// A device restart: no gap spans it.
    pub fn restart(&mut self) {
        self.gaps.clear();
    }

    /// Take `sensor`'s next record (later than its last), at `t_us`:
    /// `line` its line where it is valid ([`Anchor::of`]), `key` what to
    /// give back with its value. The values of the gap a valid record
    /// closes go to `out`, in time order.
    pub fn take(
        &mut self,
        sensor: u8,
        t_us: u64,
        line: Option<Anchor>,
        key: K,
        mut out: impl FnMut(Filled<K>),
    ) {
        let gap = self.gaps.entry(sensor).or_default();
        let Some(after) = line else {
            let near = gap
                .before
                .is_some_and(|b| t_us.saturating_sub(b.t_us) <= MAX_GAP_US);
            if near && gap.waiting.len() < WAITING_MAX {
                gap.waiting.push((t_us, key));
            } else {
                *gap = Gap::default();
            }
            return;
        };
        if let Some(before) = gap.before {
            let span = after.t_us.saturating_sub(before.t_us);
            if span <= MAX_GAP_US && !gap.waiting.is_empty() {
                for &(t, key) in &gap.waiting {
                    out(between(key, t, &before, &after));
                }
                *self.given.entry(sensor).or_default() += gap.waiting.len() as u64;
            }
        }
        gap.waiting.clear();
        gap.before = Some(after);
    }
}

/// The value at `t_us` straight between `before` and `after`.
fn between<K>(key: K, t_us: u64, before: &Anchor, after: &Anchor) -> Filled<K> {
    let span = after.t_us.saturating_sub(before.t_us);
    let u = t_us.saturating_sub(before.t_us) as f64 / span.max(1) as f64;
    let lerp = |a: f64, b: f64| a + (b - a) * u;
    Filled {
        key,
        t_us,
        c_farad: lerp(before.c_farad, after.c_farad),
        r_ohm: lerp(before.r_ohm, after.r_ohm),
        stretch_mm: before.stretch_mm.zip(after.stretch_mm).map(|(a, b)| lerp(a, b)),
        gap_us: span,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const VALID: Flags = Flags(0);
    const MODEL: Flags = Flags(Flags::MODEL);

    fn run(recs: &[(u8, u64, f32, Flags)]) -> Vec<Filled<usize>> {
        let mut it = Interpolator::default();
        let mut out = vec![];
        for (k, &(s, t, c_pf, flags)) in recs.iter().enumerate() {
            let line = Anchor::of(t, flags, c_pf * 1e-12, 7e5 + c_pf, c_pf / 10.0);
            it.take(s, t, line, k, |f| out.push(f));
        }
        out
    }

    /// Each record of a gap between valid neighbours, straight between
    /// them at its time.
    #[test]
    fn a_gap_between_valid_neighbours_is_filled_straight() {
        let out = run(&[
            (2, 0, 200.0, VALID),
            (2, 4_000, 999.0, MODEL),
            (2, 8_000, 999.0, Flags(Flags::UNCERTAIN)),
            (2, 16_000, 216.0, VALID),
        ]);
        assert_eq!(out.len(), 2, "{out:?}");
        assert_eq!((out[0].key, out[0].t_us, out[0].gap_us), (1, 4_000, 16_000));
        assert!((out[0].c_farad * 1e12 - 204.0).abs() < 1e-4);
        assert!((out[1].c_farad * 1e12 - 208.0).abs() < 1e-4);
        assert!((out[1].r_ohm - 700_208.0).abs() < 1e-3);
        assert!((out[1].stretch_mm.unwrap() - 20.8).abs() < 1e-4);
    }

    /// None for a gap longer than the limit, at the start or the end, or
    /// across a restart; no stretch where a neighbour's is not valid;
    /// sensors' gaps do not mix.
    #[test]
    fn no_value_where_the_neighbours_do_not_vouch_for_one() {
        let long = MAX_GAP_US + 1;
        assert!(run(&[
            (0, 0, 200.0, VALID),
            (0, 50_000, 1.0, MODEL),
            (0, long, 210.0, VALID)
        ])
        .is_empty());
        assert!(run(&[
            (0, 0, 1.0, MODEL),
            (0, 4_000, 200.0, VALID),
            (0, 8_000, 1.0, MODEL)
        ])
        .is_empty());
        assert!(run(&[
            (0, 0, 200.0, VALID),
            (0, 4_000, 1.0, MODEL),
            (1, 6_000, 300.0, VALID)
        ])
        .is_empty());
        let off = Flags(Flags::OFF_TABLE);
        let out = run(&[
            (0, 0, 200.0, off),
            (0, 4_000, 1.0, MODEL),
            (0, 8_000, 208.0, VALID),
        ]);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].stretch_mm, None);
        let mut it = Interpolator::default();
        let mut out = vec![];
        it.take(0, 0, Anchor::of(0, VALID, 2e-10, 7e5, 0.0), (), |f| out.push(f));
        it.take(0, 4_000, None, (), |f| out.push(f));
        it.restart();
        it.take(0, 8_000, Anchor::of(8_000, VALID, 2e-10, 7e5, 0.0), (), |f| {
            out.push(f)
        });
        assert!(out.is_empty() && it.given.is_empty());
    }
}
