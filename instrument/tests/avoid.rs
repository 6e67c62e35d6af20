//! Moving off a tone an interferer occupies (`instrument::avoid`): which
//! tones a channel reads instead, and when it moves and moves back.

use instrument::array::TONES;
use instrument::avoid::{Avoidance, HOLD_S, MIN_HOLD_S, VOTES, WINDOW_S};
use instrument::tones::ToneChannel;

/// 250 records/s.
const DT: f32 = 0.004;

/// An avoidance that has moved off `tone`.
fn avoiding(tone: usize) -> Avoidance {
    let mut a = Avoidance::new();
    for _ in 0..VOTES {
        a.update_on(Some(tone), DT);
    }
    assert_eq!(a.tone(), Some(tone));
    a
}

/// For every pair the policy can choose and every tone avoided: three
/// distinct tones, ascending, without the avoided one; the policy's own
/// where they do not hold it; else none above the policy's upper tone
/// unless fewer than three lie at or below it, and then the lowest three.
#[test]
fn the_tones_read_instead_leave_the_avoided_one_out_and_stay_low() {
    for hi in 1..TONES as u8 {
        let natural = ToneChannel::fitted_of(ToneChannel::pair_of(hi));
        for k in 0..TONES {
            let f = avoiding(k).fitted(natural);
            assert!(
                f[0] < f[1] && f[1] < f[2] && f[2] < TONES,
                "{natural:?} avoiding {k}: {f:?}"
            );
            assert!(!f.contains(&k), "{natural:?} avoiding {k}: {f:?}");
            if !natural.contains(&k) {
                assert_eq!(f, natural);
                continue;
            }
            let below = (0..=natural[2]).filter(|&t| t != k).count();
            if below >= 3 {
                assert!(f[2] <= natural[2], "{natural:?} avoiding {k}: {f:?}");
                // The highest three of them.
                let mut top: Vec<usize> = (0..=natural[2]).filter(|&t| t != k).collect();
                top.drain(..top.len() - 3);
                assert_eq!(f.to_vec(), top);
            } else {
                let low: Vec<usize> = (0..TONES).filter(|&t| t != k).take(3).collect();
                assert_eq!(f.to_vec(), low);
            }
        }
    }
    // Tones 0, 1, 2 (250 Hz, 500 Hz, 1 kHz) off tone 0: 500 Hz, 1 and 2 kHz.
    assert_eq!(avoiding(0).fitted([0, 1, 2]), [1, 2, 3]);
    assert_eq!(Avoidance::new().fitted([0, 1, 2]), [0, 1, 2]);
}

/// VOTES rescues without one tone within WINDOW_S move the channel off
/// it; fewer, or spread over more than the window, or split between
/// tones, do not; no evidence never moves it.
#[test]
fn a_channel_moves_on_evidence_gathered_within_a_second() {
    let mut a = Avoidance::new();
    for _ in 0..10_000 {
        assert!(!a.update_on(None, DT));
    }
    assert_eq!(a.tone(), None);
    // One short.
    for _ in 1..VOTES {
        assert!(!a.update_on(Some(2), DT));
    }
    assert_eq!(a.tone(), None);
    assert!(a.update_on(Some(2), DT));
    assert_eq!(a.tone(), Some(2));
    // Spread over more than the window: never.
    let mut a = Avoidance::new();
    let gap = WINDOW_S / (VOTES - 1) as f32 * 1.05;
    for _ in 0..4 * VOTES {
        a.update_on(Some(1), gap);
    }
    assert_eq!(a.tone(), None);
    // Alternating between two tones: never.
    let mut a = Avoidance::new();
    for n in 0..4 * usize::from(VOTES) {
        a.update_on(Some(n % 2), DT);
    }
    assert_eq!(a.tone(), None);
}

/// An avoided tone is tried again after HOLD_S; another tone singled out
/// replaces it only once it has been avoided MIN_HOLD_S.
#[test]
fn an_avoided_tone_is_tried_again_and_replaced_only_after_a_while() {
    let mut a = avoiding(0);
    let steps = (HOLD_S / DT) as usize;
    let mut back = None;
    for n in 0..steps + 10 {
        if a.update_on(None, DT) {
            back = Some(n);
            break;
        }
    }
    let back = back.expect("tried again");
    assert!((back as f32 * DT - HOLD_S).abs() <= 2.0 * DT, "{back}");
    assert_eq!(a.tone(), None);
    // Evidence for the avoided tone itself changes nothing.
    let mut a = avoiding(0);
    for _ in 0..100 {
        assert!(!a.update_on(Some(0), DT));
    }
    // Another tone at once: held for MIN_HOLD_S first.
    let mut a = avoiding(0);
    for _ in 0..VOTES {
        a.update_on(Some(3), DT);
    }
    assert_eq!(a.tone(), Some(0));
    let mut a = avoiding(0);
    let mut t = 0.0;
    while t < MIN_HOLD_S {
        a.update_on(None, DT);
        t += DT;
    }
    for _ in 0..VOTES {
        a.update_on(Some(3), DT);
    }
    assert_eq!(a.tone(), Some(3));
}
