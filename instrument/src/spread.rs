//! What an interferer near a tone of the comb does to every tone a
//! record fits at once: its spread ([`dsp_core::twotone::Spread`]),
//! what a bound on one disturbance takes
//! ([`dsp_core::twotone::bound_along`]), taken in every record of the
//! 4 ms comb that fits three tones, but those rescued from two or moved
//! off a tone ([`of_record`]; a moved channel's interferer is a known
//! one, bounded by its sideband's leak, and its residual would pass for
//! an unknown one besides).
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

use crate::sensor::Sensor;
use dsp_core::comb::Levels;
use dsp_core::dielectric::Dielectric;
use dsp_core::fixture::Fixture;
use dsp_core::spread::{Along, Reach};
use dsp_core::twotone::{Solution, Spread, Tone};
use dsp_core::Complex32;
use skin_spec::array::TONES;
use skin_spec::leak::{self, POINTS};

// In memory once, read where they lie (a `const` may be built again
// where it is used).
static KERNEL: [[[Complex32; 2]; TONES]; POINTS] = leak::KERNEL;
static NEAR: [u8; POINTS] = leak::NEAR;
static SEEN: [f32; POINTS] = leak::SEEN;

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
    let kernel = kernel_at(point, fitted);
    core::array::from_fn(|j| [factors[j] * kernel[j][0], factors[j] * kernel[j][1]])
}

/// The kernels of a sinusoid at [`skin_spec::leak::NU`]`[point]` in each
/// of the `fitted` tones' bins (0 past the table's ends).
fn kernel_at(point: usize, fitted: &[usize; 3]) -> [[Complex32; 2]; 3] {
    core::array::from_fn(|j| {
        KERNEL
            .get(point)
            .and_then(|k| k.get(fitted[j]))
            .copied()
            .unwrap_or_default()
    })
}

/// What one sinusoid near a record's `fitted` tones could hide in its
/// line `sol` beyond what an error at one tone hides ([`bound`]):
/// `inputs` the voltage's and the current's levels, `excess` their
/// residuals beyond the noise (counts rms), `tones` as measured, on
/// `sensor` (its wiring and line model) and the film `film`; `share`
/// and `room` as [`bound`]'s. The line's reach is taken afresh at its
/// line behind the wiring (one evaluation of the model). (Out of line,
/// in flash on a board: the fast RAM holds the record's own path.)
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub fn of_record<const N: usize>(
    inputs: &[&Levels<TONES>; 2],
    excess: [f32; 2],
    tones: &[Tone; 3],
    sensor: &Sensor<N>,
    film: &Dielectric,
    fitted: [usize; 3],
    sol: &Solution,
    share: f32,
    room: f32,
) -> f32 {
    // The tones behind the wiring, as the line was fitted to them (the
    // line was solved from them, so none fails; one that did would give
    // NaN, which no bound vouches for).
    let fixture = &sensor.fixture;
    let behind = fixture.behind(tones).unwrap_or_else(|_| {
        tones.map(|t| Tone {
            z: Complex32::new(f32::NAN, f32::NAN),
            ..t
        })
    });
    let reach = dsp_core::spread::reach(sensor.tracker.inverter(), film, &behind, sol);
    let one_tone = sol.hidden_ln_c * share;
    let [v, i] = *inputs;
    bound(
        v, i, excess, tones, &behind, fixture, fitted, &reach, share, one_tone, room,
    )
}

/// The most ln C of a record's line can be off where one sinusoid
/// within half a bin of one of its `fitted` comb tones, on the voltage's
/// input `v` or on the current's `i`, spreads over them: for each
/// frequency of [`skin_spec::leak::NU`] near one and each input, the
/// spread's bound by the line's `reach` ([`Along::bound_above`]) with `share`
/// of the residual (√χ², as [`crate::joint::hidden`]'s) and an
/// amplitude of at most √2·`excess`/[`leak::SEEN`] (`excess` each input's
/// residual beyond its noise, counts rms, as large as the noise may
/// hide); the worst. `tones` are the fitted tones as measured (Ω),
/// before the sensor's `fixture` is taken out, whose slope
/// ([`Fixture::slope`]) carries each tone's change to the line behind
/// it, in units of the σ it has there (`behind`'s, the tones the line
/// was fitted to). The search keeps to spreads beyond `floor` (a bound known
/// already: where none is, the result is at most `floor`), and the first
/// beyond `room` ends it (its bound is returned).
#[allow(clippy::too_many_arguments)]
pub fn bound(
    v: &Levels<TONES>,
    i: &Levels<TONES>,
    excess: [f32; 2],
    tones: &[Tone; 3],
    behind: &[Tone; 3],
    fixture: &Fixture,
    fitted: [usize; 3],
    reach: &Reach,
    share: f32,
    floor: f32,
    room: f32,
) -> f32 {
    let z = tones.map(|t| t.z);
    let per_sigma: [Complex32; 3] =
        core::array::from_fn(|k| fixture.slope(z[k], tones[k].f_hz) / behind[k].sigma_ohm);
    let weigh = |f: [Complex32; 3]| -> [Complex32; 3] { core::array::from_fn(|k| f[k] * per_sigma[k]) };
    let along: [Along; 2] = [
        reach.along(&weigh(factors(v, false, &z, &fitted))),
        reach.along(&weigh(factors(i, true, &z, &fitted))),
    ];
    let mask = fitted.iter().fold(0u8, |m, &k| m | (1u8 << k.min(7)));
    let mut worst = floor;
    for p in 0..POINTS {
        if NEAR[p] & mask == 0 {
            continue;
        }
        let kernel = kernel_at(p, &fitted);
        for (along, e) in along.iter().zip(excess) {
            let most = core::f32::consts::SQRT_2 * e / SEEN[p];
            let b = along.bound_above(&kernel, share, most, worst);
            // (NaN stays, and ends the search.)
            if b > worst || b.is_nan() {
                worst = b;
                if worst > room || worst.is_nan() {
                    return worst;
                }
            }
        }
    }
    worst
}
