//! The model check's history (`instrument::joint::Quiet`) against what
//! it bounds, drawn: an error at one tone of share s, fixed or turning
//! its phase from block to block, under white noise of the check's
//! degrees of freedom. A calm block's share is the lesser of its own
//! (√χ², at least √dof) and the history's; its own falls short of its
//! error where the noise cancels part of it (about 6 % of the calm
//! blocks drawn here), which no history mends. What the history adds,
//! a share short of the error where the block's own was not, is at most
//! 0.08 % of the calm blocks over histories of every length it bounds
//! from (`QUIET_MIN_BLOCKS` to 16 times `QUIET_BLOCKS`). Its standard error
//! from white noise's spread alone, not the blocks' own, adds up to
//! 0.12 % (and fails this test).

use dsp_core::invert::Line;
use dsp_core::twotone::Solution;
use instrument::joint::{Quiet, QUIET_BLOCKS, QUIET_MIN_BLOCKS};
use skin_sim::rng::Rng;

/// A solution of χ² `chi2` with `dof` degrees of freedom.
fn sol(chi2: f32, dof: f32) -> Solution {
    Solution {
        line: Line {
            r_ohm: 7e5,
            c_farad: 2e-10,
            x: 1.0,
            kappa: f32::NAN,
        },
        chi2,
        sigma_ln_c: 1e-3,
        loss_tangent: 0.0,
        hidden_ln_c: 1e-3,
        tone_ln_c2: [1e-6; 3],
        dof,
    }
}

/// One block's χ² and its error's share: white noise in `dof`
/// dimensions plus the error, of share `s` (fixed) or √2·s·cos φ (turning
/// at phase `phi`: its mean square s²).
fn block(rng: &mut Rng, dof: usize, s: f64, turning: bool, phi: f64) -> (f32, f64) {
    let e = if turning {
        std::f64::consts::SQRT_2 * s * phi.cos()
    } else {
        s
    };
    let chi2: f64 = (0..dof)
        .map(|k| {
            let z = rng.gaussian() + if k == 0 { e } else { 0.0 };
            z * z
        })
        .sum();
    (chi2 as f32, e.abs())
}

/// The share of calm blocks whose bound falls short of their error where
/// their own share did not, after histories of `n` blocks, over errors
/// of several sizes, fixed and turning.
fn short_of(n: u16, dof: usize, flag: f32, seed: u64) -> f64 {
    let mut rng = Rng::new(seed);
    let (mut short, mut asked) = (0u64, 0u64);
    for trial in 0..6000 {
        let s = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0][trial % 6];
        let turning = trial % 12 >= 6;
        let step = rng.uniform() * std::f64::consts::PI;
        let mut phi = rng.uniform() * std::f64::consts::TAU;
        let mut q = Quiet::new();
        for _ in 0..n {
            let (chi2, _) = block(&mut rng, dof, s, turning, phi);
            q.take(chi2, flag, 1.0);
            phi += step;
        }
        for _ in 0..8 {
            let (chi2, e) = block(&mut rng, dof, s, turning, phi);
            phi += step;
            if chi2 > 0.5 * flag {
                continue; // its own share stands
            }
            asked += 1;
            let own = instrument::joint::own_share(&sol(chi2, dof as f32)) as f64;
            if own >= e && (q.share(&sol(chi2, dof as f32), flag, 1.0) as f64) < e {
                short += 1;
            }
            q.take(chi2, flag, 1.0);
        }
    }
    short as f64 / asked as f64
}

#[test]
fn a_short_history_bounds_as_surely_as_a_full_one() {
    // Three tones (4 degrees of freedom, the array's flag) and two (2,
    // the multiplexed channel's).
    for (dof, flag) in [(4usize, 26.6f32), (2, 18.4)] {
        // (The exponential mean's weights settle after several times its
        // span: 4,096 blocks.)
        let lengths = [
            QUIET_MIN_BLOCKS,
            2 * QUIET_MIN_BLOCKS,
            QUIET_BLOCKS / 2,
            QUIET_BLOCKS,
            2 * QUIET_BLOCKS,
            16 * QUIET_BLOCKS,
        ];
        for n in lengths {
            let short = short_of(n, dof, flag, 92 + u64::from(n));
            println!("{dof} dof, {n} blocks: {:.3} %", 100.0 * short);
            assert!(short <= 0.0008, "{dof} dof, {n} blocks: {short}");
        }
        // No history: the block's own share alone, nothing added.
        assert_eq!(short_of(0, dof, flag, 91), 0.0);
    }
}
