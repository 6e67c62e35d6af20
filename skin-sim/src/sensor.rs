//! The sensor on a fine grid, read through the two tabs at one end.
//!
//! [`SEGMENTS`] segments from the read end (ξ = 0) to the far end (ξ = 1);
//! segment i has top and bottom electrode resistances r_t,i, r_b,i (in
//! series for the current, which flows out along one electrode and back
//! along the other), capacitance c_i and leakage conductance g_i. The grid
//! is much finer than any estimator's model, so tests never check a model
//! against itself.
//!
//! Optional non-ideal effects of the sensor and its wiring, from the
//! catalogue ([`skin_spec::effects`], all off by default): contact
//! resistance at the tabs, parasitic (cable) capacitance at the meter,
//! electrode resistance varying linearly along the sensor, dielectric
//! leakage, stretch varying linearly along the sensor, dielectric
//! dispersion and loss, tab leads carrying a fraction of each electrode's
//! resistance outside the capacitor, and a frequency-dependent
//! conductivity of the electrode film. The recording's effects (meter lag, time offset) belong to
//! the meter that reads the sensor (host-sim's chain).

use crate::electrode::{ElectrodeParams, ElectrodeState};
use crate::profile::Profile;
use num_complex::Complex64;
use skin_spec::calib::{CalTable, POINTS};
use skin_spec::design;
use skin_spec::effects::{Effect, EffectSet};

/// Number of grid segments.
pub const SEGMENTS: usize = 240;

/// Sensor parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorParams {
    /// Capacitance at rest (prestretched, 0 mm), F.
    pub c_rest_farad: f64,
    /// Active length at rest, mm: C = c_rest·(1 + s/length) (uniaxial
    /// stretch of an incompressible film).
    pub rest_length_mm: f64,
    /// Top electrode.
    pub top: ElectrodeParams,
    /// Bottom electrode.
    pub bottom: ElectrodeParams,
    /// Non-ideal effects (SI, [`skin_spec::effects`]).
    pub effects: EffectSet,
}

impl SensorParams {
    /// The reference sensor: 100 mm, 210 pF, ≈350 + 362 kΩ, a silicone
    /// film of loss tangent [`REFERENCE_LOSS_TANGENT`], no other effect.
    pub const REFERENCE: Self = Self {
        c_rest_farad: design::SENSOR_C_REST_FARAD,
        rest_length_mm: design::SENSOR_REST_LENGTH_MM,
        top: ElectrodeParams::TOP,
        bottom: ElectrodeParams::BOTTOM,
        effects: EffectSet::NONE.with(Effect::DielectricLoss, REFERENCE_LOSS_TANGENT),
    };

    /// The founding paper's sensor, as its text describes it
    /// (`data/paper/claims.csv`) and `identify` fits its static sweep
    /// (`data/paper/dataset`): 175 pF unstretched and ~205 pF at 0 mm,
    /// C = 175 pF·λ^1.13, λ = (115 mm + s)/100 mm (between a uniaxial
    /// stretch of free width, C ∝ λ, and pure shear, C ∝ λ²), linear over
    /// 0…30 mm within 0.3 %; electrodes of 350 and 361 kΩ, flat to
    /// 15 mm, 20 % and 25 % lower at 30 mm; 64 % of each electrode's
    /// end-to-end resistance in its tab leads (`identify`: 0.642 ± 0.010);
    /// cycling raises the resistance (the relaxed 180 pF at 2 kHz), and
    /// the breakdown under motion gives the paper's 2 kHz undershoots.
    /// The dynamic parameters are fitted to the paper's dynamic numbers;
    /// see the README's "The paper's own measurements". Its silicone film
    /// loses [`PAPER_LOSS_TANGENT`] (the paper does not measure it).
    pub const PAPER: Self = Self {
        c_rest_farad: 205.2e-12,
        rest_length_mm: 101.8,
        top: ElectrodeParams::PAPER_TOP,
        bottom: ElectrodeParams::PAPER_BOTTOM,
        effects: EffectSet::NONE
            .with(Effect::LeadResistance, 0.6415)
            .with(Effect::DielectricLoss, PAPER_LOSS_TANGENT),
    };

    /// Sensor `s` of a skin of hand-made sensors (the array's `skin` and
    /// `stairs` scenarios), drawn at a fixed seed from the spread of such
    /// sensors and their wiring: rest C 0.8–1.2 times the paper's (film
    /// thickness and area), electrode resistance 0.5–1.5 times
    /// (carbon-black loading), 0–20 pF of cable and fixture capacitance,
    /// tab leads from none to the paper sensor's share of each electrode,
    /// and a silicone film of loss tangent 1–5·10⁻³ (uniform draws).
    pub fn hand_made(s: usize) -> Self {
        let mut rng = crate::rng::Rng::new(0x5e45_0000 + s as u64);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let mut p = Self::PAPER;
        p.c_rest_farad *= u(0.8, 1.2);
        let k = u(0.5, 1.5);
        p.top.r_rest_ohm *= k;
        p.bottom.r_rest_ohm *= k;
        let leads = u(0.0, 1.0) * Self::PAPER.effects.get(Effect::LeadResistance);
        let parasitic = u(0.0, 20e-12);
        let loss = u(1e-3, 5e-3);
        p.effects = EffectSet::NONE
            .with(Effect::LeadResistance, leads)
            .with(Effect::ParasiticCapacitance, parasitic)
            .with(Effect::DielectricLoss, loss);
        p
    }

    /// This sensor with both electrodes `k` times as resistive (their
    /// rest resistance scaled; their dynamics unchanged).
    pub fn with_electrodes_scaled(self, k: f64) -> Self {
        let mut p = self;
        p.top.r_rest_ohm *= k;
        p.bottom.r_rest_ohm *= k;
        p
    }

    /// True capacitance at a uniform stretch `s` (mm), F.
    pub fn capacitance(&self, s: f64) -> f64 {
        self.c_rest_farad * (1.0 + s / self.rest_length_mm)
    }
}

/// The loss tangent of the paper's silicone film, within what silicone
/// elastomers measure at 0.1–10 kHz (1–5·10⁻³) and not the middle the
/// firmware assumes (`dsp_core::dielectric::Dielectric::SILICONE`, 3·10⁻³):
/// the paper neglects the film's losses and does not measure them.
pub const PAPER_LOSS_TANGENT: f64 = 3.5e-3;

/// The loss tangent of the reference sensor's silicone film (as
/// [`PAPER_LOSS_TANGENT`], on the other side of the firmware's 3·10⁻³).
pub const REFERENCE_LOSS_TANGENT: f64 = 2.5e-3;

/// The paper's sensor's stretch table, as the firmware holds it: its line
/// capacitance, linear in stretch ([`SensorParams::PAPER`]).
pub static PAPER_CALIBRATION: CalTable<POINTS> = CalTable::linear(
    SensorParams::PAPER.c_rest_farad,
    SensorParams::PAPER.rest_length_mm,
);

/// What the simulated sensor truly is at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Truth {
    /// Time, s.
    pub t: f64,
    /// Mean stretch, mm.
    pub stretch_mm: f64,
    /// Stretch rate, mm/s.
    pub rate_mm_s: f64,
    /// Line capacitance Σc_i, F.
    pub c_farad: f64,
    /// Line resistance Σ(r_t,i + r_b,i), without contacts, Ω.
    pub r_line_ohm: f64,
    /// End-to-end top electrode resistance, as measured through its two
    /// tabs (includes two contacts), Ω.
    pub r_top_ohm: f64,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom_ohm: f64,
}

impl Truth {
    /// The truth line of the block whose middle is `t_us` of `sensor`,
    /// as the QEMU firmware logs it beside the record.
    pub fn line(&self, t_us: u64, sensor: u8) -> skin_spec::truth::TruthLine {
        skin_spec::truth::TruthLine {
            t_us,
            sensor,
            c_farad: self.c_farad as f32,
            r_line_ohm: self.r_line_ohm as f32,
            stretch_mm: self.stretch_mm as f32,
            r_top_ohm: self.r_top_ohm as f32,
            r_bottom_ohm: self.r_bottom_ohm as f32,
        }
    }
}

/// A sensor in time.
#[derive(Clone, Debug)]
pub struct Sensor {
    /// Parameters.
    pub params: SensorParams,
    top: ElectrodeState,
    bottom: ElectrodeState,
    t: f64,
    stretch: f64,
    rate: f64,
}

impl Sensor {
    /// A sensor at t = 0 in the electrodes' steady state (cycled long
    /// enough, as the paper waited 15 min before recording).
    pub fn settled(params: SensorParams) -> Self {
        Self {
            params,
            top: ElectrodeState::cycled(&params.top),
            bottom: ElectrodeState::cycled(&params.bottom),
            t: 0.0,
            stretch: 0.0,
            rate: 0.0,
        }
    }

    /// A sensor at t = 0 at its static resistances R_static(s): no
    /// excess, no transients (what a static measurement records).
    pub fn at_static(params: SensorParams) -> Self {
        Self {
            top: ElectrodeState::default(),
            bottom: ElectrodeState::default(),
            ..Self::settled(params)
        }
    }

    /// A sensor at t = 0 that has rested long (resistance excess present).
    pub fn rested(params: SensorParams) -> Self {
        Self {
            top: ElectrodeState::rested(&params.top),
            bottom: ElectrodeState::rested(&params.bottom),
            ..Self::settled(params)
        }
    }

    /// Current time, s.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Follow `profile` up to time `t` (s) in steps of at most 1 ms.
    pub fn advance(&mut self, profile: &Profile, t: f64) {
        const DT: f64 = 1e-3;
        while self.t < t {
            let dt = DT.min(t - self.t);
            // The rate over the step, from the profile's stretch change.
            let (s0, _) = profile.at(self.t);
            let (s1, _) = profile.at(self.t + dt);
            let rate = (s1 - s0) / dt;
            self.params.top.step(&mut self.top, rate, dt);
            self.params.bottom.step(&mut self.bottom, rate, dt);
            self.t += dt;
            self.stretch = s1;
            self.rate = rate;
        }
    }

    /// Local stretch of segment i, mm.
    fn local_stretch(&self, i: usize) -> f64 {
        let xi = (i as f64 + 0.5) / SEGMENTS as f64;
        self.stretch * self.params.effects.stretch_profile(xi)
    }

    /// Weight of segment i's electrode resistance (mean 1).
    fn r_weight(&self, i: usize) -> f64 {
        let xi = (i as f64 + 0.5) / SEGMENTS as f64;
        self.params.effects.resistance_profile(xi)
    }

    /// Segment i: (r_t + r_b, c, g).
    fn segment(&self, i: usize) -> (f64, f64, f64) {
        let p = &self.params;
        let s = self.local_stretch(i);
        let w = self.r_weight(i) / SEGMENTS as f64;
        let body = 1.0 - p.effects.get(Effect::LeadResistance);
        let r = body * w * (p.top.resistance(&self.top, s) + p.bottom.resistance(&self.bottom, s));
        let c = p.capacitance(s) / SEGMENTS as f64;
        // Bulk leakage: G/C = σ/ε of the film, so each segment's
        // conductance follows its capacitance.
        let g = p.effects.get(Effect::DielectricLeakage) * c;
        (r, c, g)
    }

    /// The truth now.
    pub fn truth(&self) -> Truth {
        let p = &self.params;
        let (mut c, mut rt, mut rb) = (0.0, 0.0, 0.0);
        // Alike segments sum to one of them (no profile: ξ does not
        // matter), else segment by segment.
        let n = if self.uniform_profiles() { 0 } else { SEGMENTS };
        if n == 0 {
            let s = self.local_stretch(0);
            rt = p.top.resistance(&self.top, s);
            rb = p.bottom.resistance(&self.bottom, s);
            c = p.capacitance(s);
        }
        for i in 0..n {
            let s = self.local_stretch(i);
            let w = self.r_weight(i) / SEGMENTS as f64;
            rt += w * p.top.resistance(&self.top, s);
            rb += w * p.bottom.resistance(&self.bottom, s);
            c += p.capacitance(s) / SEGMENTS as f64;
        }
        let rc = 2.0 * p.effects.get(Effect::ContactResistance);
        let body = 1.0 - p.effects.get(Effect::LeadResistance);
        Truth {
            t: self.t,
            stretch_mm: self.stretch,
            rate_mm_s: self.rate,
            c_farad: c,
            r_line_ohm: body * (rt + rb),
            r_top_ohm: rt + rc,
            r_bottom_ohm: rb + rc,
        }
    }

    /// Impedance seen through the two tabs at the read end at `f_hz`, Ω.
    pub fn impedance(&self, f_hz: f64) -> Complex64 {
        self.impedances(&[f_hz])[0]
    }

    /// Impedances at several frequencies at once, Ω: the segments and the
    /// leads are evaluated once for all of them.
    pub fn impedances<const K: usize>(&self, f_hz: &[f64; K]) -> [Complex64; K] {
        let uniform = self.uniform();
        let leads = self.leads_ohm();
        f_hz.map(|f| {
            let (w, k, film) = self.frequency_terms(f);
            let z = match uniform {
                Some(seg) => uniform_ladder(seg, w, k, film),
                None => self.ladder(w, k, film),
            };
            self.wired(z + film * leads, w)
        })
    }

    /// ω (rad/s), the dielectric's complex permittivity factor (its
    /// dispersion, and its loss: k·(1 − j·tan δ)) and the film's
    /// relaxation 1/(1 + jωτ) at `f_hz`.
    fn frequency_terms(&self, f_hz: f64) -> (f64, Complex64, Complex64) {
        let w = core::f64::consts::TAU * f_hz;
        let fx = &self.params.effects;
        let dispersion = fx.get(Effect::DielectricDispersion);
        let k = if dispersion != 0.0 {
            1.0 - dispersion * libm::log10(f_hz / 1e3)
        } else {
            1.0
        };
        let k = Complex64::new(k, -k * fx.get(Effect::DielectricLoss));
        // The film's conductivity relaxes: each electrode resistance is
        // r/(1 + jωτ) (the recorded end-to-end values are DC).
        let tau = fx.get(Effect::ElectrodeDispersion);
        (w, k, Complex64::new(1.0, w * tau).inv())
    }

    /// The common segment when all segments are alike (no profile along
    /// the sensor), else `None`.
    fn uniform(&self) -> Option<(f64, f64, f64)> {
        self.uniform_profiles().then(|| self.segment(0))
    }

    /// No profile along the sensor: all segments alike.
    fn uniform_profiles(&self) -> bool {
        !self.params.effects.nonuniform()
    }

    /// The line's impedance by the segment recursion (any profile).
    fn ladder(&self, w: f64, k: Complex64, film: Complex64) -> Complex64 {
        // Midpoint segments (r/2, shunt c ‖ g, r/2): second-order accurate
        // in the segment length. The far half resistor carries no current.
        let (r, c, g) = self.segment(SEGMENTS - 1);
        let mut z = film * (0.5 * r) + (g + Complex64::i() * (w * c) * k).inv();
        for i in (0..SEGMENTS - 1).rev() {
            let (r, c, g) = self.segment(i);
            let beyond = z + film * (0.5 * r);
            z = film * (0.5 * r) + (g + Complex64::i() * (w * c) * k + beyond.inv()).inv();
        }
        z
    }

    /// The tab leads' series resistance at the read end (top and bottom,
    /// β/2 of each electrode's end-to-end resistance), Ω.
    fn leads_ohm(&self) -> f64 {
        let beta = self.params.effects.get(Effect::LeadResistance);
        if beta > 0.0 {
            0.5 * beta / (1.0 - beta) * self.truth().r_line_ohm
        } else {
            0.0
        }
    }

    /// The wiring around the sensor's `z`: contacts in series, cable
    /// capacitance at the meter.
    fn wired(&self, z: Complex64, w: f64) -> Complex64 {
        let (series, shunt) = self.params.effects.wiring();
        let z = z + series;
        if shunt > 0.0 {
            (z.inv() + Complex64::new(0.0, w * shunt)).inv()
        } else {
            z
        }
    }
}

/// The ladder of [`SEGMENTS`] equal segments (r, c, g) by its Möbius
/// matrix: a segment maps the impedance z beyond it to
/// h + 1/(Y + 1/(z + h)), h = film·r/2, Y = g + jωkc (k complex), the matrix
/// [[1 + hY, h(2 + hY)], [Y, 1 + hY]] (determinant 1); the open far end is
/// z = ∞, so the line is a/c of the matrix's [`SEGMENTS`]-th power (by
/// squaring, scaled as it goes: a Möbius map ignores a common factor).
/// The same ladder as [`Sensor::ladder`]'s recursion, in 12 products
/// instead of 240 steps.
fn uniform_ladder(seg: (f64, f64, f64), w: f64, k: Complex64, film: Complex64) -> Complex64 {
    type M = [Complex64; 4];
    let (r, c, g) = seg;
    let h = film * (0.5 * r);
    let y = g + Complex64::i() * (w * c) * k;
    let d = Complex64::new(1.0, 0.0) + h * y;
    let a: M = [d, h * (d + 1.0), y, d];
    let mul = |p: &M, q: &M| -> M {
        let m = [
            p[0] * q[0] + p[1] * q[2],
            p[0] * q[1] + p[1] * q[3],
            p[2] * q[0] + p[3] * q[2],
            p[2] * q[1] + p[3] * q[3],
        ];
        let s = m.iter().fold(0.0f64, |s, v| s.max(v.re.abs()).max(v.im.abs()));
        if s > 0.0 && s.is_finite() {
            m.map(|v| v / s)
        } else {
            m
        }
    };
    let one = Complex64::new(1.0, 0.0);
    let zero = Complex64::new(0.0, 0.0);
    let (mut result, mut base, mut n): (M, M, usize) = ([one, zero, zero, one], a, SEGMENTS);
    while n > 0 {
        if n & 1 == 1 {
            result = mul(&result, &base);
        }
        n >>= 1;
        if n > 0 {
            base = mul(&base, &base);
        }
    }
    result[0] / result[2]
}

impl Sensor {
    #[cfg(test)]
    fn ladder_recursion(&self, f_hz: f64) -> Complex64 {
        let (w, k, film) = self.frequency_terms(f_hz);
        self.wired(self.ladder(w, k, film) + film * self.leads_ohm(), w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The matrix power is the recursion's ladder, within 10⁻¹⁰, for
    /// uniform sensors with every frequency-dependent and wiring effect,
    /// over 100 Hz–50 kHz (x to ≈ 100).
    #[test]
    fn the_uniform_ladder_is_the_recursion() {
        let mut worst = 0f64;
        let mut sensors = [
            SensorParams::REFERENCE,
            SensorParams::PAPER,
            SensorParams::REFERENCE,
        ];
        sensors[2].effects = EffectSet::NONE
            .with(Effect::ContactResistance, 20e3)
            .with(Effect::ParasiticCapacitance, 12e-12)
            .with(Effect::DielectricLeakage, 50.0)
            .with(Effect::DielectricDispersion, 0.02)
            .with(Effect::DielectricLoss, 0.01)
            .with(Effect::ElectrodeDispersion, 2e-6)
            .with(Effect::LeadResistance, 0.3);
        for p in sensors {
            let mut s = Sensor::settled(p);
            s.advance(&Profile::paper(20.0), 2.0);
            assert!(s.uniform().is_some());
            for f in [100.0, 586.0, 2000.0, 6000.0, 20e3, 50e3] {
                let (a, b) = (s.impedance(f), s.ladder_recursion(f));
                worst = worst.max((a - b).norm() / b.norm());
            }
        }
        assert!(worst < 1e-10, "worst {worst:e}");
        // Several frequencies at once are each one alone.
        let s = Sensor::settled(SensorParams::PAPER);
        let many = s.impedances(&[500.0, 1000.0, 6000.0]);
        assert_eq!(many[2], s.impedance(6000.0));
    }

    /// A profile along the sensor takes the recursion.
    #[test]
    fn a_profile_takes_the_recursion() {
        let mut p = SensorParams::REFERENCE;
        p.effects = EffectSet::NONE.with(Effect::ResistanceGradient, 0.3);
        let s = Sensor::settled(p);
        assert!(s.uniform().is_none());
        assert_eq!(s.impedance(2000.0), s.ladder_recursion(2000.0));
    }
}
