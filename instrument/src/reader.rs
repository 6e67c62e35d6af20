//! Every sensor of the array from one block: the comb on the excitation
//! and on each sensor's input ([`dsp_core::comb`]), then each sensor's
//! two tones turned into a record ([`crate::tones`]).
//!
//! The board and QEMU keep a block differently (the board's five DMA
//! buffers, each with two halves; QEMU's one [`Frame`](crate::array::Frame)),
//! so the reader takes a block as a function from ADC to its rows. Two
//! steps, so that a firmware can demodulate while it holds the block and
//! solve after it let go: [`ArrayReader::demodulate`] reads the block,
//! [`ArrayReader::solve`] does not.

use crate::array::{
    adc_position, input_of, skew_rotation, Rows, BLOCK_INSTANTS, COMB, SENSORS, TONES, VOLTAGE_INPUT,
};
use crate::channel::Decimation;
use crate::sensor::Sensors;
use crate::tones::{Input, ToneChannel, ToneRecord, ToneSettings};
use dsp_core::comb::{Comb, CombError, Tones};
use dsp_core::Complex32;

/// A block demodulated: the comb's sums of the excitation and of every
/// sensor's input.
#[derive(Clone, Copy, Debug)]
pub struct Demodulated {
    /// The excitation (input [`VOLTAGE_INPUT`]).
    pub v: Tones<TONES>,
    /// Sensor s's current (input [`input_of`]`(s)`).
    pub i: [Tones<TONES>; SENSORS],
}

/// The array's demodulator and its sixteen channels.
#[derive(Clone, Debug)]
pub struct ArrayReader {
    comb: Comb<BLOCK_INSTANTS, TONES>,
    /// Each sensor's channel.
    pub channels: [ToneChannel; SENSORS],
    rotations: [[Complex32; TONES]; SENSORS],
    /// Which blocks are reported.
    reports: Decimation,
}

impl ArrayReader {
    /// Sixteen channels, each resting at its sensor's rest capacitance.
    pub fn new<const N: usize>(sensors: &Sensors<N, SENSORS>) -> Result<Self, CombError> {
        Ok(Self {
            comb: Comb::new(COMB)?,
            channels: core::array::from_fn(|s| ToneChannel::new(sensors.of(s as u8).rest_farad)),
            rotations: core::array::from_fn(skew_rotation),
            reports: Decimation::new(),
        })
    }

    /// The comb demodulator every input goes through.
    pub fn comb(&self) -> &Comb<BLOCK_INSTANTS, TONES> {
        &self.comb
    }

    /// The comb on the excitation and on every sensor's input; `rows(a)`
    /// is ADC a's rows of the block.
    pub fn demodulate<'a>(&self, rows: impl Fn(usize) -> &'a Rows) -> Demodulated {
        let column = |input: usize| {
            let (a, j) = adc_position(input);
            self.comb.column(rows(a), j)
        };
        Demodulated {
            v: column(VOLTAGE_INPUT),
            i: core::array::from_fn(|s| column(input_of(s))),
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
        let v = Input::of(&block.v);
        let v_clipped = clipped(VOLTAGE_INPUT);
        let report = self.reports.due(settings.record_every);
        for (s, ch) in self.channels.iter_mut().enumerate() {
            if !settings.sensors.of(s as u8).in_use {
                continue;
            }
            let rec = ch.process(
                settings,
                s as u8,
                t_us,
                &v,
                &Input::of(&block.i[s]),
                clipped(input_of(s)) || v_clipped,
                &self.rotations[s],
            );
            if report {
                record(rec);
            }
        }
    }

    /// [`ArrayReader::demodulate`] then [`ArrayReader::solve`], for a
    /// block whose rows are all at hand: `rows(a)` is ADC a's rows.
    pub fn read<'a, const N: usize>(
        &mut self,
        settings: &ToneSettings<'_, N>,
        t_us: u64,
        rows: impl Fn(usize) -> &'a Rows,
        clipped: impl Fn(usize) -> bool,
        record: impl FnMut(ToneRecord),
    ) {
        let block = self.demodulate(rows);
        self.solve(settings, t_us, &block, clipped, record);
    }
}
