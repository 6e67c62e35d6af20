//! The array's analog front end and ADCs ([`skin_spec::array`]): one comb
//! excitation, a transimpedance stage per sensor, five ADCs scanning four
//! inputs each, as their DMA leaves a block.
//!
//! At instant n of a block, scan position j is converted at
//! t = n/[`RATE_HZ`] + j·[`SCAN_STEP_S`], so tone k (pₖ periods per block,
//! phase φₖ) stands at θ = 2π·(pₖ·n/N + fₖ·j·Δ) + φₖ there. The excitation
//! input reads v = g_v·Σ Aₖ cos θ; sensor s's input reads the inverting
//! stage's −R_f·Σ Re{Aₖ·e^(jθ)/Zₛ,ₖ}, Zₛ,ₖ its impedance at tone k (held over
//! the block: the sensor moves slowly against a block of 1 or 4 ms; the
//! layout, [`skin_spec::array::Layout`], is the front end's). Each result is
//! quantized to the 15-bit oversampled scale with Gaussian noise of
//! [`NOISE_COUNTS`] and clipped at the rails (reported per input). The
//! self-test's reference network on [`REFERENCE_INPUT`] reads as a
//! sensor of R + 1/(jωC) would; the other spare inputs read noise. Phases use dsp-core's integer `cossin` and the
//! synthesis `f32` arithmetic, so the codes are the same on the host and
//! in QEMU.

use crate::frontend::Disturbance;
use crate::rng::Rng;
use dsp_core::cossin::cossin;
use num_complex::Complex64;
use skin_spec::array::{
    adc_position, input_of, Frame, Layout, HALF_SCALE, NOISE_COUNTS, RATE_HZ, REFERENCE_FARAD,
    REFERENCE_INPUT, REFERENCE_OHM, SCAN, SCAN_STEP_S, SENSORS, SENSOR_TIA_OHM, TONES, VOLTAGE_INPUT,
};
use skin_spec::design;

pub use skin_spec::array::INPUTS;

/// The array front end's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayFrontEnd {
    /// The blocks' layout: their length and the comb's tones,
    /// amplitudes (at the sensors) and phases.
    pub layout: Layout,
    /// Gain from the excitation to its ADC input, V/V.
    pub v_gain: f64,
    /// Every sensor's transimpedance, Ω.
    pub tia_ohm: f64,
    /// ADC input span around the bias, V (±).
    pub half_scale_volt: f64,
    /// Noise of one result, counts rms.
    pub noise_counts: f64,
    /// The self-test's reference network on [`REFERENCE_INPUT`] as
    /// assembled: its resistor, Ω, and capacitor, F (None: a spare that
    /// reads noise).
    pub reference: Option<(f64, f64)>,
    /// A DC offset at each input, counts: a stage's output off the bias
    /// (one past a rail: a stage open loop).
    pub offset_counts: [f32; INPUTS],
}

impl ArrayFrontEnd {
    /// As designed ([`skin_spec::array`]), with 4 ms blocks.
    pub const REFERENCE: Self = Self::reference(Layout::BLOCK_4MS);

    /// As designed, with blocks of `layout`.
    pub const fn reference(layout: Layout) -> Self {
        Self {
            layout,
            v_gain: 1.0,
            tia_ohm: SENSOR_TIA_OHM,
            half_scale_volt: design::ADC_HALF_SCALE_VOLT,
            noise_counts: NOISE_COUNTS as f64,
            reference: Some((REFERENCE_OHM, REFERENCE_FARAD)),
            offset_counts: [0.0; INPUTS],
        }
    }

    /// The complex transimpedance k in Z = k·V/I for dsp-core.
    pub fn dsp_front_end(&self) -> dsp_core::demod::FrontEnd {
        dsp_core::demod::FrontEnd::transimpedance((self.tia_ohm / self.v_gain) as f32, true)
    }

    /// Fill the first [`Layout::instants`] rows of each ADC's `frame`
    /// with one block for sensors of impedances `z[s][k]`
    /// (Ω, at comb tone k), with `hum[s]` added at sensor s's input (only
    /// its hum fields are used; `t0_s` is the block's start). Returns
    /// which inputs clipped.
    pub fn frame(
        &self,
        z: &[[Complex64; TONES]; SENSORS],
        hum: &[Disturbance; SENSORS],
        rng: &mut Rng,
        frame: &mut Frame,
    ) -> [bool; INPUTS] {
        let half = HALF_SCALE as f32;
        let lsb = self.half_scale_volt / HALF_SCALE as f64;
        // Per input and tone: the cos and sin coefficients of its code.
        let mut coef = [[(0f32, 0f32); TONES]; INPUTS];
        let (volts, comb, phases) = (self.layout.tone_volts(), self.layout.comb(), self.layout.phases());
        let instants = self.layout.instants().min(frame[0].len());
        for (c, &a) in coef[VOLTAGE_INPUT].iter_mut().zip(&volts) {
            *c = ((a * self.v_gain / lsb) as f32, 0.0);
        }
        let g = -self.tia_ohm / lsb;
        let current = |z: Complex64, k: usize| {
            let y = Complex64::new(volts[k], 0.0) / z;
            ((g * y.re) as f32, (g * y.im) as f32)
        };
        for (s, zs) in z.iter().enumerate() {
            for (k, zk) in zs.iter().enumerate() {
                coef[input_of(s)][k] = current(*zk, k);
            }
        }
        if let Some((r, c)) = self.reference {
            let hz = self.layout.tones_hz();
            for (k, x) in coef[REFERENCE_INPUT].iter_mut().enumerate() {
                let w = core::f64::consts::TAU * hz[k] as f64;
                *x = current(Complex64::new(r, -1.0 / (w * c)), k);
            }
        }
        // The phase offset of each tone at each scan position, 2³² a turn.
        let turn = 4_294_967_296.0f64;
        let tone_hz = |k: usize| comb[k] as f64 * RATE_HZ as f64 / instants as f64;
        let offset: [[u32; TONES]; SCAN] = core::array::from_fn(|j| {
            core::array::from_fn(|k| {
                let t =
                    tone_hz(k) * j as f64 * SCAN_STEP_S as f64 + phases[k] as f64 / core::f64::consts::TAU;
                ((t - libm::floor(t)) * turn) as u64 as u32
            })
        });
        let hum_turns = |h: &Disturbance, t: f64| {
            let x = h.hum_hz as f64 * t + h.hum_phase_turns as f64;
            ((x - libm::floor(x)) * turn) as u64 as u32
        };
        let q = 1.0 / 2_147_483_648.0f32;
        let noise = self.noise_counts as f32;
        let mut clipped = [false; INPUTS];
        #[allow(clippy::needless_range_loop)] // n is the instant: a phase, and a row of each ADC
        for n in 0..instants {
            // cos and sin of every tone at every scan position.
            let mut cs = [[(0f32, 0f32); TONES]; SCAN];
            for (j, row) in cs.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    let m = (comb[k] as u64 * n as u64) % instants as u64;
                    let base = (((m << 32) + instants as u64 / 2) / instants as u64) as u32;
                    let (c, s) = cossin(base.wrapping_add(offset[j][k]) as i32);
                    *v = (c as f32 * q, s as f32 * q);
                }
            }
            for input in 0..INPUTS {
                let (a, j) = adc_position(input);
                let mut x = 0f32;
                for (&(cc, ss), &(c, s)) in coef[input].iter().zip(&cs[j]) {
                    x += cc * c - ss * s;
                }
                if let Some(h) = (1..=SENSORS).contains(&input).then(|| &hum[input - 1]) {
                    if h.hum_i != 0.0 {
                        let t = h.t0_s + n as f64 / RATE_HZ as f64 + j as f64 * SCAN_STEP_S as f64;
                        let (_, s) = cossin(hum_turns(h, t) as i32);
                        x += h.hum_i * s as f32 * q;
                    }
                }
                x += noise * rng.gaussian_fast() + self.offset_counts[input];
                let (code, rail) = crate::frontend::quantize(x, half);
                clipped[input] |= rail;
                frame[a][n][j] = code;
            }
        }
        clipped
    }
}
