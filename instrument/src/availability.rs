//! How many of a sensor's records were valid, and why the others were
//! not: counted record by record, a few words per sensor whatever the
//! session's length. The other half of an instrument's promise beside
//! the error of its valid records: what share of them it delivers.

use crate::faults::Flags;
use core::fmt;

/// A sensor's (or a skin's) records: how many, how many valid, and how
/// often each fault flag stood on the others.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Availability {
    /// Records counted.
    pub records: u64,
    /// Records whose C is valid ([`Flags::valid`]).
    pub valid: u64,
    /// Among the records not valid, how many carry each fault flag, in
    /// the order of [`Flags::NAMES`] (status flags stay 0). A record may
    /// carry several: these may sum to more than the records not valid.
    pub flagged: [u64; Flags::NAMES.len()],
}

impl Availability {
    /// Nothing counted.
    pub const fn new() -> Self {
        Self {
            records: 0,
            valid: 0,
            flagged: [0; Flags::NAMES.len()],
        }
    }

    /// Count one record with `flags`.
    pub fn count(&mut self, flags: Flags) {
        self.records += 1;
        if flags.valid() {
            self.valid += 1;
            return;
        }
        for (n, (bit, _)) in self.flagged.iter_mut().zip(Flags::NAMES) {
            if flags.0 & bit & Flags::FAULTS != 0 {
                *n += 1;
            }
        }
    }

    /// Add `other`'s counts (another segment, another sensor).
    pub fn add(&mut self, other: &Self) {
        self.records += other.records;
        self.valid += other.valid;
        for (a, b) in self.flagged.iter_mut().zip(other.flagged) {
            *a += b;
        }
    }

    /// The share of records valid, 0 … 1; `None` before any record.
    pub fn share(&self) -> Option<f64> {
        (self.records > 0).then(|| self.valid as f64 / self.records as f64)
    }

    /// Records not valid.
    pub fn invalid(&self) -> u64 {
        self.records - self.valid
    }

    /// The fault flags that stood on records not valid, with how many,
    /// most frequent first (ties in bit order).
    pub fn reasons(&self) -> impl Iterator<Item = (&'static str, u64)> {
        let counts = self.flagged;
        order(&counts)
            .into_iter()
            .map(move |k| (Flags::NAMES[k].1, counts[k]))
            .filter(|&(_, n)| n > 0)
    }

    /// Why the records not valid were not, for a summary: each fault
    /// flag with its count, most frequent first (`MODEL 40, DISTURBED
    /// 23`), or `–` when every record was valid.
    pub fn why(&self) -> Why {
        Why(*self)
    }
}

/// The indices of `counts`, largest first, equal ones in index order.
fn order(counts: &[u64; Flags::NAMES.len()]) -> [usize; Flags::NAMES.len()] {
    let mut idx: [usize; Flags::NAMES.len()] = core::array::from_fn(|k| k);
    // Insertion sort: twelve entries, stable, no allocation.
    for i in 1..idx.len() {
        let mut j = i;
        while j > 0 && counts[idx[j - 1]] < counts[idx[j]] {
            idx.swap(j - 1, j);
            j -= 1;
        }
    }
    idx
}

/// `97.2 % valid (2187 of 2250)`, or `no records`.
impl fmt::Display for Availability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.share() {
            Some(s) => write!(f, "{:.1} % valid ({} of {})", 100.0 * s, self.valid, self.records),
            None => f.write_str("no records"),
        }
    }
}

/// [`Availability::why`]'s text.
#[derive(Clone, Copy, Debug)]
pub struct Why(Availability);

impl fmt::Display for Why {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut any = false;
        for (name, n) in self.0.reasons() {
            if any {
                f.write_str(", ")?;
            }
            write!(f, "{name} {n}")?;
            any = true;
        }
        if !any {
            f.write_str("–")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::format;

    #[test]
    fn counts_shares_and_reasons() {
        let mut a = Availability::new();
        assert_eq!(a.share(), None);
        assert_eq!(format!("{a}"), "no records");
        assert_eq!(format!("{}", a.why()), "–");
        for _ in 0..7 {
            a.count(Flags(0));
        }
        // A status flag leaves a record valid and is no reason.
        a.count(Flags(Flags::UNCALIBRATED));
        a.count(Flags(Flags::MODEL));
        a.count(Flags(Flags::MODEL | Flags::UNCERTAIN | Flags::OFF_TABLE));
        a.count(Flags(Flags::DISTURBED));
        a.count(Flags(Flags::CLIPPED));
        assert_eq!((a.records, a.valid, a.invalid()), (12, 8, 4));
        assert_eq!(a.share(), Some(8.0 / 12.0));
        assert_eq!(format!("{a}"), "66.7 % valid (8 of 12)");
        // MODEL twice first; the ones in bit order.
        assert_eq!(
            format!("{}", a.why()),
            "MODEL 2, CLIPPED 1, DISTURBED 1, UNCERTAIN 1"
        );
        let mut b = Availability::new();
        b.count(Flags(Flags::LATE));
        b.add(&a);
        assert_eq!((b.records, b.valid), (13, 8));
        assert_eq!(
            format!("{}", b.why()),
            "MODEL 2, CLIPPED 1, DISTURBED 1, UNCERTAIN 1, LATE 1"
        );
    }
}
