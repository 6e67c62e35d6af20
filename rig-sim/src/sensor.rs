//! The sensor on the bench: a film capacitor cut into symmetric T cells
//! (half the cell's series impedance, the cell's shunt admittance, the
//! other half), each at its own local stretch, read through the two tabs
//! at one end, its far end open.
//!
//! Per cell i of n at ξᵢ = (i + ½)/n (ξ = 0 at the read end), local stretch
//! λᵢ = 1 + (λ − 1)·p(ξᵢ) with p the stretch profile (mean 1):
//! - capacitance Cᵢ = C₀·λᵢ^a / n · ε(ω)/ε(0), ε the dielectric's
//!   permittivity (Cole–Cole when relaxing);
//! - each electrode's film resistance R₀·λᵢ^b·(1 + D)·wᵢ / n, D the film's
//!   dynamic damage (see [`crate::bench::Film`]) and w the resistance profile (mean 1);
//!   the film conducts as r/(1 + jωτ_f) when dispersive;
//! - leakage Gᵢ = G·Cᵢ/C(0), a conductance that scales with the dielectric.
//!
//! Outside the capacitor: each electrode's two tab leads (together a
//! fraction β of its end-to-end resistance), and a contact at each of the
//! four tabs (plain resistance, or a blocking contact R ∥ C).

use num_complex::Complex64;
use std::f64::consts::PI;

/// The sensor's own constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Capacitance at rest, F.
    pub c0_f: f64,
    /// Exponent a of C ∝ λ^a.
    pub c_exp: f64,
    /// Film resistance of the top electrode at rest, Ω.
    pub r0_top_ohm: f64,
    /// Film resistance of the bottom electrode at rest, Ω.
    pub r0_bottom_ohm: f64,
    /// Exponent b of R ∝ λ^b.
    pub r_exp: f64,
    /// Length between the clamps at rest (prestretched), mm.
    pub length_mm: f64,
    /// T cells of the coarser of the two ladders extrapolated to the
    /// continuous film ([`Sensor::read`]).
    pub cells: usize,
}

impl Sensor {
    /// The bench's sensor.
    pub const BENCH: Sensor = Sensor {
        c0_f: 192e-12,
        c_exp: 1.08,
        r0_top_ohm: 343e3,
        r0_bottom_ohm: 366e3,
        r_exp: 2.3,
        length_mm: 62.0,
        cells: 32,
    };

    /// Mean stretch ratio at `stretch_mm`.
    pub fn lambda(&self, stretch_mm: f64) -> f64 {
        1.0 + stretch_mm / self.length_mm
    }
}

/// Dielectric relaxation (Cole–Cole): ε(ω)/ε(0) = 1 − Δ + Δ/(1 + (jωτ)^α).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ColeCole {
    /// Relaxing fraction of the static permittivity.
    pub delta: f64,
    /// Relaxation time, s.
    pub tau_s: f64,
    /// Broadening, 0 < α ≤ 1.
    pub alpha: f64,
}

impl ColeCole {
    fn factor(&self, w: f64) -> Complex64 {
        if self.delta == 0.0 {
            return Complex64::new(1.0, 0.0);
        }
        let jwt = Complex64::new(0.0, w * self.tau_s).powf(self.alpha);
        Complex64::new(1.0 - self.delta, 0.0) + self.delta / (1.0 + jwt)
    }
}

/// Everything that is not the ideal sensor (0: absent).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    /// Contact resistance of each tab (nominal), Ω.
    pub contact_ohm: f64,
    /// A blocking contact's capacitance at each tab, in parallel with its
    /// resistance, F (0: a plain resistive contact).
    pub contact_cap_f: f64,
    /// Cable and fixture capacitance at the meter, F.
    pub parasitic_f: f64,
    /// Resistance profile w(ξ) ∝ exp(κ(ξ − ½)): κ > 0 more resistive
    /// away from the tabs.
    pub resistance_kappa: f64,
    /// Resistance profile's symmetric part: w(ξ) ∝ 1 + m(π/2·sin πξ − 1).
    pub resistance_bulge: f64,
    /// Stretch profile p(ξ) ∝ exp(κ(ξ − ½)): κ > 0 the far end stretches
    /// more.
    pub stretch_kappa: f64,
    /// Stretch profile's symmetric part: p(ξ) = 1 + m(π/2·sin πξ − 1),
    /// m > 0 the middle stretches more than the clamped ends.
    pub stretch_bulge: f64,
    /// Leakage conductance at rest, S.
    pub leakage_s: f64,
    /// Fraction of each electrode's end-to-end resistance in its leads.
    pub lead_fraction: f64,
    /// Film conductivity relaxation time, s.
    pub film_tau_s: f64,
    /// Dielectric relaxation.
    pub dielectric: ColeCole,
    /// A localized bump of stretch along the sensor (a press, a fold).
    pub stretch_bump: Bump,
    /// A localized bump of the film's resistance (a thin or cracked
    /// patch, or a thick one).
    pub resistance_bump: Bump,
}

/// A sine-squared bump along the sensor, from ξ_a to ξ_b (the issue's
/// external generator's shape): a profile 1 + a·(g(ξ) − ḡ), g =
/// sin²(π(ξ − ξ_a)/(ξ_b − ξ_a)) between them, 0 outside, ḡ its mean over
/// the line's cells (so the profile's mean is 1 on the cells).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bump {
    /// Amplitude a (0: none).
    pub amplitude: f64,
    /// Where it starts, ξ_a (0: the read end, 1: the far end; may lie
    /// beyond either end).
    pub start: f64,
    /// Where it ends, ξ_b > ξ_a.
    pub end: f64,
}

impl Bump {
    /// g(ξ) (0 without a bump).
    fn g(&self, xi: f64) -> f64 {
        let span = self.end - self.start;
        if self.amplitude == 0.0 || span <= 0.0 || xi <= self.start || xi >= self.end {
            return 0.0;
        }
        (PI * (xi - self.start) / span).sin().powi(2)
    }

    /// The profile's factors on `n` cells (midpoints), mean 1.
    fn factors(&self, n: usize) -> impl Fn(usize) -> f64 + '_ {
        let xi = move |i: usize| (i as f64 + 0.5) / n as f64;
        let mean = (0..n).map(|i| self.g(xi(i))).sum::<f64>() / n as f64;
        move |i| 1.0 + self.amplitude * (self.g(xi(i)) - mean)
    }
}

/// Normalised exp(κ(ξ − ½)) (mean 1 over ξ ∈ [0, 1]).
fn exp_profile(kappa: f64, xi: f64) -> f64 {
    if kappa.abs() < 1e-12 {
        return 1.0;
    }
    (kappa * (xi - 0.5)).exp() * kappa / (2.0 * (0.5 * kappa).sinh())
}

/// 1 + m(π/2·sin πξ − 1) (mean 1).
fn sin_profile(m: f64, xi: f64) -> f64 {
    1.0 + m * (0.5 * PI * (PI * xi).sin() - 1.0)
}

/// Per-tab spread of the contact resistance around its nominal value
/// (tabs are not alike): top read, top far, bottom read, bottom far.
pub const TAB_SPREAD: [f64; 4] = [1.12, 0.91, 0.95, 1.04];

/// The sensor in a state: its mean stretch and its film's damage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Stretch, mm.
    pub stretch_mm: f64,
    /// The film's dynamic damage D (R grows by 1 + D).
    pub damage: f64,
}

/// What the bench measures of the sensor in one state at one frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Impedance between the two read-end tabs, at the meter, Ω.
    pub z: Complex64,
    /// End-to-end resistance of the top electrode through its tabs, Ω.
    pub r_top_ohm: f64,
    /// Same, bottom electrode, Ω.
    pub r_bottom_ohm: f64,
    /// The sensor's true (static, low-frequency) capacitance, F.
    pub c_true_f: f64,
}

/// The line of `n` cells: (input impedance of the film line, top film
/// resistance, bottom film resistance, capacitance) at ω `w`.
struct Ladder {
    z: Complex64,
    r_top: f64,
    r_bottom: f64,
    c: f64,
}

impl Sensor {
    fn ladder(&self, fx: &Effects, state: State, w: f64, n: usize) -> Ladder {
        let lam = self.lambda(state.stretch_mm);
        let eps = fx.dielectric.factor(w);
        let film = Complex64::new(1.0, w * fx.film_tau_s).inv();
        let dyn_r = 1.0 + state.damage;
        let (mut r_top, mut r_bottom, mut c) = (0.0, 0.0, 0.0);
        // From the open far end towards the tabs.
        let mut zin: Option<Complex64> = None;
        let (sb, rb) = (fx.stretch_bump.factors(n), fx.resistance_bump.factors(n));
        for i in (0..n).rev() {
            let xi = (i as f64 + 0.5) / n as f64;
            let p = exp_profile(fx.stretch_kappa, xi) * sin_profile(fx.stretch_bulge, xi) * sb(i);
            let li = 1.0 + (lam - 1.0) * p;
            let ci = self.c0_f * li.powf(self.c_exp) / n as f64;
            let wr =
                exp_profile(fx.resistance_kappa, xi) * sin_profile(fx.resistance_bulge, xi) * rb(i).max(0.0);
            let scale = li.powf(self.r_exp) * dyn_r * wr / n as f64;
            let (rt, rb) = (self.r0_top_ohm * scale, self.r0_bottom_ohm * scale);
            r_top += rt;
            r_bottom += rb;
            c += ci;
            let half = 0.5 * (rt + rb) * film;
            let y = Complex64::new(fx.leakage_s * ci / self.c0_f, w * ci) * eps;
            let load = match zin {
                None => y,
                Some(zl) => y + (half + zl).inv(),
            };
            zin = Some(half + load.inv());
        }
        Ladder {
            z: zin.unwrap_or_default(),
            r_top,
            r_bottom,
            c,
        }
    }

    /// What the bench sees of `state` at `freq_hz`, with `fx`: the film
    /// as the continuous line, from ladders of n and 2n cells extrapolated
    /// (Richardson: the symmetric cell's error is even in 1/n, so
    /// (4·X₂ₙ − Xₙ)/3 leaves O(n⁻⁴)).
    pub fn read(&self, fx: &Effects, state: State, freq_hz: f64) -> Reading {
        let w = 2.0 * PI * freq_hz;
        let n = self.cells.max(1);
        let (a, b) = (self.ladder(fx, state, w, n), self.ladder(fx, state, w, 2 * n));
        let x = |a: f64, b: f64| (4.0 * b - a) / 3.0;
        let (z_line, r_top, r_bot, c_true) = (
            (4.0 * b.z - a.z) / 3.0,
            x(a.r_top, b.r_top),
            x(a.r_bottom, b.r_bottom),
            x(a.c, b.c),
        );
        // Leads: a fraction β of the end-to-end resistance, half at each
        // end; the film keeps 1 − β.
        let beta = fx.lead_fraction;
        let lead = |r_film: f64| 0.5 * beta / (1.0 - beta) * r_film;
        let contact = |k: usize| -> Complex64 {
            let r = fx.contact_ohm * TAB_SPREAD[k];
            if fx.contact_cap_f > 0.0 && r > 0.0 {
                Complex64::new(1.0 / r, w * fx.contact_cap_f).inv()
            } else {
                Complex64::new(r, 0.0)
            }
        };
        let dc = |k: usize| fx.contact_ohm * TAB_SPREAD[k];
        let z_sensor = z_line + lead(r_top) + lead(r_bot) + contact(0) + contact(2);
        let z = if fx.parasitic_f > 0.0 {
            (z_sensor.inv() + Complex64::new(0.0, w * fx.parasitic_f)).inv()
        } else {
            z_sensor
        };
        Reading {
            z,
            r_top_ohm: r_top + 2.0 * lead(r_top) + dc(0) + dc(1),
            r_bottom_ohm: r_bot + 2.0 * lead(r_bot) + dc(2) + dc(3),
            c_true_f: c_true,
        }
    }
}

/// Series-model capacitance of `z` at `freq_hz` (what an LCR meter's Cs
/// reads), F.
pub fn series_c(z: Complex64, freq_hz: f64) -> f64 {
    -1.0 / (2.0 * PI * freq_hz * z.im)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The continuous uniform line: Z = √(z/y)·coth(√(zy)).
    fn coth_line(r: f64, c: f64, f: f64) -> Complex64 {
        let z = Complex64::new(r, 0.0);
        let y = Complex64::new(0.0, 2.0 * PI * f * c);
        let g = (z * y).sqrt();
        (z / y).sqrt() * (g.cosh() / g.sinh())
    }

    #[test]
    fn the_uniform_ladder_converges_to_the_continuous_line() {
        let s = Sensor::BENCH;
        for f in [100.0, 500.0, 2000.0, 6000.0, 20000.0] {
            let exact = coth_line(s.r0_top_ohm + s.r0_bottom_ohm, s.c0_f, f);
            let mut last = f64::INFINITY;
            for cells in [10, 40, 160] {
                let t = Sensor { cells, ..s };
                let z = t
                    .read(
                        &Effects::default(),
                        State {
                            stretch_mm: 0.0,
                            damage: 0.0,
                        },
                        f,
                    )
                    .z;
                let err = ((z - exact).norm() / exact.norm()).abs();
                // Symmetric cells: second order in 1/n.
                assert!(
                    err < last / 10.0 || err < 1e-9,
                    "f {f}, n {cells}: {err} after {last}"
                );
                last = err;
            }
            assert!(last < 2e-5, "f {f}: {last}");
        }
    }

    #[test]
    fn the_bench_sensor_reads_as_the_continuous_line_within_a_thousandth_of_a_pf() {
        // Across the bench's range: rest to full stroke with a damaged
        // film (R × 3.5 at 30 mm), 200 Hz to 10 kHz (ωRC up to ~40).
        let s = Sensor::BENCH;
        let mut worst: f64 = 0.0;
        for f in [200.0, 500.0, 2000.0, 6000.0, 10000.0] {
            for (st, d) in [(0.0, 0.0), (15.0, 0.2), (30.0, 0.0), (30.0, 0.4)] {
                let r = s.read(
                    &Effects::default(),
                    State {
                        stretch_mm: st,
                        damage: d,
                    },
                    f,
                );
                let exact = coth_line(r.r_top_ohm + r.r_bottom_ohm, r.c_true_f, f);
                worst = worst.max((series_c(r.z, f) - series_c(exact, f)).abs());
            }
        }
        assert!(worst < 1e-15, "{worst}");
    }

    #[test]
    fn profiles_have_unit_mean_and_leave_totals_alone() {
        for k in [-3.0, -0.5, 0.0, 1.0, 3.0] {
            let n = 100_000;
            let m: f64 = (0..n)
                .map(|i| exp_profile(k, (i as f64 + 0.5) / n as f64))
                .sum::<f64>()
                / n as f64;
            assert!((m - 1.0).abs() < 1e-8, "{k}: {m}");
            let m: f64 = (0..n)
                .map(|i| sin_profile(k / 3.0, (i as f64 + 0.5) / n as f64))
                .sum::<f64>()
                / n as f64;
            assert!((m - 1.0).abs() < 1e-8, "{k}: {m}");
        }
        let s = Sensor::BENCH;
        let st = State {
            stretch_mm: 0.0,
            damage: 0.0,
        };
        let plain = s.read(&Effects::default(), st, 500.0);
        let graded = s.read(
            &Effects {
                resistance_kappa: 2.0,
                ..Default::default()
            },
            st,
            500.0,
        );
        assert!((graded.r_top_ohm / plain.r_top_ohm - 1.0).abs() < 1e-3);
        assert!((graded.c_true_f / plain.c_true_f - 1.0).abs() < 1e-12);
    }

    #[test]
    fn wiring_adds_what_it_should() {
        let s = Sensor::BENCH;
        let st = State {
            stretch_mm: 10.0,
            damage: 0.2,
        };
        let plain = s.read(&Effects::default(), st, 2000.0);
        let fx = Effects {
            contact_ohm: 10e3,
            lead_fraction: 0.4,
            ..Default::default()
        };
        let r = s.read(&fx, st, 2000.0);
        let tabs = 10e3 * (TAB_SPREAD[0] + TAB_SPREAD[1]);
        assert!((r.r_top_ohm - plain.r_top_ohm / 0.6 - tabs).abs() < 1e-6);
        let series =
            10e3 * (TAB_SPREAD[0] + TAB_SPREAD[2]) + 0.5 * 0.4 / 0.6 * (plain.r_top_ohm + plain.r_bottom_ohm);
        assert!(((r.z - plain.z).re - series).abs() < 1e-6);
        assert!((r.z - plain.z).im.abs() < 1e-9);
        // A parallel capacitance at low frequency adds to Cs.
        let p = s.read(
            &Effects {
                parasitic_f: 10e-12,
                ..Default::default()
            },
            st,
            20.0,
        );
        let q = s.read(&Effects::default(), st, 20.0);
        let d = series_c(p.z, 20.0) - series_c(q.z, 20.0);
        assert!((d - 10e-12).abs() < 0.01e-12, "{d}");
    }
}
