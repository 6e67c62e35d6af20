//! What an interferer near a tone of the comb does to every tone a
//! record fits at once: its spread ([`dsp_core::twotone::Spread`]),
//! what a bound on one disturbance takes
//! ([`dsp_core::twotone::bound_along`]). Not yet in the channels: taken
//! in every record it closes the hole of docs/accuracy.md, but costs
//! five times a record's cycles.
//!
//! A sinusoid on an input adds δXₖ to each tone's phasor Xₖ by its bin's
//! kernel ([`skin_spec::leak`]); to first order tone k's impedance
//! Z = k·V/I moves by Zₖ·δVₖ/Vₖ on the voltage's input and by
//! −Zₖ·δIₖ/Iₖ on the current's. Every frequency of
//! [`skin_spec::leak::NU`] within half a bin of a fitted tone, on each
//! input, is one spread: what the residual cannot see of a sinusoid
//! there hides in the bins, and an error spread over several tones can
//! hide more behind χ² than an error at one (docs/accuracy.md). Only
//! for the 4 ms comb, whose kernels these are.

use dsp_core::comb::Levels;
use dsp_core::twotone::Spread;
use dsp_core::Complex32;
use skin_spec::array::TONES;
use skin_spec::leak::{KERNEL, NEAR, POINTS, SEEN};

/// One input's factors of a record's spreads: ±Zₖ·2³¹·N/(2·Xₖ) for each
/// of the `fitted` comb tones (impedances `z`, Ω; phasors Xₖ of
/// `levels`, Q31·counts, over N instants), + on the voltage's input, −
/// (`current`) on the current's: a kernel times it is tone k's change,
/// Ω per count of the sinusoid's amplitude. A tone without a phasor
/// gives NaN, which no bound vouches for.
pub fn factors(
    levels: &Levels<TONES>,
    current: bool,
    z: &[Complex32; 3],
    fitted: &[usize; 3],
) -> [Complex32; 3] {
    let phasor = |k: usize| levels.phasor.get(k).copied().unwrap_or_default();
    let sign = if current { -1.0 } else { 1.0 };
    let scale = sign * 1_073_741_824.0 * skin_spec::array::BLOCK_INSTANTS as f32;
    core::array::from_fn(|j| z[j] * scale / phasor(fitted[j]))
}

/// The spread over the `fitted` tones of a sinusoid at
/// [`skin_spec::leak::NU`]`[point]` on the input of `factors`.
pub fn spread_at(factors: &[Complex32; 3], fitted: &[usize; 3], point: usize) -> Spread<3> {
    core::array::from_fn(|j| {
        let kernel = KERNEL
            .get(point)
            .and_then(|k| k.get(fitted[j]))
            .copied()
            .unwrap_or_default();
        [factors[j] * kernel[0], factors[j] * kernel[1]]
    })
}

/// Every spread of a record, each with the most its amplitude can be
/// (counts): for each frequency of [`skin_spec::leak::NU`] within half a
/// bin of one of the `fitted` tones, on the voltage's input `v`, then on
/// the current's `i`; `excess` each input's residual beyond its noise
/// (counts rms, as large as the noise may hide), of which a sinusoid
/// there keeps at least [`SEEN`]: √2·excess/`SEEN`.
pub fn spreads<'a>(
    v: &'a Levels<TONES>,
    i: &'a Levels<TONES>,
    excess: [f32; 2],
    z: [Complex32; 3],
    fitted: [usize; 3],
) -> impl Iterator<Item = (Spread<3>, f32)> + 'a {
    let inputs = [factors(v, false, &z, &fitted), factors(i, true, &z, &fitted)];
    let mask = fitted.iter().fold(0u8, |m, &k| m | (1u8 << k.min(7)));
    (0..POINTS)
        .filter(move |&p| NEAR[p] & mask != 0)
        .flat_map(move |p| {
            let most = excess.map(|e| core::f32::consts::SQRT_2 * e / SEEN[p]);
            [0, 1].map(|input| (spread_at(&inputs[input], &fitted, p), most[input]))
        })
}
