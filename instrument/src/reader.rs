//! A block to its records, for either front end: the multiplexer's
//! channels ([`MuxReader`]: one sensor a slot, [`crate::channel`]) and
//! the array's ([`ArrayReader`]). The board and QEMU apps of each keep
//! only what moves their samples.
//!
//! The array reads every sensor from one block: the comb on the
//! excitation and on each sensor's input ([`dsp_core::comb`]), then each
//! sensor's two tones turned into a record ([`crate::tones`]).
//!
//! The board and QEMU keep a block differently (the board's five DMA
//! buffers, each with two halves; QEMU's one [`Frame`](crate::array::Frame)),
//! so the reader takes a block as a function from ADC to its rows (the
//! layout's [`Layout::instants`] of them: [`Layout::rows`]). Two
//! steps, so that a firmware can demodulate while it holds the block and
//! solve after it let go: [`ArrayReader::demodulate`] reads the block,
//! [`ArrayReader::solve`] does not.

use crate::array::{
    adc_position, input_of, Layout, BLOCK_INSTANTS, SCAN, SENSORS, SHORT_INSTANTS, TONES, VOLTAGE_INPUT,
};
use crate::channel::{Channel, Decimation, Record, Settings};
use crate::config::{Readings, CHANNELS};
use crate::faults::Flags;
use crate::mains::{BlockMains, Hum, MAINS_HZ};
use crate::sensor::Sensors;
use crate::sequencer::{Plan, Slot};
use crate::sideband::{Sidebands, Track};
use crate::tones::{Input, ToneChannel, ToneRecord, ToneSettings};
use dsp_core::comb::{Comb, CombError, Tones};
use dsp_core::hum::Mains;
use dsp_core::Complex32;

/// What became of a multiplexed slot's block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Read {
    /// Its record, to report.
    Report(Record),
    /// Measured (its channel's line and policy follow it), not reported:
    /// an empty socket, or a block between those the settings'
    /// `record_every` asks for.
    Quiet,
    /// Played at another frequency than its channel's policy now wants
    /// (the policy switched after the slot was planned): not measured;
    /// the next slot catches up.
    Skipped,
}

/// The multiplexer's channels, each following its sensor from slot to
/// slot: the multiplexed front end's reader.
#[derive(Clone, Debug)]
pub struct MuxReader {
    /// Each sensor's channel.
    pub channels: [Channel; CHANNELS],
}

impl MuxReader {
    /// Every channel free, resting at its sensor's rest capacitance.
    pub fn new<const N: usize, const S: usize>(sensors: &crate::sensor::Sensors<N, S>) -> Self {
        Self::with(|c| Channel::new(sensors.of(c).rest_farad))
    }

    /// Channel c as `channel(c)` makes it (pinned, for a recording at one
    /// frequency).
    pub fn with(channel: impl Fn(u8) -> Channel) -> Self {
        Self {
            channels: core::array::from_fn(|c| channel(c as u8)),
        }
    }

    /// What channel `c` wants for its next slot.
    pub fn plan(&self, c: u8) -> Plan {
        self.channels[usize::from(c) % CHANNELS].plan()
    }

    /// The record of `slot`'s block, read by the lock-ins as `readings`
    /// (`clipped`: an ADC sample hit a rail).
    pub fn read<const N: usize, const S: usize>(
        &mut self,
        settings: &Settings<'_, N, S>,
        slot: &Slot,
        readings: &Readings,
        clipped: bool,
    ) -> Read {
        let Some(channel) = self.channels.get_mut(usize::from(slot.channel)) else {
            return Read::Skipped;
        };
        if channel.fidx() != slot.fidx {
            return Read::Skipped;
        }
        let t_us = slot.block_mid_us();
        let rec = channel.process(settings, slot.channel, t_us, readings, clipped, slot.range);
        let due = channel.due(settings.record_every);
        if due && settings.sensors.of(slot.channel).in_use {
            Read::Report(rec)
        } else {
            Read::Quiet
        }
    }
}

/// A block demodulated: the comb's sums of the excitation and of every
/// sensor's input.
#[derive(Clone, Copy, Debug)]
pub struct Demodulated {
    /// The excitation (input [`VOLTAGE_INPUT`]).
    pub v: Tones<TONES>,
    /// Sensor s's current (input [`input_of`]`(s)`).
    pub i: [Tones<TONES>; SENSORS],
    /// Each input's hum sums ([`Mains::sums`]), by input: [`VOLTAGE_INPUT`]
    /// and [`input_of`]`(s)` (zero where the reader follows no hum).
    pub hum: [[i64; 2]; INPUTS],
    /// Sensor s's sums against the sideband the reader fits, where its
    /// channel avoids that tone ([`crate::sideband`]; zero elsewhere).
    pub sideband: [[i64; 2]; SENSORS],
    /// The tone of that sideband ([`NO_TONE`]: none this block).
    pub sideband_tone: u8,
}

/// [`Demodulated::sideband`]'s "no tone".
pub const NO_TONE: u8 = u8::MAX;

/// The array's inputs: the excitation and every sensor's current.
pub const INPUTS: usize = SENSORS + 1;

impl Demodulated {
    /// No block yet: every input empty (read as no excitation).
    pub const EMPTY: Self = Self {
        v: Tones::EMPTY,
        i: [Tones::EMPTY; SENSORS],
        hum: [[0; 2]; INPUTS],
        sideband: [[0; 2]; SENSORS],
        sideband_tone: NO_TONE,
    };
}

/// The comb demodulator of a layout's blocks (4 KiB for 4 ms blocks,
/// 1 KiB for 1 ms: the reader is as large as the longer either way).
#[derive(Clone, Debug)]
// No heap to box the longer one in: a firmware keeps its one reader in
// place, sized for either layout.
#[allow(clippy::large_enum_variant)]
pub enum BlockComb {
    /// Blocks of [`BLOCK_INSTANTS`] ([`Layout::BLOCK_4MS`]).
    Long(Comb<BLOCK_INSTANTS, TONES>),
    /// Blocks of [`SHORT_INSTANTS`] ([`Layout::BLOCK_1MS`]).
    Short(Comb<SHORT_INSTANTS, TONES>),
}

impl BlockComb {
    /// The comb of `layout`'s blocks.
    pub fn new(layout: &Layout) -> Result<Self, CombError> {
        Ok(if layout.instants() == SHORT_INSTANTS {
            Self::Short(Comb::new(layout.comb())?)
        } else {
            Self::Long(Comb::new(layout.comb())?)
        })
    }

    /// Demodulate input `col` of a block's rows ([`Comb::column`]): an
    /// empty result (`n` = 0, so no excitation) unless `rows` holds at
    /// least a block.
    #[inline]
    pub fn column(&self, rows: &[[i16; SCAN]], col: usize) -> Tones<TONES> {
        match self {
            Self::Long(c) => {
                if let Some(r) = rows.first_chunk() {
                    return c.column(r, col);
                }
            }
            Self::Short(c) => {
                if let Some(r) = rows.first_chunk() {
                    return c.column(r, col);
                }
            }
        }
        Tones::EMPTY
    }
}

/// Every input's comb in blocks of N instants, into `out`
/// ([`ArrayReader::demodulate_into`]).
fn demodulate_with<'a, const N: usize>(
    comb: &Comb<N, TONES>,
    mains: Option<&Mains<N, TONES>>,
    rows: impl Fn(usize) -> &'a [[i16; SCAN]],
    out: &mut Demodulated,
) {
    // In place: a result returned is copied on its way (~100
    // instructions an input on the Cortex-M4).
    let column = |input: usize, out: &mut Tones<TONES>, hum: &mut [[i64; 2]; INPUTS]| {
        let (a, j) = adc_position(input);
        match rows(a).first_chunk::<N>() {
            Some(r) => {
                comb.column_into(r, j, out);
                hum[input] = mains.map_or([0; 2], |m| m.sums(r, j));
            }
            None => *out = Tones::EMPTY,
        }
    };
    column(VOLTAGE_INPUT, &mut out.v, &mut out.hum);
    for (s, i) in out.i.iter_mut().enumerate() {
        column(input_of(s), i, &mut out.hum);
    }
}

/// The array's demodulator and its sixteen channels.
#[derive(Clone, Debug)]
pub struct ArrayReader {
    comb: BlockComb,
    hum: Option<Hum>,
    sidebands: Sidebands,
    /// Each sensor's sideband from block to block.
    tracks: [Track; SENSORS],
    layout: Layout,
    /// Each sensor's channel.
    pub channels: [ToneChannel; SENSORS],
    rotations: [[Complex32; TONES]; SENSORS],
    /// The self-test's reference input's rotation.
    reference_rotation: [Complex32; TONES],
    /// Which blocks are reported.
    reports: Decimation,
    /// Sensors whose records the power-up self-test refused, one bit
    /// each ([`crate::selftest::Outcome::refused`]).
    refused: u16,
}

impl ArrayReader {
    /// Sixteen channels, each resting at its sensor's rest capacitance,
    /// reading blocks of `layout` (the same as the settings' given to
    /// [`ArrayReader::solve`]).
    ///
    /// Mains hum is followed at [`MAINS_HZ`] in 4 ms blocks; not in 1 ms
    /// blocks, whose four times the blocks' hum fits would take the
    /// board past its core (the cycle model's 1 ms block: 1.3 ms with
    /// it, 0.82 without).
    pub fn new<const N: usize>(layout: Layout, sensors: &Sensors<N, SENSORS>) -> Result<Self, CombError> {
        Self::for_mains(layout, sensors, MAINS_HZ)
    }

    /// [`ArrayReader::new`] where the mains run at `mains_hz` (50 or 60).
    pub fn for_mains<const N: usize>(
        layout: Layout,
        sensors: &Sensors<N, SENSORS>,
        mains_hz: u32,
    ) -> Result<Self, CombError> {
        let mut reader = Self::with_mains(layout, sensors, None);
        if let Ok(r) = reader.as_mut() {
            r.follow_mains(mains_hz);
        }
        reader
    }

    /// Follow mains hum at `mains_hz` (50 or 60) from the next block, in
    /// 4 ms blocks (none in 1 ms blocks: [`ArrayReader::new`]). For a
    /// reader built where it stays: the hum's constants are laid out in
    /// this call's frame, not beside a reader being built.
    #[inline]
    pub fn follow_mains(&mut self, mains_hz: u32) {
        let on = self.layout.instants() == BLOCK_INSTANTS;
        self.hum = crate::mains::following(on, &self.comb, mains_hz);
    }

    /// [`ArrayReader::new`] following mains hum at `mains_hz` (None:
    /// none; [`dsp_core::hum`]).
    pub fn with_mains<const N: usize>(
        layout: Layout,
        sensors: &Sensors<N, SENSORS>,
        mains_hz: Option<u32>,
    ) -> Result<Self, CombError> {
        let comb = BlockComb::new(&layout)?;
        Ok(Self {
            hum: mains_hz.map(|hz| Hum::new(&comb, hz)),
            sidebands: Sidebands::new(layout),
            tracks: [Track::NEW; SENSORS],
            comb,
            layout,
            channels: core::array::from_fn(|s| ToneChannel::new(sensors.of(s as u8).rest_farad)),
            rotations: core::array::from_fn(|s| layout.input_rotation(input_of(s))),
            reference_rotation: layout.input_rotation(crate::array::REFERENCE_INPUT),
            reports: Decimation::new(),
            refused: 0,
        })
    }

    /// Refuse the records of the sensors whose bits `sensors` sets (the
    /// power-up self-test's [`crate::selftest::Outcome::refused`]): they
    /// are measured and flagged [`Flags::SELF_TEST`].
    pub fn refuse(&mut self, sensors: u16) {
        self.refused = sensors;
    }

    /// The factor that takes the self-test's reference input's scan
    /// skew out of its V/I ([`Layout::input_rotation`]).
    pub fn reference_rotation(&self) -> &[Complex32; TONES] {
        &self.reference_rotation
    }

    /// The comb on the self-test's reference input
    /// ([`crate::array::REFERENCE_INPUT`]) of a block: `rows(a)` as
    /// [`ArrayReader::demodulate`]'s.
    pub fn reference<'a>(&self, rows: impl Fn(usize) -> &'a [[i16; SCAN]]) -> Tones<TONES> {
        let (a, j) = adc_position(crate::array::REFERENCE_INPUT);
        let mut out = Tones::EMPTY;
        // The demodulation every input goes through (`column_into`):
        // one more instance of the comb's unrolled sums would cost the
        // board's flash 26 KiB.
        match &self.comb {
            BlockComb::Long(c) => {
                if let Some(r) = rows(a).first_chunk() {
                    c.column_into(r, j, &mut out);
                }
            }
            BlockComb::Short(c) => {
                if let Some(r) = rows(a).first_chunk() {
                    c.column_into(r, j, &mut out);
                }
            }
        }
        out
    }

    /// The comb demodulator every input goes through.
    pub fn comb(&self) -> &BlockComb {
        &self.comb
    }

    /// The layout of the blocks it reads.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The comb on the excitation and on every sensor's input; `rows(a)`
    /// is ADC a's rows of the block ([`Layout::rows`]; an input whose
    /// rows are short of a block reads as no excitation).
    pub fn demodulate<'a>(&self, rows: impl Fn(usize) -> &'a [[i16; SCAN]]) -> Demodulated {
        let mut out = Demodulated::EMPTY;
        self.demodulate_into(rows, &mut out);
        out
    }

    /// [`ArrayReader::demodulate`] into a block the firmware keeps (1.7
    /// KiB: returned, it is copied whole on its way).
    pub fn demodulate_into<'a>(&self, rows: impl Fn(usize) -> &'a [[i16; SCAN]], out: &mut Demodulated) {
        // One match a block, the comb's length known in each arm.
        let mains = self.hum.as_ref().map(|h| &h.mains);
        match (&self.comb, mains) {
            (BlockComb::Long(c), Some(BlockMains::Long(m))) => demodulate_with(c, Some(m), &rows, out),
            (BlockComb::Short(c), Some(BlockMains::Short(m))) => demodulate_with(c, Some(m), &rows, out),
            (BlockComb::Long(c), _) => demodulate_with(c, None, &rows, out),
            (BlockComb::Short(c), _) => demodulate_with(c, None, &rows, out),
        }
        self.sideband_sums(rows, out);
    }

    /// Each sensor's sums against the sideband the reader fits, where
    /// its channel avoids that tone, into `out` (4 ms blocks; where none
    /// is fitted, the common case, one test in the per-block code and
    /// the rest out of it).
    fn sideband_sums<'a>(&self, rows: impl Fn(usize) -> &'a [[i16; SCAN]], out: &mut Demodulated) {
        out.sideband_tone = NO_TONE;
        if let Some(k) = self.sidebands.tone() {
            out.sideband_tone = k as u8;
            let avoided = |s: usize| self.channels.get(s).and_then(ToneChannel::avoided);
            self.sidebands.sums_into(k, avoided, rows, &mut out.sideband);
        }
    }

    /// Every sensor's record of the block whose middle is at `t_us`, in
    /// sensor order, to `record` (sensors not in use give none; and
    /// only one block in every `settings.record_every` is reported, the
    /// first included: the others are solved all the same);
    /// `clipped(input)` says an ADC result of that input hit a rail.
    pub fn solve<const N: usize>(
        &mut self,
        settings: &ToneSettings<'_, N>,
        t_us: u64,
        block: &Demodulated,
        clipped: impl Fn(usize) -> bool,
        mut record: impl FnMut(ToneRecord),
    ) {
        let clean = settings.thresholds.residual_counts;
        let mut v = Input::of(&block.v);
        crate::mains::take_out(&mut self.hum, VOLTAGE_INPUT, &block.hum, &mut v, clean);
        let v_clipped = clipped(VOLTAGE_INPUT);
        let report = self.reports.due(settings.record_every);
        for (s, ch) in self.channels.iter_mut().enumerate() {
            if !settings.sensors.of(s as u8).in_use {
                // Its hum not followed: a sensor put in use again starts
                // its window afresh.
                crate::mains::forget(&mut self.hum, input_of(s));
                continue;
            }
            let mut i = Input::of(&block.i[s]);
            let hummed = crate::mains::take_out(&mut self.hum, input_of(s), &block.hum, &mut i, clean);
            // The sideband of the tone the channel avoids, where no hum
            // was taken out. Without a sideband fitted, one test
            // (`follow` emptied every history when it dropped the last).
            if block.sideband_tone != NO_TONE {
                let fitted = (ch.avoided() == Some(usize::from(block.sideband_tone)) && !hummed)
                    .then_some(block.sideband[s]);
                self.sidebands
                    .take_out(fitted, block.sideband_tone, &mut self.tracks[s], &mut i, clean);
            }
            let mut rec = ch.process(
                settings,
                s as u8,
                t_us,
                &v,
                &i,
                clipped(input_of(s)) || v_clipped,
                &self.rotations[s],
            );
            if self.refused & 1 << s != 0 {
                rec.flags.set(Flags::SELF_TEST);
            }
            if report {
                record(rec);
            }
        }
        // The sideband the next block fits: the tone the channels now
        // avoid (a call only where one is fitted or a channel avoids a
        // tone: never in 1 ms blocks, whose channels do not move).
        let channels = &self.channels;
        if self.sidebands.tone().is_some() || channels.iter().any(|c| c.avoided().is_some()) {
            self.sidebands.follow(
                &self.comb,
                channels.iter().map(ToneChannel::avoided),
                &mut self.tracks,
            );
        }
    }

    /// [`ArrayReader::demodulate`] then [`ArrayReader::solve`], for a
    /// block whose rows are all at hand: `rows(a)` is ADC a's rows.
    pub fn read<'a, const N: usize>(
        &mut self,
        settings: &ToneSettings<'_, N>,
        t_us: u64,
        rows: impl Fn(usize) -> &'a [[i16; SCAN]],
        clipped: impl Fn(usize) -> bool,
        record: impl FnMut(ToneRecord),
    ) {
        let mut block = Demodulated::EMPTY;
        self.demodulate_into(rows, &mut block);
        self.solve(settings, t_us, &block, clipped, record);
    }
}

#[cfg(test)]
mod tests {
    use crate::array::Layout;

    /// The comb is laid out for every block length the layouts name.
    #[test]
    fn every_layout_has_its_comb() {
        for layout in Layout::ALL {
            assert!(super::BlockComb::new(&layout).is_ok(), "{layout:?}");
        }
    }
}
