//! The analog front end and ADC: excitation voltage and sensor current
//! sampled in pairs, as the firmware's ADC sees them.
//!
//! Channel 0 samples the excitation v(t) = A·cos θₙ through a gain
//! `v_gain`; channel 1 samples the output of an inverting transimpedance
//! stage, −R_f·i(t), with i(t) = Re{A·e^(jθₙ)/Z} for the sensor impedance Z
//! (quasi-static: the sensor changes slowly against one block). Both are
//! quantized by a `bits`-bit bipolar ADC of full scale ±`full_scale_volt`,
//! with (Irwin–Hall) Gaussian noise, and clipped at the rails (reported).
//!
//! The synthesis uses dsp-core's integer `cossin` and `f32` arithmetic (IEEE
//! basic operations), so a block costs a few dozen instructions per pair
//! and gives the same codes on the host and in QEMU.

use crate::rng::Rng;
use dsp_core::demod::FrontEnd;
use dsp_core::{Oscillator, OscillatorState};
use num_complex::Complex64;
use skin_spec::design;
use skin_spec::ranging::Ranging;

/// Front-end parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontEndParams {
    /// Pair sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Excitation amplitude at the sensor, V.
    pub excitation_volt: f64,
    /// Gain from the excitation to the voltage ADC channel, V/V.
    pub v_gain: f64,
    /// Transimpedance R_f of the (inverting) current amplifier, Ω.
    pub tia_ohm: f64,
    /// ADC resolution, bits (≤ 16).
    pub adc_bits: u32,
    /// ADC full scale: inputs span ±this, V.
    pub full_scale_volt: f64,
    /// Gaussian noise at the ADC input, rms LSB.
    pub noise_lsb: f64,
}

impl FrontEndParams {
    /// The reference front end, as designed ([`skin_spec::design`]:
    /// 200 kSa/s, 1 V excitation, 100 kΩ transimpedance, 12-bit ±1.65 V
    /// ADC), with 0.7 LSB rms noise.
    pub const REFERENCE: Self = Self {
        sample_rate_hz: design::SAMPLE_RATE as f64,
        excitation_volt: design::EXCITATION_VOLT,
        v_gain: design::V_GAIN,
        tia_ohm: design::TIA_LOWEST_RANGE_OHM,
        adc_bits: design::CONVERSION_BITS,
        full_scale_volt: design::ADC_HALF_SCALE_VOLT,
        noise_lsb: 0.7,
    };

    /// The complex transimpedance k with Z = k·V/I for dsp-core.
    pub fn dsp_front_end(&self) -> FrontEnd {
        FrontEnd::transimpedance((self.tia_ohm / self.v_gain) as f32, true)
    }

    /// The auto-ranging of this front end: the board's ranges
    /// ([`design::TIA_RANGES_OHM`]) scaled so that the lowest is
    /// `tia_ohm`, on this ADC.
    pub fn ranging(&self) -> Ranging {
        let k = self.tia_ohm / design::TIA_LOWEST_RANGE_OHM;
        Ranging {
            ranges_ohm: design::TIA_RANGES_OHM.map(|r| (r * k) as f32),
            half_scale: (1u32 << (self.adc_bits.clamp(2, 16) - 1)) as f32,
            ..Ranging::DEFAULT
        }
    }

    /// The front end switched to range `k` of `ranging` (unchanged for an
    /// index beyond its ranges).
    pub fn at_range(&self, ranging: &Ranging, k: u8) -> Self {
        Self {
            tia_ohm: ranging
                .ranges_ohm
                .get(k as usize)
                .map_or(self.tia_ohm, |&r| r as f64),
            ..*self
        }
    }

    /// Fill `out` with one block of `[v, i]` ADC codes for a sensor of
    /// impedance `z` (Ω) excited by `osc` from phase 0. Returns true if any
    /// sample clipped.
    pub fn block(&self, osc: &Oscillator, z: Complex64, rng: &mut Rng, out: &mut [[i16; 2]]) -> bool {
        self.block_disturbed(osc, z, rng, out, &Disturbance::NONE)
    }

    /// As [`block`](Self::block), with `d` added at the ADC inputs.
    pub fn block_disturbed(
        &self,
        osc: &Oscillator,
        z: Complex64,
        rng: &mut Rng,
        out: &mut [[i16; 2]],
        d: &Disturbance,
    ) -> bool {
        let tone = Excitation {
            osc: *osc,
            share: 1.0,
            z,
        };
        self.tones_disturbed(&[tone], rng, out, d)
    }

    /// One block of the multiplexed board at set entry `i`: its two tones
    /// ([`skin_spec::config::tones`]) at their shares of the excitation,
    /// the sensor's impedance at each from `z` (Hz → Ω), `d` added at the
    /// ADC inputs. Returns true if any sample clipped.
    pub fn mux_block(
        &self,
        i: usize,
        z: impl Fn(f64) -> Complex64,
        rng: &mut Rng,
        out: &mut [[i16; 2]],
        d: &Disturbance,
    ) -> bool {
        use skin_spec::config::{freq_hz, ftw, tones, TONE_SHARES};
        let [a, b] = tones(i);
        let tone = |k: usize, share: f32| Excitation {
            osc: Oscillator::from_ftw(ftw(k)),
            share: share as f64,
            z: z(freq_hz(k) as f64),
        };
        self.tones_disturbed(&[tone(a, TONE_SHARES[0]), tone(b, TONE_SHARES[1])], rng, out, d)
    }

    /// One block of `[v, i]` codes for an excitation of several tones (up
    /// to [`MAX_TONES`]; more are not played), each
    /// from phase 0 at its share of the excitation's amplitude through the
    /// sensor's impedance at its frequency, `d` added at the ADC inputs.
    /// Returns true if any sample clipped.
    pub fn tones_disturbed(
        &self,
        tones: &[Excitation],
        rng: &mut Rng,
        out: &mut [[i16; 2]],
        d: &Disturbance,
    ) -> bool {
        let half = (1i32 << (self.adc_bits.clamp(2, 16) - 1)) as f32;
        let lsb = (self.full_scale_volt as f32) / half;
        let k = (-self.tia_ohm / lsb as f64) as f32;
        // Per tone: the voltage's amplitude and the current phasor (A)
        // through the transimpedance, in LSB per unit cos/sin.
        let mut synth = [(
            0.0f32,
            0.0f32,
            0.0f32,
            Oscillator::from_ftw(0),
            OscillatorState::default(),
        ); MAX_TONES];
        let m = tones.len().min(MAX_TONES);
        for (x, t) in synth.iter_mut().zip(tones) {
            let volt = self.excitation_volt * t.share;
            let y = Complex64::new(volt, 0.0) / t.z;
            let va = (volt * self.v_gain) as f32 / lsb;
            *x = (
                va,
                k * y.re as f32,
                k * y.im as f32,
                t.osc,
                OscillatorState::default(),
            );
        }
        let noise = self.noise_lsb as f32;
        let q = 1.0 / 2_147_483_648.0f32;
        let mut clipped = false;
        let mut adc = |x: f32| {
            let (code, rail) = quantize(x, half);
            clipped |= rail;
            code
        };
        // Hum phase as a 32-bit turn fraction: per pair, and at the block's
        // first pair from its absolute time.
        let turns = |t: f64| {
            let x = d.hum_hz as f64 * t;
            ((x - libm::floor(x)) * 4_294_967_296.0) as u64 as u32
        };
        let hum_step = turns(1.0 / self.sample_rate_hz);
        let mut hum_phase =
            turns(d.t0_s).wrapping_add((d.hum_phase_turns as f64 * 4_294_967_296.0) as i64 as u32);
        for (n, o) in out.iter_mut().enumerate() {
            let (mut v, mut i) = (0.0f32, 0.0f32);
            for (va, ir, ii, osc, st) in synth[..m].iter_mut() {
                let (c, s) = osc.next(st);
                let (c, s) = (c as f32 * q, s as f32 * q);
                v += *va * c;
                i += *ir * c - *ii * s;
            }
            let (_, h) = dsp_core::cossin::cossin(hum_phase as i32);
            let h = h as f32 * q;
            hum_phase = hum_phase.wrapping_add(hum_step);
            let step = if (d.step_at..d.step_until).contains(&n) {
                d.step_i
            } else {
                0.0
            };
            let v = v + noise * rng.gaussian_fast() + d.hum_v * h;
            let i = i + noise * rng.gaussian_fast() + d.hum_i * h + step;
            *o = [adc(v), adc(i)];
            if let Some(code) = d.stuck_i {
                o[1] = code;
            }
        }
        clipped
    }
}

/// The most tones [`FrontEndParams::tones_disturbed`] plays.
pub const MAX_TONES: usize = 4;

/// One tone of an excitation ([`FrontEndParams::tones_disturbed`]).
#[derive(Clone, Copy, Debug)]
pub struct Excitation {
    /// Its oscillator (from phase 0 at the block's first pair).
    pub osc: Oscillator,
    /// Its share of the excitation's amplitude.
    pub share: f64,
    /// The sensor's impedance at its frequency, Ω.
    pub z: Complex64,
}

/// An ADC's code for an input of `x` counts on a bipolar range of
/// ±`half`: rounded half away from zero, then clipped to the range;
/// true when it clipped.
pub(crate) fn quantize(x: f32, half: f32) -> (i16, bool) {
    let code = if x >= 0.0 {
        (x + 0.5) as i32
    } else {
        (x - 0.5) as i32
    } as f32;
    let rail = code > half - 1.0 || code < -half;
    (code.clamp(-half, half - 1.0) as i16, rail)
}

/// Disturbances at the ADC inputs of a block, counts: what a bench adds to
/// the excitation and what the instrument must not mistake for the sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disturbance {
    /// Mains hum frequency, Hz (50 or 60).
    pub hum_hz: f32,
    /// Hum amplitude on the voltage channel, counts (peak).
    pub hum_v: f32,
    /// Hum amplitude on the current channel, counts (peak).
    pub hum_i: f32,
    /// Hum phase at t = 0, turns.
    pub hum_phase_turns: f32,
    /// Time of the block's first pair, s (where the hum is in its cycle).
    pub t0_s: f64,
    /// A step on the current channel from pair `step_at` on, counts.
    pub step_i: f32,
    /// First pair of the step.
    pub step_at: usize,
    /// The pair the step ends before (`usize::MAX`: it lasts the block;
    /// a few pairs: a burst).
    pub step_until: usize,
    /// The current channel stuck at one code (an ADC or DMA fault).
    pub stuck_i: Option<i16>,
}

impl Disturbance {
    /// Nothing added.
    pub const NONE: Self = Self {
        hum_hz: 50.0,
        hum_v: 0.0,
        hum_i: 0.0,
        hum_phase_turns: 0.0,
        t0_s: 0.0,
        step_i: 0.0,
        step_at: usize::MAX,
        step_until: usize::MAX,
        stuck_i: None,
    };
}
