//! A tone's sideband, fitted beside a comb so that an interferer a
//! fraction of a bin off that tone stops leaking into the others.
//!
//! A sinusoid δ of a bin off tone k (δ within ±½) is, over a block,
//! tone k's own frequency with a phase that turns by 2π·δ across it:
//!
//! ```text
//! A·e^(j(θₖ + 2πδ/N)·n) = A·e^(jθₖn)·(1 + j·πδ·(1 + tₙ) + O(δ²)),   tₙ = (2n − (N − 1))/N
//! ```
//!
//! The constant term is tone k's (the comb fits it); the ramp tₙ·e^(jθₖn),
//! the sideband, is what the comb's other tones and its residual see:
//! the leak. Fitted as two more basis functions (tₙ·cos θₖn, tₙ·sin θₖn,
//! within the block alone: [`crate::hum`]'s fit with no window), it is
//! taken out of the other tones' sums and of the residual; the leak left
//! is of order δ², a fraction of the sideband's own size that grows with
//! |δ| (the layout bounds it: `skin_spec::array::Layout::sideband_leak`).
//! In 4 ms blocks an interferer 20 Hz off the 500 Hz tone leaks 9.9 % of
//! its amplitude into the 250 Hz tone and 1.8 % with its sideband
//! fitted.
//!
//! The price is the fit's: the tones that overlap the sideband carry
//! more noise (the factor [`crate::hum::Fit::cancel`] returns; 1.9 for
//! the 250 Hz tone beside the 500 Hz sideband, 1.04–1.08 for the others),
//! and tone k's own sum is no measurement any more. So it is for a
//! channel that has left tone k already (`instrument::avoid`).

use crate::comb::Comb;
use crate::hum::{q15, Mains};

/// Tone k's sideband beside a comb of K tones in blocks of N instants:
/// its basis, Q15, and the fit every block makes of it (configuration).
#[derive(Clone, Debug, PartialEq)]
pub struct Sideband<const N: usize, const K: usize> {
    basis: Mains<N, K>,
}

impl<const N: usize, const K: usize> Sideband<N, K> {
    /// Tone `k` of `comb`'s sideband: its reference words (Q31) times tₙ,
    /// rounded to Q15. None without tone `k`.
    pub fn new(k: usize, comb: &Comb<N, K>) -> Option<Self> {
        let tone = comb.reference(k)?;
        let span = N as i64;
        let mut words = [[0i16; 2]; N];
        for ((w, t), n) in words.iter_mut().zip(tone).zip(0i64..) {
            // |word·(2n − N + 1)/N| < 2³¹: a Q31 word again.
            let ramp = 2 * n - (span - 1);
            *w = t.map(|v| q15(((v as i64 * ramp) / span) as i32));
        }
        Some(Self {
            basis: Mains::from_words(words, comb, [1.0, 0.0], 0.0),
        })
    }

    /// Take the block's sideband (`sums`: [`Sideband::sums`] of the input
    /// whose comb gave `tones` and `levels`) out of `levels` where it
    /// stands out of the noise it leaves (χ² above
    /// [`crate::hum::SIGNIFICANT`]) and leaves less than the block had:
    /// [`crate::hum::Fit::cancel`] on this block alone. Returns the
    /// sideband taken out, p (counts per unit of the basis), and each
    /// tone's noise gain; None where none was (`levels` untouched).
    #[inline(never)]
    pub fn cancel(
        &self,
        sums: [i64; 2],
        tones: &crate::comb::Tones<K>,
        levels: &mut crate::comb::Levels<K>,
        clean_counts: f32,
    ) -> Option<([f32; 2], [f32; K])> {
        let mut state = crate::hum::HumState::EMPTY;
        self.basis
            .fit()
            .cancel(&mut state, sums, tones, levels, clean_counts)
    }

    /// The most one block's sideband p can be off by, per unit of the
    /// block's noise σ ([`crate::hum::Fit::spread`]).
    pub fn spread(&self) -> f32 {
        self.basis.fit().spread()
    }

    /// Σₙ xₙ·b₀ₙ and Σₙ xₙ·b₁ₙ of input `col` of a block's rows (Q31 ·
    /// counts), as [`Mains::sums`] (the same dual products on the
    /// Cortex-M4).
    #[inline(never)]
    pub fn sums<const S: usize>(&self, rows: &[[i16; S]; N], col: usize) -> [i64; 2] {
        self.basis.sums(rows, col)
    }
}

#[cfg(test)]
mod tests;
