//! A data set from the bench, in the interchange format
//! (`docs/data-format.md`): static calibration points at 500 Hz, static
//! frequency sweeps at three stretches, and traces of the rig's stroke
//! cycles at two speeds and three frequencies.
//!
//! The film's resistance has its own dynamics here ([`Film`]): damage
//! that grows with the strain rate (more when released than when
//! stretched) and heals exponentially.

use crate::meter::{Dynamics, Exponential, Meter, SAMPLE_S};
use crate::motion::Cycle;
use crate::sensor::{series_c, Effects, Sensor, State};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::io;
use std::path::Path;

/// The film's dynamic damage: dD/dt = k·|λ̇|·(1 + a·[λ̇ < 0]) − D/τ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Film {
    /// Damage per unit of stretch-ratio change.
    pub gain: f64,
    /// Extra on release (λ̇ < 0), fraction.
    pub release_extra: f64,
    /// Healing time, s.
    pub heal_s: f64,
}

impl Film {
    /// The bench's film: a 20 mm/s stroke cycle raises R by about a
    /// quarter, healing in 0.6 s.
    pub const BENCH: Film = Film {
        gain: 0.9,
        release_extra: 0.6,
        heal_s: 0.6,
    };
}

/// The bench's row interval, s (50 readings a second, the paper's LCR
/// meter's rate).
pub const ROW_S: f64 = 0.02;

/// Everything the bench needs to make a data set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bench {
    /// The sensor.
    pub sensor: Sensor,
    /// Its film's dynamics.
    pub film: Film,
    /// Its non-ideal effects.
    pub effects: Effects,
    /// The LCR meter.
    pub meter: Meter,
    /// Row interval of the traces, s.
    pub row_s: f64,
    /// Seed of the noise.
    pub seed: u64,
}

/// A trace's rows on the meter's sample grid.
struct Grid {
    /// The first sample the meter takes, s.
    t0: f64,
    /// Samples per row.
    step: usize,
    /// The row interval, s (`step` samples).
    row_s: f64,
    /// How many rows.
    rows: usize,
    /// The meter's time offset of a reading from its row, s.
    offset: f64,
}

impl Grid {
    /// Row k's time stamp, s.
    fn time(&self, k: usize) -> f64 {
        k as f64 * self.row_s
    }

    /// Each row's reading through the meter's `dynamics`, from its
    /// samples `z_at(t)`.
    fn readings(&self, dynamics: Dynamics, z_at: &dyn Fn(f64) -> Complex64) -> Vec<Complex64> {
        match dynamics {
            Dynamics::Instant => (0..self.rows).map(|k| z_at(self.time(k) + self.offset)).collect(),
            Dynamics::Window { length_s, centred } => self.window(length_s, centred, z_at),
            Dynamics::FirstOrder { tau_s } => self.first_order(tau_s, z_at),
            Dynamics::Cascade { tau_s, sections } => self.cascade(tau_s, sections, z_at),
            Dynamics::MovingMean { .. } | Dynamics::Ewma { .. } => self.discrete(dynamics, z_at),
        }
    }

    /// n samples over `length_s` ending at the row's time (trailing) or
    /// centred on it; the rows' windows overlap, so the samples are
    /// taken once and summed by prefix sums.
    fn window(&self, length_s: f64, centred: bool, z_at: &dyn Fn(f64) -> Complex64) -> Vec<Complex64> {
        let n = ((length_s / SAMPLE_S).round() as usize).max(1);
        let shift = if centred { 0.5 * (n - 1) as f64 } else { 0.0 };
        let first = self.offset + (shift - (n - 1) as f64) * SAMPLE_S;
        let m = (self.rows - 1) * self.step + n;
        let mut prefix = Vec::with_capacity(m + 1);
        let mut acc = Complex64::default();
        prefix.push(acc);
        for i in 0..m {
            acc += z_at(first + i as f64 * SAMPLE_S);
            prefix.push(acc);
        }
        (0..self.rows)
            .map(|k| (prefix[k * self.step + n] - prefix[k * self.step]) / n as f64)
            .collect()
    }

    /// A first-order average of time constant `tau_s` along the meter's
    /// samples; each row takes the average at the sample just before its
    /// time, advanced over the remaining fraction of a sample.
    fn first_order(&self, tau_s: f64, z_at: &dyn Fn(f64) -> Complex64) -> Vec<Complex64> {
        let mut avg = Exponential::new(tau_s);
        let mut out = Vec::with_capacity(self.rows);
        let mut t = self.t0;
        let mut y = avg.update(z_at(t));
        for k in 0..self.rows {
            let target = self.time(k) + self.offset;
            while t + SAMPLE_S <= target {
                t += SAMPLE_S;
                y = avg.update(z_at(t));
            }
            let frac = (target - t) / SAMPLE_S;
            let decay = (-(target - t) / tau_s).exp();
            let zt = z_at(target);
            out.push(if frac > 0.0 { zt + (y - zt) * decay } else { y });
        }
        out
    }

    /// `sections` first-order averages of time constant `tau_s` in
    /// series, each averaging the one before it sample by sample; a row
    /// takes the sections at the sample just before its time, each
    /// advanced over the remaining fraction of a sample towards its
    /// input there.
    fn cascade(&self, tau_s: f64, sections: usize, z_at: &dyn Fn(f64) -> Complex64) -> Vec<Complex64> {
        let mut avgs: Vec<Exponential> = (0..sections.max(1)).map(|_| Exponential::new(tau_s)).collect();
        let run = |avgs: &mut Vec<Exponential>, z: Complex64| avgs.iter_mut().fold(z, |x, a| a.update(x));
        let mut out = Vec::with_capacity(self.rows);
        let mut t = self.t0;
        run(&mut avgs, z_at(t));
        for k in 0..self.rows {
            let target = self.time(k) + self.offset;
            while t + SAMPLE_S <= target {
                t += SAMPLE_S;
                run(&mut avgs, z_at(t));
            }
            let decay = (-(target - t) / tau_s).exp();
            let y = avgs.iter().fold(z_at(target), |x, a| x + (a.value() - x) * decay);
            out.push(y);
        }
        out
    }

    /// One reading per row at the row's time, from `back` rows before
    /// the first; row k reads the kernel over the readings up to
    /// k − delay.
    fn discrete(&self, dynamics: Dynamics, z_at: &dyn Fn(f64) -> Complex64) -> Vec<Complex64> {
        let back = dynamics.rows_back();
        let reading = |j: usize| z_at((j as f64 - back as f64) * self.row_s + self.offset);
        let inst: Vec<Complex64> = (0..self.rows + back).map(reading).collect();
        match dynamics {
            Dynamics::MovingMean { readings, delay } => {
                let n = readings.max(1);
                (0..self.rows)
                    .map(|k| {
                        let last = k + back - delay;
                        inst[last + 1 - n..=last].iter().sum::<Complex64>() / n as f64
                    })
                    .collect()
            }
            Dynamics::Ewma { weight, delay } => {
                let mut y = inst[0];
                let filtered: Vec<Complex64> = inst
                    .iter()
                    .map(|&x| {
                        y = x * weight + y * (1.0 - weight);
                        y
                    })
                    .collect();
                (0..self.rows).map(|k| filtered[k + back - delay]).collect()
            }
            _ => unreachable!("a discrete kernel"),
        }
    }
}

impl Bench {
    /// The seed of the repository's example data set (`data/example/`).
    pub const EXAMPLE_SEED: u64 = 2026;

    /// The bench of the repository's example data set (`data/example/`,
    /// written by `cargo xtask example-data`): the bench's sensor and film,
    /// no effect beyond the uniform line, the bench's meter, noise from
    /// [`Bench::EXAMPLE_SEED`].
    pub fn example() -> Self {
        Self::new(Effects::default(), Meter::BENCH, Self::EXAMPLE_SEED)
    }

    /// The bench with `effects` and `meter`, noise from `seed`.
    pub fn new(effects: Effects, meter: Meter, seed: u64) -> Self {
        Self {
            sensor: Sensor::BENCH,
            film: Film::BENCH,
            effects,
            meter,
            row_s: ROW_S,
            seed,
        }
    }
}

/// One trace row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Rig time, s.
    pub time_s: f64,
    /// Rig stretch, mm.
    pub stretch_mm: f64,
    /// Ohmmeter, top electrode, Ω.
    pub r_top_ohm: f64,
    /// Ohmmeter, bottom electrode, Ω.
    pub r_bottom_ohm: f64,
    /// LCR meter Cs, pF.
    pub cs_pf: f64,
    /// LCR meter Rs, Ω.
    pub rs_ohm: f64,
    /// The sensor's true capacitance at the time stamp, pF.
    pub c_true_pf: f64,
}

/// The film's damage along a cycle, sampled every [`SAMPLE_S`] from `t0`.
struct Damage {
    t0: f64,
    d: Vec<f64>,
}

impl Damage {
    fn new(sensor: &Sensor, film: &Film, cycle: &Cycle, t0: f64, t1: f64) -> Self {
        let n = ((t1 - t0) / SAMPLE_S).ceil() as usize + 2;
        let heal = (-SAMPLE_S / film.heal_s).exp();
        let mut d = Vec::with_capacity(n);
        let mut last = sensor.lambda(cycle.stretch_mm(t0));
        let mut acc = 0.0;
        for j in 0..n {
            let lam = sensor.lambda(cycle.stretch_mm(t0 + j as f64 * SAMPLE_S));
            let dl = lam - last;
            let k = if dl < 0.0 { 1.0 + film.release_extra } else { 1.0 };
            acc = acc * heal + film.gain * k * dl.abs();
            d.push(acc);
            last = lam;
        }
        Self { t0, d }
    }

    fn at(&self, t: f64) -> f64 {
        let u = ((t - self.t0) / SAMPLE_S).max(0.0);
        let j = (u.floor() as usize).min(self.d.len() - 2);
        let a = (u - j as f64).min(1.0);
        self.d[j] + a * (self.d[j + 1] - self.d[j])
    }
}

/// Round `v` to `decimals`.
fn round(v: f64, decimals: i32) -> f64 {
    let s = 10f64.powi(decimals);
    (v * s).round() / s
}

impl Bench {
    /// A trace of `cycle` at `freq_hz`: the film's damage, the meter's
    /// dynamics and its noise act on the same millisecond samples, in the
    /// order a bench's instruments see them.
    pub fn trace(&self, cycle: &Cycle, freq_hz: f64, rng: &mut ChaCha8Rng) -> Vec<Row> {
        let (before, after) = self.meter.reach(self.row_s);
        let t_end = cycle.duration_s();
        let t0 = -before - 1.0;
        let damage = Damage::new(&self.sensor, &self.film, cycle, t0, t_end + after + 1.0);
        let state = |t: f64| State {
            stretch_mm: cycle.stretch_mm(t),
            damage: damage.at(t),
        };
        let fx = &self.effects;
        // A sample of the meter: (Cs pF, Rs Ω) as a complex pair, so the
        // averages run on the readings themselves.
        let z_at = |t: f64| {
            let z = self.sensor.read(fx, state(t), freq_hz).z;
            Complex64::new(series_c(z, freq_hz) * 1e12, z.re)
        };
        // Rows on the meter's sample grid (the row interval rounded to
        // whole samples).
        let step = ((self.row_s / SAMPLE_S).round() as usize).max(1);
        let grid = Grid {
            t0,
            step,
            row_s: step as f64 * SAMPLE_S,
            rows: (t_end / (step as f64 * SAMPLE_S)).floor() as usize + 1,
            offset: self.meter.offset_s,
        };
        let readings = grid.readings(self.meter.dynamics, &z_at);
        let noise = self.meter.noise;
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let mut drift = noise.drift_pf * unit.sample(rng);
        let innov = (1.0 - noise.drift_rho * noise.drift_rho).sqrt();
        (0..grid.rows)
            .map(|k| grid.time(k))
            .zip(readings)
            .map(|(t, z)| {
                let truth = self.sensor.read(fx, state(t), freq_hz);
                let cs = z.re;
                drift = noise.drift_rho * drift + innov * noise.drift_pf * unit.sample(rng);
                let cs = cs + noise.white_pf(cs, freq_hz) * unit.sample(rng) + drift;
                let rel = noise.resistance_relative;
                let mut ohm = |r: f64| round(r * (1.0 + rel * unit.sample(rng)), 0);
                Row {
                    time_s: round(t, 4),
                    stretch_mm: round(cycle.stretch_mm(t), 3),
                    r_top_ohm: ohm(truth.r_top_ohm),
                    r_bottom_ohm: ohm(truth.r_bottom_ohm),
                    cs_pf: round(cs, 3),
                    rs_ohm: ohm(z.im),
                    c_true_pf: truth.c_true_f * 1e12,
                }
            })
            .collect()
    }

    /// A static point (film at rest): stretch, Cs, Rs, R top, R bottom.
    fn point(&self, stretch_mm: f64, freq_hz: f64, rng: &mut ChaCha8Rng) -> [f64; 5] {
        let st = State {
            stretch_mm,
            damage: 0.0,
        };
        let r = self.sensor.read(&self.effects, st, freq_hz);
        let noise = self.meter.noise;
        let k = noise.static_average.max(1) as f64;
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let cs = series_c(r.z, freq_hz) * 1e12;
        let sigma = noise.white_pf(cs, freq_hz) / k.sqrt();
        let rel = noise.resistance_relative / k.sqrt();
        let cs = round(cs + sigma * unit.sample(rng), 3);
        let mut ohm = |v: f64| round(v * (1.0 + rel * unit.sample(rng)), 0);
        [stretch_mm, cs, ohm(r.z.re), ohm(r.r_top_ohm), ohm(r.r_bottom_ohm)]
    }

    /// Write the data set into `dir` (created if missing): `calibration.csv`,
    /// `sweep.csv` and `trace_{speed}mmps_{freq}hz.csv` for 10 and 20 mm/s at
    /// 500, 2000 and 6000 Hz.
    pub fn write(&self, dir: &Path) -> io::Result<()> {
        std::fs::create_dir_all(dir)?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let header = [
            "stretch_mm",
            "freq_hz",
            "cs_pf",
            "rs_ohm",
            "r_top_ohm",
            "r_bottom_ohm",
        ];
        let mut cal = csv::Writer::from_path(dir.join("calibration.csv"))?;
        cal.write_record(header)?;
        for i in 0..=10 {
            let p = self.point(3.0 * i as f64, 500.0, &mut rng);
            cal.write_record(static_row(p, 500.0))?;
        }
        cal.flush()?;
        let mut sweep = csv::Writer::from_path(dir.join("sweep.csv"))?;
        sweep.write_record(header)?;
        for s in [0.0, 15.0, 30.0] {
            for j in 0..12 {
                let f = round(200.0 * 50f64.powf(j as f64 / 11.0), 1);
                let p = self.point(s, f, &mut rng);
                sweep.write_record(static_row(p, f))?;
            }
        }
        sweep.flush()?;
        for (speed, cycles) in [(10.0, 3), (20.0, 4)] {
            for f in [500.0, 2000.0, 6000.0] {
                // Each trace its own stream, so traces do not depend on
                // the order they are written in.
                let mut trng = ChaCha8Rng::seed_from_u64(self.seed ^ ((speed as u64) << 32) ^ f as u64);
                let rows = self.trace(&Cycle::bench(speed, cycles), f, &mut trng);
                let mut w = csv::Writer::from_path(dir.join(format!("trace_{speed:.0}mmps_{f:.0}hz.csv")))?;
                w.write_record([
                    "time_s",
                    "stretch_mm",
                    "r_top_ohm",
                    "r_bottom_ohm",
                    "freq_hz",
                    "cs_pf",
                    "rs_ohm",
                    "c_true_pf",
                ])?;
                for r in rows {
                    w.write_record([
                        r.time_s.to_string(),
                        r.stretch_mm.to_string(),
                        r.r_top_ohm.to_string(),
                        r.r_bottom_ohm.to_string(),
                        f.to_string(),
                        r.cs_pf.to_string(),
                        r.rs_ohm.to_string(),
                        format!("{:.4}", r.c_true_pf),
                    ])?;
                }
                w.flush()?;
            }
        }
        Ok(())
    }
}

fn static_row(p: [f64; 5], f: f64) -> [String; 6] {
    [
        p[0].to_string(),
        f.to_string(),
        p[1].to_string(),
        p[2].to_string(),
        p[3].to_string(),
        p[4].to_string(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_cycling_raises_the_resistance_and_it_heals() {
        let b = Bench::new(Effects::default(), Meter::BENCH, 1);
        let c = Cycle::bench(20.0, 2);
        let d = Damage::new(&b.sensor, &b.film, &c, -1.0, c.duration_s() + 5.0);
        let peak = (0..2000).map(|i| d.at(i as f64 * 0.005)).fold(0.0, f64::max);
        assert!(peak > 0.15 && peak < 0.6, "{peak}");
        assert!(d.at(c.duration_s() + 4.5) < 1e-3);
    }

    /// The bench with a noiseless meter of `dynamics`, late by
    /// `offset_s`, rows every `row_s`.
    fn quiet(dynamics: Dynamics, offset_s: f64, row_s: f64) -> Bench {
        let noise = crate::meter::Noise {
            floor_pf: 0.0,
            relative_500hz: 0.0,
            drift_pf: 0.0,
            resistance_relative: 0.0,
            ..crate::meter::Noise::BENCH
        };
        Bench {
            row_s,
            ..Bench::new(
                Effects::default(),
                Meter {
                    dynamics,
                    offset_s,
                    noise,
                },
                1,
            )
        }
    }

    #[test]
    fn windows_average_the_instant_samples_they_cover() {
        let mk = |dynamics, row_s| quiet(dynamics, 0.05, row_s);
        let c = Cycle::bench(20.0, 1);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let samples = mk(Dynamics::Instant, SAMPLE_S).trace(&c, 2000.0, &mut rng);
        for centred in [false, true] {
            let w = mk(
                Dynamics::Window {
                    length_s: 0.201,
                    centred,
                },
                0.02,
            )
            .trace(&c, 2000.0, &mut rng);
            let mut worst: f64 = 0.0;
            // Rows whose window lies inside the recording.
            for (k, row) in w.iter().enumerate().skip(11).take(w.len() - 22) {
                let end = 20 * k + if centred { 100 } else { 0 };
                let mean = samples[end - 200..=end].iter().map(|r| r.cs_pf).sum::<f64>() / 201.0;
                worst = worst.max((row.cs_pf - mean).abs());
            }
            // Both rounded to the meter's 0.001 pF.
            assert!(worst <= 0.0011, "centred {centred}: {worst}");
        }
    }

    /// The discrete meters: a moving mean of N row readings, or an
    /// exponentially weighted one, each some rows late, against the same
    /// bench's instant readings row by row.
    #[test]
    fn discrete_meters_average_their_own_readings() {
        let mk = |dynamics| quiet(dynamics, 0.0, ROW_S);
        let c = Cycle::bench(20.0, 1);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let inst = mk(Dynamics::Instant).trace(&c, 2000.0, &mut rng);
        let mean = mk(Dynamics::MovingMean {
            readings: 5,
            delay: 2,
        })
        .trace(&c, 2000.0, &mut rng);
        let (w, d) = (0.3, 1);
        let ewma = mk(Dynamics::Ewma { weight: w, delay: d }).trace(&c, 2000.0, &mut rng);
        assert_eq!((mean.len(), ewma.len()), (inst.len(), inst.len()));
        let (mut worst_mean, mut worst_ewma): (f64, f64) = (0.0, 0.0);
        let mut y = inst[0].cs_pf;
        for k in 0..inst.len() {
            if k >= 6 {
                let want = inst[k - 6..=k - 2].iter().map(|r| r.cs_pf).sum::<f64>() / 5.0;
                worst_mean = worst_mean.max((mean[k].cs_pf - want).abs());
            }
            if k >= d {
                y = w * inst[k - d].cs_pf + (1.0 - w) * y;
                // Settled after 40 rows (0.7⁴⁰ < 10⁻⁶ of the start).
                if k >= 40 {
                    worst_ewma = worst_ewma.max((ewma[k].cs_pf - y).abs());
                }
            }
        }
        // Rounded to 0.001 pF on both sides.
        assert!(
            worst_mean <= 0.0011 && worst_ewma <= 0.0011,
            "{worst_mean} {worst_ewma}"
        );
        // It moves: the kernels are not the instant readings.
        let moved = (0..inst.len())
            .map(|k| (mean[k].cs_pf - inst[k].cs_pf).abs())
            .fold(0.0, f64::max);
        assert!(moved > 0.1, "{moved}");
        // Centroids: (N − 1)/2 + delay rows, (1 − w)/w + delay rows.
        let row = 0.02;
        let m = Dynamics::MovingMean {
            readings: 5,
            delay: 2,
        };
        assert!((m.centroid_s(row) - 4.0 * row).abs() < 1e-12);
        let e = Dynamics::Ewma {
            weight: 0.25,
            delay: 1,
        };
        assert!((e.centroid_s(row) - 4.0 * row).abs() < 1e-12);
    }
}
