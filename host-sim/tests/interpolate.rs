//! `host_sim::interpolate` against a second reading of its rule, done
//! offline over the whole record set: for each record not valid, the
//! nearest valid records of its sensor before and after it, at most
//! `MAX_GAP_US` apart, and the straight line between them in f64.

use host_sim::interpolate::{Anchor, Interpolator, MAX_GAP_US};
use instrument::faults::Flags;
use proptest::prelude::*;

/// One record: sensor, time (µs), C (F, as a record holds it), flags.
type Rec = (u8, u64, f32, u16);

/// What the rule gives each record, by its index: (C pF, gap µs).
fn offline(recs: &[Rec]) -> Vec<Option<(f64, u64)>> {
    let valid = |r: &Rec| Flags(r.3).valid();
    (0..recs.len())
        .map(|k| {
            let r = recs[k];
            if valid(&r) {
                return None;
            }
            let before = recs[..k].iter().rev().find(|q| q.0 == r.0 && valid(q))?;
            let after = recs[k + 1..].iter().find(|q| q.0 == r.0 && valid(q))?;
            let gap = after.1 - before.1;
            if gap > MAX_GAP_US {
                return None;
            }
            let u = (r.1 - before.1) as f64 / gap as f64;
            let (a, b) = (f64::from(before.2) * 1e12, f64::from(after.2) * 1e12);
            Some((a + (b - a) * u, gap))
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2_000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Every value the streaming rule gives is the offline one (to 10⁻⁹
    /// of C: f64 rounding), and it gives one exactly where the offline
    /// rule does: no value across a longer gap, before a sensor's first
    /// valid record or after its last.
    #[test]
    fn the_streaming_rule_gives_the_offline_values(
        draws in prop::collection::vec((0u8..3, 1u64..40_000, 150.0f32..300.0, prop::bool::weighted(0.4)), 1..300),
    ) {
        // Times per sensor, increasing.
        let mut clock = [0u64; 3];
        let recs: Vec<Rec> = draws
            .iter()
            .map(|&(s, step, c, bad)| {
                clock[usize::from(s)] += step;
                (s, clock[usize::from(s)], c * 1e-12, if bad { Flags::UNCERTAIN } else { 0 })
            })
            .collect();
        let want = offline(&recs);
        let mut got: Vec<Option<(f64, u64)>> = vec![None; recs.len()];
        let mut it = Interpolator::default();
        for (k, &(s, t, c, flags)) in recs.iter().enumerate() {
            let line = Anchor::of(t, Flags(flags), c, 7e5, 1.0);
            it.take(s, t, line, k, |f| got[f.key] = Some((f.c_farad * 1e12, f.gap_us)));
        }
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            match (g, w) {
                (Some((gc, gg)), Some((wc, wg))) => {
                    prop_assert_eq!(gg, wg, "record {}", k);
                    prop_assert!((gc - wc).abs() <= 1e-9 * wc, "record {}: {} vs {}", k, gc, wc);
                }
                (None, None) => {}
                _ => prop_assert!(false, "record {}: {:?} vs {:?}", k, g, w),
            }
        }
        let given: u64 = it.given.values().sum();
        prop_assert_eq!(given as usize, want.iter().flatten().count());
    }
}
