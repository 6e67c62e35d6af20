//! The array's reader following mains hum ([`dsp_core::hum`]): the
//! layout's view of it and each input's window. Out of the reader's module, and out of line, so that it runs
//! from flash: the boards' zero-wait RAM holds the per-block path
//! without it (`hot-ram.x`).

use crate::array::{BLOCK_INSTANTS, SHORT_INSTANTS};
use crate::array::{RATE_HZ, TONES};
use crate::reader::{BlockComb, INPUTS};
use crate::tones::Input;
use dsp_core::hum::{Fit, HumState, Mains};

/// The mains frequency the array follows hum at by default, Hz
/// ([`crate::reader::ArrayReader::for_mains`] for 60 Hz).
pub const MAINS_HZ: u32 = 50;

/// A layout's view of mains hum ([`dsp_core::hum`]), for either block
/// length.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub enum BlockMains {
    /// Blocks of [`BLOCK_INSTANTS`].
    Long(Mains<BLOCK_INSTANTS, TONES>),
    /// Blocks of [`SHORT_INSTANTS`].
    Short(Mains<SHORT_INSTANTS, TONES>),
}

impl BlockMains {
    /// What every block's fit reads.
    pub fn fit(&self) -> &Fit<TONES> {
        match self {
            Self::Long(m) => m.fit(),
            Self::Short(m) => m.fit(),
        }
    }

    /// Hum at `mains_hz` beside `comb`'s tones.
    #[inline(never)]
    pub fn new(comb: &BlockComb, mains_hz: u32) -> Self {
        match comb {
            BlockComb::Long(c) => Self::Long(Mains::new(mains_hz, RATE_HZ, c)),
            BlockComb::Short(c) => Self::Short(Mains::new(mains_hz, RATE_HZ, c)),
        }
    }
}

/// The hum the array follows: the layout's view of it and each input's
/// window (state beside configuration, as the reader's channels).
#[derive(Clone, Debug)]
pub(crate) struct Hum {
    pub(crate) mains: BlockMains,
    inputs: [HumState; INPUTS],
}

impl Hum {
    /// No block yet: hum at `mains_hz` beside `comb`'s tones.
    #[inline(never)]
    pub(crate) fn new(comb: &BlockComb, mains_hz: u32) -> Self {
        Self {
            mains: BlockMains::new(comb, mains_hz),
            inputs: [HumState::EMPTY; INPUTS],
        }
    }
}

/// Hum at `mains_hz` beside `comb`'s tones where `on`, else none. (Out
/// of line and off the per-block code: a reader calls it once.)
#[inline(never)]
pub(crate) fn following(on: bool, comb: &BlockComb, mains_hz: u32) -> Option<Hum> {
    on.then(|| Hum::new(comb, mains_hz))
}

/// Input `input`'s window emptied (its sensor not in use: nothing it
/// held would be this block's once the sensor is back).
#[inline(never)]
pub(crate) fn forget(hum: &mut Option<Hum>, input: usize) {
    if let Some(h) = hum.as_mut() {
        h.inputs[input] = HumState::EMPTY;
    }
}

/// Input `input`'s hum (`sums`: every input's [`Mains::sums`]) into its
/// state, and out of `into`'s levels where the window vouches for it,
/// its tones' noise gains then the window's; nothing without `hum`.
/// True where a hum was taken out.
#[inline(never)]
pub(crate) fn take_out(
    hum: &mut Option<Hum>,
    input: usize,
    sums: &[[i64; 2]; INPUTS],
    into: &mut Input<'_>,
    clean: f32,
) -> bool {
    let Some(h) = hum.as_mut() else { return false };
    let state = &mut h.inputs[input];
    if let Some((_, gains)) = h
        .mains
        .fit()
        .cancel(state, sums[input], into.tones, &mut into.levels, clean)
    {
        into.gains = gains;
        return true;
    }
    false
}
