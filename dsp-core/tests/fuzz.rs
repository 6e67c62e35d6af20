//! Fuzzing dsp-core's public API with proptest: arbitrary `f32` (NaN, ±∞,
//! subnormals, extremes), arbitrary samples and sequences. Properties: no
//! panic, and no non-finite or non-positive value returned as `Ok`.
//!
//! The number of cases per target is `FUZZ_CASES` (default 100 000, the
//! full pass, `cargo xtask test --full`; the README's test command runs
//! 1 000); `cargo xtask fuzz` runs 1 000 000.

use dsp_core::demod::{Demodulator, FrontEnd};
use dsp_core::invert::Inverter;
use dsp_core::lockin::{Basis, Lockin};
use dsp_core::lumped::SeriesRc;
use dsp_core::tline::LineModel;
use dsp_core::track::{TrackState, Tracker};
use dsp_core::{Complex32, Oscillator};
use proptest::prelude::*;
use std::sync::OnceLock;

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000)
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Any f32, with the awkward ones often.
fn f32_any() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<f32>(),
        Just(0.0),
        Just(-0.0),
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MIN_POSITIVE),
        Just(1e-45),
        Just(f32::MAX),
        (-1e7f32..1e7),
        (1e-12f32..1e-9),
        (100f32..5e4),
    ]
}

fn model() -> impl Strategy<Value = LineModel> {
    prop_oneof![
        Just(LineModel::Continuous),
        (0u8..=70).prop_map(LineModel::Ladder)
    ]
}

fn inverters() -> &'static [Inverter] {
    static INV: OnceLock<Vec<Inverter>> = OnceLock::new();
    INV.get_or_init(|| {
        let mut v = vec![];
        for m in [
            LineModel::Continuous,
            LineModel::Ladder(1),
            LineModel::Ladder(2),
            LineModel::Ladder(30),
            LineModel::Ladder(64),
        ] {
            for x_max in [1.0, 10.0, 16.0, 100.0] {
                v.push(Inverter::with_x_max(m, x_max).unwrap());
            }
            for lead in [0.05, 1.79, dsp_core::invert::LEAD_MAX] {
                v.push(Inverter::with_leads(m, 16.0, lead).unwrap());
            }
        }
        v
    })
}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn model_zeta(m in model(), x in f32_any()) {
        if let Ok(z) = m.zeta(x) {
            prop_assert!(z.re.is_finite() && z.im.is_finite() && z.re >= 0.0 && z.im < 0.0, "{m:?} {x}: {z}");
        }
    }

    #[test]
    fn model_impedance(m in model(), r in f32_any(), c in f32_any(), f in f32_any()) {
        if let Ok(z) = m.impedance(r, c, f) {
            prop_assert!(z.re.is_finite() && z.im.is_finite() && z.im < 0.0, "{z}");
        }
    }

    #[test]
    fn series_rc(re in f32_any(), im in f32_any(), f in f32_any()) {
        if let Ok(m) = SeriesRc::from_impedance(Complex32::new(re, im), f) {
            prop_assert!(positive(m.cs_farad) && m.rs_ohm.is_finite() && m.rs_ohm >= 0.0, "{m:?}");
        }
    }

    #[test]
    fn inversion(k in 0usize..20, re in f32_any(), im in f32_any(), f in f32_any(), c in f32_any(), c2 in f32_any()) {
        let inv = &inverters()[k];
        let z = Complex32::new(re, im);
        for l in [inv.invert(z, f), inv.invert_near(z, f, c), inv.invert_within(z, f, c, c2)].into_iter().flatten() {
            prop_assert!(positive(l.c_farad) && positive(l.r_ohm) && positive(l.x), "{l:?}");
            prop_assert!(l.x <= inv.x_max() * 1.001, "{l:?} beyond {}", inv.x_max());
        }
    }

    #[test]
    fn tracker(steps in prop::collection::vec((f32_any(), f32_any(), f32_any()), 1..12), prior in f32_any()) {
        static T: OnceLock<Tracker> = OnceLock::new();
        let t = T.get_or_init(|| Tracker::new(LineModel::Continuous, Tracker::X_MAX).unwrap());
        let mut st = TrackState::new(prior);
        for (re, im, f) in steps {
            if let Ok(r) = t.update(&mut st, Complex32::new(re, im), f) {
                prop_assert!(positive(r.line.c_farad) && positive(r.line.r_ohm), "{r:?}");
            }
        }
    }

    #[test]
    fn demodulator(ftw in any::<u32>(), samples in prop::collection::vec(any::<[i16; 2]>(), 0..64), gain in f32_any(), chunk in 1usize..70) {
        let o = Oscillator::from_ftw(ftw);
        let _ = o.periods_per_block(ftw % 40);
        let d = Demodulator::<64>::new(&o);
        let mut st = Default::default();
        for c in samples.chunks(chunk) {
            d.update(&mut st, c);
        }
        let ph = d.finish(&mut st);
        let [rv, ri] = ph.residual_rms();
        prop_assert!(rv.is_finite() && rv >= 0.0 && ri.is_finite() && ri >= 0.0);
        prop_assert!(ph.v_amplitude().is_finite() && ph.i_amplitude().is_finite());
        if let Some(z) = ph.impedance(&FrontEnd::transimpedance(gain, true)) {
            if gain.is_finite() {
                prop_assert!(!z.re.is_nan() || gain == 0.0 || !gain.is_normal(), "{z}");
            }
        }
    }

    /// Any samples, the extremes of i16 among them, through a lock-in of
    /// any periods: every phasor finite (the folded sums cannot overflow),
    /// a block of the wrong length refused.
    #[test]
    fn lockin(samples in prop::collection::vec(
        prop_oneof![any::<[i16; 2]>(), Just([i16::MIN, i16::MAX]), Just([i16::MAX, i16::MIN])], 63..=65),
        periods in 3u32..=30,
    ) {
        static BASIS: Basis<32> = Basis::new();
        let l = Lockin::new(periods, &BASIS);
        match l.block(&samples) {
            Ok(r) => {
                prop_assert_eq!(samples.len(), 64);
                let all = [r.v, r.i, r.guards[0][0], r.guards[0][1], r.guards[1][0], r.guards[1][1]];
                prop_assert!(all.iter().all(|z| z.re.is_finite() && z.im.is_finite()), "{r:?}");
                prop_assert!(r.v_amplitude() <= 65536.0 && r.i_amplitude() <= 65536.0, "{r:?}");
            }
            Err(e) => prop_assert_ne!(e.got, 64),
        }
    }
}
