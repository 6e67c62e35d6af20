//! The array's power-up self-test: before the skin is measured, every
//! path from the excitation to the ADCs is read for [`DURATION_US`] and
//! held to what the firmware's constants assume.
//!
//! The board carries a reference network of known parts on a spare input
//! ([`REFERENCE_INPUT`]: [`REFERENCE_OHM`] in series with
//! [`REFERENCE_FARAD`], C0G, to a stage laid out as the sensors' are).
//! Its impedance, read as any sensor's is (k·V/I with the firmware's k
//! and the scan skew taken out), checks the whole chain a record rests
//! on: the excitation, the voltage path, a transimpedance stage, two of
//! the five ADCs. The checks, each path an ADC input:
//!
//! | check | path | against | a failure means |
//! |---|---|---|---|
//! | on a rail | every one | no result within [`crate::array::RAIL_MARGIN`] of a rail | a stage open loop (its R_f missing), a short to a supply |
//! | offset | every one | the block's mean within [`Limits::offset_counts`] of the bias | leakage at a stage's input, a bridge, a wrong bias |
//! | excitation | 0 | each tone's amplitude within [`Limits::excitation`] of [`Layout::tone_volts`] | the DAC, its filter or the buffer not as designed |
//! | impedance | the reference's | |Z| within [`Limits::gain`] and its phase within [`Limits::phase_rad`] of R + 1/(jωC) at every tone | a gain or delay the firmware's k does not have: a wrong part on a path, or the reference's own |
//! | noise | every one | the residual rms within [`Limits::noise`] times [`NOISE_COUNTS`] | hum or an interferer at power-up, a noisy stage: reported only |
//!
//! A record rests on the excitation's path, the reference's check of the
//! chain and its own sensor's path: if either of the first two fails,
//! every sensor's records are refused (flagged
//! [`Flags::SELF_TEST`](crate::faults::Flags::SELF_TEST)), else those of
//! the sensors whose own path failed. Noise refuses nothing: each
//! record's residual check judges its own block. A sensor's own gain is
//! not checked (its sensor is unknown); the reference's stage stands for
//! the sixteen, whose parts are the same.
//!
//! **Limits.** The reference's parts alone move |Z| by at most 0.94 %
//! and its phase by 5.0 mrad (1 % of C at the tone where ωRC = 1, the
//! worst; 0.1 % of R); a stage's 2.7 pF ± 0.05 pF moves the phase by
//! 0.7 mrad at 4 kHz. [`Limits::DEFAULT`] allows 1.5 % and 10 mrad:
//! the parts' worst and a margin for the two ADCs' gains, while a
//! wrong part (an E6 step is 20 % or more; a missing feedback capacitor
//! 22 mrad at 4 kHz) fails.

use crate::array::{
    Layout, HALF_SCALE, NOISE_COUNTS, REFERENCE_FARAD, REFERENCE_INPUT, REFERENCE_OHM, SENSORS, TONES,
    VOLTAGE_INPUT,
};
use crate::reader::Demodulated;
use dsp_core::comb::Tones;
use dsp_core::demod::FrontEnd;
use dsp_core::fmath::i64_to_f32;
use dsp_core::Complex32;
use link::Verdict;

/// Paths checked: ADC inputs 0 (the excitation) to [`REFERENCE_INPUT`].
pub const PATHS: usize = REFERENCE_INPUT + 1;

/// How long the test measures, µs: 25 blocks of 4 ms, 100 of 1 ms.
pub const DURATION_US: u64 = 100_000;

/// What a path may be off by and pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// The reference's |Z| against the nominal, relative.
    pub gain: f32,
    /// The reference's phase against the nominal, rad.
    pub phase_rad: f32,
    /// Each excitation tone's amplitude against the design, relative.
    pub excitation: f32,
    /// A path's mean against the bias, counts (1 000: 50 mV, ten times
    /// the op-amps' largest offset).
    pub offset_counts: f32,
    /// A path's residual rms over [`NOISE_COUNTS`] above which it is
    /// reported noisy: the records' own threshold (6.4 counts, 2.1×).
    pub noise: f32,
}

impl Limits {
    /// The limits of the module's docs.
    pub const DEFAULT: Self = Self {
        gain: 0.015,
        phase_rad: 0.010,
        excitation: 0.03,
        offset_counts: 1000.0,
        noise: crate::faults::Thresholds::ARRAY.residual_counts / NOISE_COUNTS,
    };
}

/// The test under way: its sums over the blocks read so far.
#[derive(Clone, Debug)]
pub struct SelfTest {
    layout: Layout,
    blocks: u32,
    /// Σ of the excitation's phasors (Q31 · counts, f32).
    v: [Complex32; TONES],
    /// Σ of the reference's current phasors.
    i: [Complex32; TONES],
    /// Σ of each path's block mean, counts.
    mean: [f32; PATHS],
    /// Σ of each path's residual variance (its degrees of freedom's),
    /// counts².
    var: [f32; PATHS],
    /// Paths with a result on a rail, one bit each.
    rails: u32,
}

impl SelfTest {
    /// A test of blocks of `layout`.
    pub fn new(layout: Layout) -> Self {
        Self {
            layout,
            blocks: 0,
            v: [Complex32::new(0.0, 0.0); TONES],
            i: [Complex32::new(0.0, 0.0); TONES],
            mean: [0.0; PATHS],
            var: [0.0; PATHS],
            rails: 0,
        }
    }

    /// Blocks the test reads.
    pub fn blocks_needed(&self) -> u32 {
        (DURATION_US / self.layout.block_us()) as u32
    }

    /// Has it read them all?
    pub fn done(&self) -> bool {
        self.blocks >= self.blocks_needed()
    }

    /// One block: every sensor's and the excitation's sums as the reader
    /// demodulated them, the reference's (`reference`, input
    /// [`REFERENCE_INPUT`]) and which inputs hit a rail (`rail(input)`).
    pub fn add(&mut self, block: &Demodulated, reference: &Tones<TONES>, rail: impl Fn(usize) -> bool) {
        for p in 0..PATHS {
            let tones = match p {
                VOLTAGE_INPUT => &block.v,
                REFERENCE_INPUT => reference,
                s => &block.i[(s - 1).min(SENSORS - 1)],
            };
            self.add_path(p, tones, rail(p));
        }
        self.blocks += 1;
    }

    fn add_path(&mut self, p: usize, tones: &Tones<TONES>, rail: bool) {
        if rail {
            self.rails |= 1 << p;
        }
        let sums = match p {
            VOLTAGE_INPUT => Some(&mut self.v),
            REFERENCE_INPUT => Some(&mut self.i),
            _ => None,
        };
        if let Some(sums) = sums {
            // The phasors in f32 as the records' levels convert them
            // (not `Tones::levels`: a second copy of it in flash).
            for (s, x) in sums.iter_mut().zip(&tones.x) {
                *s += Complex32::new(i64_to_f32(x.re), i64_to_f32(x.im));
            }
        }
        let n = tones.n.max(1) as f32;
        self.mean[p] += tones.sum as f32 / n;
        // Not `residual_rms`: a second caller would take it out of line,
        // and out of the records' per-block code in the board's fast RAM.
        let r = dsp_core::comb::root_over(tones.residual_n_energy(), 0, tones.n.max(1));
        self.var[p] += r * r * n / self.layout.residual_dof() as f32;
    }

    /// The verdict on the blocks read, with `front_end`'s k (the one
    /// the records use), the reference's scan skew taken out by
    /// `rotation` ([`crate::reader::ArrayReader::reference_rotation`])
    /// and `limits`.
    pub fn outcome(&self, front_end: &FrontEnd, rotation: &[Complex32; TONES], limits: &Limits) -> Outcome {
        let mut out = Outcome::EMPTY;
        for p in 0..PATHS {
            self.path(p, limits, &mut out);
        }
        out.excitation = self.excitation_error();
        (out.gain, out.phase_rad) = self.reference_error(front_end, rotation);
        if !worst(&out.excitation).is_some_and(|e| within(e, limits.excitation)) {
            out.failed |= 1 << VOLTAGE_INPUT;
        }
        let gain_ok = worst(&out.gain).is_some_and(|e| within(e, limits.gain));
        let phase_ok = worst(&out.phase_rad).is_some_and(|e| within(e, limits.phase_rad));
        if !(gain_ok && phase_ok) {
            out.failed |= 1 << REFERENCE_INPUT;
        }
        out
    }

    /// Path `p`'s offset and noise into `out`, and whether it failed (a
    /// rail, its offset) or is noisy. Out of line: a loop of calls, not
    /// eighteen copies of it in the board's flash.
    #[inline(never)]
    fn path(&self, p: usize, limits: &Limits, out: &mut Outcome) {
        let blocks = self.blocks.max(1) as f32;
        let offset = self.mean[p] / blocks;
        let noise = dsp_core::fmath::sqrt(self.var[p] / blocks) / NOISE_COUNTS;
        out.offset_counts[p] = offset;
        out.noise[p] = noise;
        if self.rails & 1 << p != 0 || !within(offset, limits.offset_counts) {
            out.failed |= 1 << p;
        }
        if !within(noise, limits.noise) {
            out.noisy |= 1 << p;
        }
    }

    /// Each excitation tone's amplitude against the design, relative.
    fn excitation_error(&self) -> [f32; TONES] {
        // In f32 (no f64 arithmetic in the image): counts a volt.
        const COUNTS_PER_VOLT: f32 = (HALF_SCALE as f64 / crate::design::ADC_HALF_SCALE_VOLT) as f32;
        let volts = self.layout.tone_volts();
        let per_block = self.layout.instants() as f32 * self.blocks.max(1) as f32;
        core::array::from_fn(|k| {
            let counts = dsp_core::fmath::hypot(self.v[k].re, self.v[k].im) * 2.0 / (Q31 * per_block);
            counts / (volts[k] as f32 * COUNTS_PER_VOLT) - 1.0
        })
    }

    /// The reference's impedance against R + 1/(jωC) at each tone: |Z|'s
    /// relative error and the phase's, rad.
    fn reference_error(
        &self,
        front_end: &FrontEnd,
        rotation: &[Complex32; TONES],
    ) -> ([f32; TONES], [f32; TONES]) {
        let mut gain = [f32::NAN; TONES];
        let mut phase = [f32::NAN; TONES];
        for k in 0..TONES {
            let d = self.i[k].norm_sqr();
            if !(d > 0.0 && d.is_finite()) {
                continue;
            }
            let z = self.v[k] * self.i[k].conj() / d * front_end.gain * rotation[k];
            let want = nominal(self.layout.tone_hz(k));
            let q = z / want;
            gain[k] = libm::sqrtf(q.norm_sqr()) - 1.0;
            phase[k] = libm::atan2f(q.im, q.re);
        }
        (gain, phase)
    }
}

/// 2³¹, the comb's phasors' scale.
const Q31: f32 = 2_147_483_648.0;

/// The reference network's nominal impedance at `f_hz`, Ω.
pub fn nominal(f_hz: f32) -> Complex32 {
    let w = core::f32::consts::TAU * f_hz;
    Complex32::new(REFERENCE_OHM as f32, -1.0 / (w * REFERENCE_FARAD as f32))
}

/// |x| ≤ limit, and x a number.
fn within(x: f32, limit: f32) -> bool {
    libm::fabsf(x) <= limit
}

/// The error of largest magnitude (None if any is not a number).
fn worst(e: &[f32; TONES]) -> Option<f32> {
    e.iter().try_fold(0f32, |m, &x| {
        (!x.is_nan()).then(|| if libm::fabsf(x) > libm::fabsf(m) { x } else { m })
    })
}

/// What the test found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Paths that failed a check, one bit per ADC input.
    pub failed: u32,
    /// Paths whose noise is over its limit.
    pub noisy: u32,
    /// Each path's mean against the bias, counts.
    pub offset_counts: [f32; PATHS],
    /// Each path's residual rms over [`NOISE_COUNTS`].
    pub noise: [f32; PATHS],
    /// Each excitation tone's amplitude error, relative.
    pub excitation: [f32; TONES],
    /// The reference's |Z| error at each tone, relative (NaN: no
    /// current).
    pub gain: [f32; TONES],
    /// The reference's phase error at each tone, rad.
    pub phase_rad: [f32; TONES],
}

impl Outcome {
    const EMPTY: Self = Self {
        failed: 0,
        noisy: 0,
        offset_counts: [0.0; PATHS],
        noise: [0.0; PATHS],
        excitation: [0.0; TONES],
        gain: [0.0; TONES],
        phase_rad: [0.0; TONES],
    };

    /// Did every path pass?
    pub fn passed(&self) -> bool {
        self.failed == 0
    }

    /// The sensors whose records are refused, one bit each: all if the
    /// excitation's path or the reference's failed, else those whose
    /// own path did.
    pub fn refused(&self) -> u16 {
        let test = link::SelfTest {
            failed: self.failed,
            ..link::SelfTest::default()
        };
        (0..SENSORS as u8)
            .filter(|&s| test.refuses(s))
            .fold(0, |m, s| m | 1 << s)
    }

    /// As the start frame carries it.
    pub fn frame(&self) -> link::SelfTest {
        let scaled = |x: Option<f32>, unit: f32| match x {
            // Saturating: a NaN (no current) reads as the most negative.
            Some(e) => (e * unit) as i32,
            None => i32::MIN,
        };
        let noisiest = self.noise.iter().fold(0f32, |m, &r| m.max(r));
        link::SelfTest {
            verdict: if self.passed() {
                Verdict::Passed
            } else {
                Verdict::Failed
            },
            failed: self.failed,
            noisy: self.noisy,
            gain_ppm: scaled(worst(&self.gain), 1e6),
            phase_urad: scaled(worst(&self.phase_rad), 1e6),
            excitation_ppm: scaled(worst(&self.excitation), 1e6),
            noise_permille: (noisiest * 1e3) as u16,
        }
    }
}
