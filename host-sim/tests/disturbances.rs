//! The disturbance table (`host-sim disturbances`, docs/disturbances.md):
//! the array leaves no valid record 1 % off in any class, both paths keep
//! a clean skin's records, and the page shows what the code measures.

use host_sim::disturbances::{markdown, rows};

#[test]
fn the_array_vouches_for_no_wrong_record_under_any_disturbance() {
    let rows = rows();
    for (class, m, a) in &rows {
        if let Some(a) = a {
            assert_eq!(a.valid_off, 0, "array, {}: {a:?}", class.name);
        }
        // Whatever flags a whole record set, flags it on both paths: a
        // stuck, open, shorted or clipped input is never read.
        if [
            "stuck ADC",
            "open sensor",
            "shorted sensor",
            "clipping",
            "step in a block",
            "mains hum",
        ]
        .contains(&class.name)
        {
            assert_eq!(m.flagged, m.records, "multiplexed, {}: {m:?}", class.name);
            assert!(
                a.as_ref().is_none_or(|a| a.flagged == a.records),
                "array, {}: {a:?}",
                class.name
            );
        }
    }
    // The clean skin: ≥ 99 % of the records vouched for on both paths.
    let (_, m, a) = &rows[0];
    let a = a.as_ref().expect("the array runs the clean skin");
    assert!(m.flagged * 100 <= m.records, "{m:?}");
    assert!(a.flagged * 100 <= a.records, "{a:?}");
    figures::check("docs/disturbances.md", "disturbances", &markdown(&rows)).unwrap();
}
