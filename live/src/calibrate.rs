//! `live calibrate`: each sensor's line, its tab leads and its wiring
//! fitted from the records a device took while the skin was held at known
//! stretches, and its stretch table from the same fit.
//!
//! # What is fitted
//! For each sensor, from the measured impedances Z (the records' two
//! tones, Ω, before any de-embedding) within each hold:
//!
//! ```text
//! Z = 1 / (1/(Z_line(R, C) + ℓ·R + R_s) + jω·C_p),   Z_line = R·coth(γ)/γ,  γ = √(jωRC)
//! ```
//!
//! the uniform line of the firmware (`dsp_core::tline`), its tab leads ℓ
//! (line resistances in series at the read end), a series contact R_s
//! and a parasitic capacitance C_p at the meter: the three the device
//! keeps per sensor (`instrument::stored::SensorSettings`). C is one
//! unknown per hold (it follows stretch alone); R one per part of a hold
//! ([`Options::parts`]) and pair of tones (a sweep measures each pair at
//! its own time), since the electrodes' resistance still recovers from
//! the move before it. The fit is weighted least squares
//! (Levenberg–Marquardt) on each part's mean impedance per tone, with the
//! scatter of its records as σ, floored at [`SIGMA_FLOOR`] of |Z|.
//!
//! # What the data cannot tell apart
//! Leads and contact are both a series resistance: only the way the
//! series part follows the line's resistance from hold to hold tells
//! them apart (leads scale with R, a contact does not). The report gives
//! each fitted value with its 1σ and the correlation of the pair, and
//! names the pair as unresolved where they trade against each other;
//! the fit's C is what the table is built on either way.
//!
//! # When a sensor is refused
//! A fit that does not explain its data (χ²/dof above [`CHI2_MAX`]), a
//! C that does not ascend with stretch, a hold with too few usable
//! records, or values outside the device's ranges: that sensor keeps what
//! the device held, and the report says why.

use anyhow::{bail, Context, Result};
use instrument::calib::POINTS;
use instrument::faults::Flags;
use instrument::stored::{SensorSettings, Stored, SENSORS_MAX};
use num_complex::Complex64;
use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::Path;

/// The floor of each mean impedance's σ, relative to |Z|: below it the
/// front end's own calibration, not the noise, limits (a transimpedance
/// and a phase known to 10⁻⁴).
pub const SIGMA_FLOOR: f64 = 1e-4;

/// The largest χ²/dof a sensor's fit may leave: beyond it the model does
/// not explain the data and the sensor is refused.
pub const CHI2_MAX: f64 = 4.0;

/// Correlation beyond which two fitted values are reported as trading
/// against each other.
pub const DEGENERATE: f64 = 0.95;

/// Flags of records whose impedances are not used (biased tones, no
/// tones, or the block after a tone switch).
const UNUSABLE: u16 = Flags::CLIPPED | Flags::OPEN | Flags::SHORTED | Flags::DISTURBED | Flags::SETTLING;

/// One hold: the skin at a known stretch for a span of the device's
/// clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Stretch held, mm.
    pub stretch_mm: f64,
    /// Start of the span, s since the device's start.
    pub from_s: f64,
    /// End of the span, s.
    pub to_s: f64,
}

/// The header of a holds file.
pub const HOLDS_HEADER: &str = "stretch_mm,from_s,to_s";

/// Read a holds file: CSV with the header [`HOLDS_HEADER`], one hold per
/// line. Errors name the file, line, column and reason; at least two
/// holds at different stretches, spans that do not overlap.
pub fn read_holds(path: &Path) -> Result<Vec<Hold>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_holds(&text).map_err(|e| anyhow::anyhow!("{}:{e}", path.display()))
}

/// [`read_holds`] on text; errors start with `line:column: `.
pub fn parse_holds(text: &str) -> Result<Vec<Hold>> {
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == HOLDS_HEADER => {}
        _ => bail!("1:1: the header must be '{HOLDS_HEADER}'"),
    }
    let mut holds: Vec<Hold> = vec![];
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let mut v = [0.0f64; 3];
        let mut col = 1;
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 3 {
            bail!("{n}:1: {} fields, not 3 ({HOLDS_HEADER})", fields.len());
        }
        for (k, f) in fields.iter().enumerate() {
            v[k] = match f.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => bail!("{n}:{col}: '{}' is not a finite number", f.trim()),
            };
            col += f.len() + 1;
        }
        let h = Hold {
            stretch_mm: v[0],
            from_s: v[1],
            to_s: v[2],
        };
        if !(h.from_s >= 0.0 && h.to_s > h.from_s) {
            bail!("{n}:1: the span must start at 0 s or later and end after it starts");
        }
        if !(0.0..=1000.0).contains(&h.stretch_mm) {
            bail!("{n}:1: stretch {} mm is outside 0 … 1000 mm", h.stretch_mm);
        }
        if let Some(p) = holds.iter().find(|p| p.from_s < h.to_s && h.from_s < p.to_s) {
            bail!("{n}:1: its span overlaps the hold at {} mm", p.stretch_mm);
        }
        if holds.iter().any(|p| p.stretch_mm == h.stretch_mm) {
            bail!("{n}:1: a second hold at {} mm", h.stretch_mm);
        }
        holds.push(h);
    }
    if holds.len() < 2 {
        bail!(
            "{}:1: {} holds: a calibration needs two stretches at least",
            text.lines().count(),
            holds.len()
        );
    }
    Ok(holds)
}

/// Write a holds file (read back by [`read_holds`]).
pub fn write_holds(path: &Path, holds: &[Hold]) -> Result<()> {
    let mut s = format!("{HOLDS_HEADER}\n");
    for h in holds {
        writeln!(s, "{},{},{}", h.stretch_mm, h.from_s, h.to_s)?;
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
}

/// How the fit splits and weighs the records.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Parts of each hold, each with its own electrode resistance.
    pub parts: usize,
    /// Records a part of a hold needs at one tone to be used.
    pub min_records: usize,
    /// The span of the device's clock (from, to: s) in which every
    /// sensor was unplugged and its cable left on the front end (an
    /// open fixture): what each sensor reads then is its cable's
    /// admittance jω·C_p, fitted together with the holds.
    pub open: Option<Span>,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            parts: 3,
            min_records: 5,
            open: None,
        }
    }
}

/// Flags of records whose tones are not used in an open fixture's span
/// (an open sensor is flagged open or off its table, and is measured).
const UNUSABLE_OPEN: u16 = Flags::CLIPPED | Flags::DISTURBED | Flags::SETTLING;

/// The impedances of a part of a hold, per tone (Hz as the records
/// carry it).
type Tones = Vec<(f32, Vec<Complex64>)>;

/// One mean impedance: a part of a hold, at one tone; or the open
/// fixture's mean admittance at one tone.
#[derive(Clone, Copy, Debug)]
struct Obs {
    /// Hold (index into the sorted holds; [`OPEN`] for the open
    /// fixture).
    hold: usize,
    /// Resistance unknown (hold and part).
    part: usize,
    /// Hz.
    f_hz: f64,
    /// Mean Z, Ω (the open fixture's: mean Y, S).
    z: Complex64,
    /// σ of each component of the mean, Ω (S).
    sigma: f64,
}

/// Add `z` to the values at tone `f_hz` (Hz as the records carry it).
fn push_at(tones: &mut Tones, f_hz: f32, z: Complex64) {
    match tones.iter_mut().find(|(f, _)| *f == f_hz) {
        Some((_, v)) => v.push(z),
        None => tones.push((f_hz, vec![z])),
    }
}

/// The mean of `v` (at least two values) and the 1σ of each of its
/// components, from their scatter.
fn mean_sigma(v: &[Complex64]) -> (Complex64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<Complex64>() / n;
    let var = v.iter().map(|z| (z - mean).norm_sqr()).sum::<f64>() / (2.0 * (n - 1.0));
    (mean, (var / n).sqrt())
}

/// A span of the device's clock: from, to, s.
pub type Span = (f64, f64);

/// [`Obs::hold`] of the open fixture.
const OPEN: usize = usize::MAX;

/// The line's impedance on a film of loss tangent `tan_d` (C·(1 − j·tan δ)),
/// with leads, contact and parasitic capacitance.
fn model(f_hz: f64, r: f64, c: f64, lead: f64, rs: f64, cp: f64, tan_d: f64) -> Complex64 {
    let w = TAU * f_hz;
    let g = (Complex64::new(0.0, w * r * c) * Complex64::new(1.0, -tan_d)).sqrt();
    let line = r * (g.cosh() / g.sinh()) / g;
    let zs = line + lead * r + rs;
    (zs.inv() + Complex64::new(0.0, w * cp)).inv()
}

/// The global unknowns of a sensor's fit: ℓ, R_s, C_p, and the film's
/// loss tangent tan δ (each tone's sweep at every hold tells a loss,
/// a resistance ∝ 1/f, from a contact, flat in f; the device takes its
/// film's loss from the settings, `dsp_core::dielectric`, not from here).
const GLOBALS: usize = 4;
/// Scale of the global unknowns in the fit's vector: ℓ, R_s/100 kΩ,
/// C_p/pF, tan δ/10⁻³.
const SCALE: [f64; GLOBALS] = [1.0, 1e5, 1e-12, 1e-3];
/// Their bounds, SI (the device's ranges, `instrument::stored`; tan δ
/// to 0.1, the lossiest films).
const BOUNDS: [(f64, f64); GLOBALS] = [
    (0.0, dsp_core::invert::LEAD_MAX as f64),
    (0.0, 10e6),
    (0.0, 1e-9),
    (0.0, 0.1),
];

/// A sensor's fit.
#[derive(Clone, Debug)]
pub struct SensorFit {
    /// Sensor.
    pub sensor: u8,
    /// Records used.
    pub records: usize,
    /// Tab leads ℓ, contact R_s (Ω), parasitic C_p (F), the film's loss
    /// tangent.
    pub values: [f64; GLOBALS],
    /// Their 1σ (NaN: at a bound, not free).
    pub sigma: [f64; GLOBALS],
    /// Correlation of leads and contact.
    pub rho_lead_contact: f64,
    /// Line C at each hold, F (in the holds' order of stretch).
    pub c_farad: Vec<f64>,
    /// Line R at each hold (mean of its parts), Ω.
    pub r_ohm: Vec<f64>,
    /// χ²/dof of the fit, and dof.
    pub chi2_dof: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// Each hold's C as the device read it (its records' mean), F.
    pub c_read_farad: Vec<f64>,
    /// The open fixture's C_p alone (Im Y/ω over its tones, weighted)
    /// and its 1σ, F; None without an open fixture.
    pub open_cp: Option<(f64, f64)>,
}

/// The outcome for one sensor.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// Fitted and checked.
    Fitted(SensorFit),
    /// Refused: why. The device keeps what it held for this sensor.
    Refused(String),
    /// Not in use in the set calibrated.
    NotInUse,
}

/// Fit one sensor from its records (`records` all of sensor `sensor`).
pub fn fit_sensor(
    sensor: u8,
    records: &[&link::Record],
    holds: &[Hold],
    opts: &Options,
) -> Result<SensorFit, String> {
    let mut order: Vec<usize> = (0..holds.len()).collect();
    order.sort_by(|&a, &b| holds[a].stretch_mm.total_cmp(&holds[b].stretch_mm));
    let parts = opts.parts.max(1);
    let mut obs = vec![];
    // The hold of each part (a slice of a hold at one pair of tones).
    let mut part_hold: Vec<usize> = vec![];
    let mut used = 0;
    let mut c_read = vec![];
    for (k, &h) in order.iter().enumerate() {
        let hold = holds[h];
        let span = hold.to_s - hold.from_s;
        let mut any = false;
        let mut c_sum = (0.0, 0usize);
        for p in 0..parts {
            let (a, b) = (
                hold.from_s + span * p as f64 / parts as f64,
                hold.from_s + span * (p + 1) as f64 / parts as f64,
            );
            // Per pair of tones (a sweep steps through them; each pair's
            // records were taken at their own time of the hold, so each
            // has its own resistance), per tone: the records' impedances.
            let mut groups: Vec<([u32; 2], Tones)> = vec![];
            for r in records {
                let t = r.t_us as f64 * 1e-6;
                if !(t >= a && t < b) || r.flags & UNUSABLE != 0 {
                    continue;
                }
                used += 1;
                if r.c_farad > 0.0 {
                    c_sum = (c_sum.0 + r.c_farad as f64, c_sum.1 + 1);
                }
                let key = r.tones.map(|t| t.f_hz.to_bits());
                let tones = match groups.iter().position(|(k, _)| *k == key) {
                    Some(g) => &mut groups[g].1,
                    None => {
                        groups.push((key, vec![]));
                        &mut groups.last_mut().expect("just pushed").1
                    }
                };
                for tone in r.tones.iter().filter(|t| t.f_hz > 0.0) {
                    let z = Complex64::new(tone.z_re_ohm as f64, tone.z_im_ohm as f64);
                    if !(z.re.is_finite() && z.im.is_finite() && z.im < 0.0) {
                        continue;
                    }
                    push_at(tones, tone.f_hz, z);
                }
            }
            for (_, tones) in groups {
                let part = part_hold.len();
                let mut seen = false;
                for (f, zs) in tones {
                    if zs.len() < opts.min_records {
                        continue;
                    }
                    let (mean, sigma) = mean_sigma(&zs);
                    let sigma = sigma.max(SIGMA_FLOOR * mean.norm());
                    obs.push(Obs {
                        hold: k,
                        part,
                        f_hz: f as f64,
                        z: mean,
                        sigma,
                    });
                    seen = true;
                }
                if seen {
                    part_hold.push(k);
                    any = true;
                }
            }
        }
        if !any {
            return Err(format!(
                "no usable records in the hold at {} mm ({:.2}–{:.2} s)",
                hold.stretch_mm, hold.from_s, hold.to_s
            ));
        }
        c_read.push(if c_sum.1 > 0 {
            c_sum.0 / c_sum.1 as f64
        } else {
            f64::NAN
        });
    }
    // The open fixture: per tone, the mean admittance (an open's
    // impedance is large and its noise is not; its admittance is
    // small, and its noise additive).
    let mut open_records = 0;
    if let Some((a, b)) = opts.open {
        let mut tones: Vec<(f32, Vec<Complex64>)> = vec![];
        for r in records {
            let t = r.t_us as f64 * 1e-6;
            if !(t >= a && t < b) || r.flags & UNUSABLE_OPEN != 0 {
                continue;
            }
            open_records += 1;
            for tone in r.tones.iter().filter(|t| t.f_hz > 0.0) {
                let y = Complex64::new(tone.z_re_ohm as f64, tone.z_im_ohm as f64).inv();
                if !(y.re.is_finite() && y.im.is_finite()) {
                    continue;
                }
                push_at(&mut tones, tone.f_hz, y);
            }
        }
        for (f, ys) in tones.into_iter().filter(|(_, v)| v.len() >= opts.min_records) {
            let (mean, sigma) = mean_sigma(&ys);
            obs.push(Obs {
                hold: OPEN,
                part: OPEN,
                f_hz: f as f64,
                z: mean,
                // Floored as the holds' (relative to |Y| of 1 pF at
                // the tone, for a cable of none).
                sigma: sigma.max(SIGMA_FLOOR * mean.norm().max(TAU * f as f64 * 1e-12)),
            });
        }
        if !obs.iter().any(|o| o.hold == OPEN) {
            return Err(format!(
                "no usable records in the open fixture's span ({a:.2}–{b:.2} s)"
            ));
        }
    }
    used += open_records;
    let open_cp = {
        let (mut sw, mut swx) = (0.0, 0.0);
        for o in obs.iter().filter(|o| o.hold == OPEN) {
            let w = TAU * o.f_hz;
            let weight = (w / o.sigma).powi(2);
            sw += weight;
            swx += weight * o.z.im / w;
        }
        (sw > 0.0).then(|| (swx / sw, sw.sqrt().recip()))
    };
    let n_holds = order.len();
    let n_parts = part_hold.len();
    // Unknowns: the globals, ln C per hold, ln R per part (every part has
    // observations).
    let has_part = vec![true; n_parts];
    let n_par = GLOBALS + n_holds + n_parts;
    // Start: each part's lumped reading at its lowest tone (C = −1/(ωX),
    // R = 3·Re Z, the line's low-frequency resistance).
    let mut start = vec![0.0; n_par];
    for k in 0..n_holds {
        let lowest = obs
            .iter()
            .filter(|o| o.hold == k)
            .min_by(|a, b| a.f_hz.total_cmp(&b.f_hz))
            .expect("a hold with observations");
        start[GLOBALS + k] = (-1.0 / (TAU * lowest.f_hz * lowest.z.im)).ln();
        for part in (0..n_parts).filter(|&p| part_hold[p] == k) {
            let o = obs
                .iter()
                .filter(|o| o.part == part)
                .min_by(|a, b| a.f_hz.total_cmp(&b.f_hz))
                .unwrap_or(lowest);
            start[GLOBALS + n_holds + part] = (3.0 * o.z.re).max(1e3).ln();
        }
    }
    let residuals = |x: &[f64], out: &mut Vec<f64>| {
        out.clear();
        let (lead, rs, cp, tan_d) = (x[0] * SCALE[0], x[1] * SCALE[1], x[2] * SCALE[2], x[3] * SCALE[3]);
        for o in &obs {
            if o.hold == OPEN {
                let d = (Complex64::new(0.0, TAU * o.f_hz * cp) - o.z) / o.sigma;
                out.push(d.re);
                out.push(d.im);
                continue;
            }
            let c = x[GLOBALS + o.hold].exp();
            let r = x[GLOBALS + n_holds + o.part].exp();
            let d = (model(o.f_hz, r, c, lead, rs, cp, tan_d) - o.z) / o.sigma;
            out.push(d.re);
            out.push(d.im);
        }
    };
    let bounds: Vec<(f64, f64)> = (0..n_par)
        .map(|i| match i {
            i if i < GLOBALS => (BOUNDS[i].0 / SCALE[i], BOUNDS[i].1 / SCALE[i]),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        })
        .collect();
    // Several starts for the globals: the fit is not convex in them.
    let mut best: Option<(f64, Vec<f64>)> = None;
    for lead in [0.0, 0.3, 1.0] {
        for cp in [0.0, 10.0] {
            // None, and a silicone's (`Dielectric::SILICONE`), in 10⁻³.
            for loss in [0.0, 3.0] {
                let mut x = start.clone();
                x[0] = lead;
                x[2] = cp;
                x[3] = loss;
                let (cost, x) = levenberg_marquardt(&residuals, x, &bounds, &has_part);
                if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                    best = Some((cost, x));
                }
            }
        }
    }
    let (cost, x) = best.expect("a start");
    // Free unknowns: globals off their bounds, every C, every observed R.
    let free: Vec<usize> = (0..n_par)
        .filter(|&i| match i {
            i if i < GLOBALS => x[i] > bounds[i].0 + 1e-9 && x[i] < bounds[i].1 - 1e-9,
            i if i < GLOBALS + n_holds => true,
            i => has_part[i - GLOBALS - n_holds],
        })
        .collect();
    let m = 2 * obs.len();
    if m <= free.len() {
        return Err(format!(
            "{} mean impedances for {} unknowns: hold longer, or at more stretches",
            obs.len(),
            free.len()
        ));
    }
    let dof = m - free.len();
    let chi2_dof = cost / dof as f64;
    // Covariance of the free unknowns, scaled by χ²/dof when above 1.
    let jac = jacobian(&residuals, &x, &free);
    let mut jtj = vec![vec![0.0; free.len()]; free.len()];
    for (a, row) in jtj.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = (0..m).map(|i| jac[a][i] * jac[b][i]).sum();
        }
    }
    let cov = invert(&jtj).map(|c| {
        let s = chi2_dof.max(1.0);
        c.into_iter()
            .map(|row| row.into_iter().map(|v| v * s).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    });
    let mut sigma = [f64::NAN; GLOBALS];
    let mut rho = f64::NAN;
    if let Some(cov) = &cov {
        let at = |i: usize| free.iter().position(|&f| f == i);
        for (g, s) in sigma.iter_mut().enumerate() {
            if let Some(a) = at(g) {
                *s = cov[a][a].sqrt() * SCALE[g];
            }
        }
        if let (Some(a), Some(b)) = (at(0), at(1)) {
            rho = cov[a][b] / (cov[a][a] * cov[b][b]).sqrt();
        }
    }
    let c: Vec<f64> = (0..n_holds).map(|k| x[GLOBALS + k].exp()).collect();
    let r: Vec<f64> = (0..n_holds)
        .map(|k| {
            let rs: Vec<f64> = (0..n_parts)
                .filter(|&p| part_hold[p] == k)
                .map(|p| x[GLOBALS + n_holds + p].exp())
                .collect();
            rs.iter().sum::<f64>() / rs.len() as f64
        })
        .collect();
    let fit = SensorFit {
        sensor,
        records: used,
        values: core::array::from_fn(|g| x[g] * SCALE[g]),
        sigma,
        rho_lead_contact: rho,
        c_farad: c,
        r_ohm: r,
        chi2_dof,
        dof,
        c_read_farad: c_read,
        open_cp,
    };
    if chi2_dof.is_nan() || chi2_dof > CHI2_MAX {
        return Err(format!(
            "the line with leads, contact, parasitic capacitance and its film's loss does not explain its data \
             (χ²/dof = {chi2_dof:.1} > {CHI2_MAX}): an effect it lacks, or a stretch that moved during a hold"
        ));
    }
    if let Some(k) = (1..n_holds).find(|&k| fit.c_farad[k] <= fit.c_farad[k - 1]) {
        return Err(format!(
            "C does not grow with stretch: {:.2} pF at {} mm, {:.2} pF at {} mm",
            fit.c_farad[k - 1] * 1e12,
            holds[order[k - 1]].stretch_mm,
            fit.c_farad[k] * 1e12,
            holds[order[k]].stretch_mm
        ));
    }
    Ok(fit)
}

impl SensorFit {
    /// The stretches of the holds, ascending (as `c_farad`).
    fn stretches(holds: &[Hold]) -> Vec<f64> {
        let mut s: Vec<f64> = holds.iter().map(|h| h.stretch_mm).collect();
        s.sort_by(f64::total_cmp);
        s
    }

    /// The stretch table: [`POINTS`] points evenly over the holds' span
    /// of stretch, C by linear interpolation between the holds' fitted C.
    pub fn table(&self, holds: &[Hold]) -> [(f32, f32); POINTS] {
        let s = Self::stretches(holds);
        let (lo, hi) = (s[0], s[s.len() - 1]);
        core::array::from_fn(|j| {
            let sj = lo + (hi - lo) * j as f64 / (POINTS - 1) as f64;
            let k = s.partition_point(|&v| v <= sj).clamp(1, s.len() - 1);
            let (s0, s1, c0, c1) = (s[k - 1], s[k], self.c_farad[k - 1], self.c_farad[k]);
            let c = c0 + (c1 - c0) * (sj - s0) / (s1 - s0);
            (c as f32, sj as f32)
        })
    }

    /// The sensor's stored settings from this fit.
    pub fn settings(&self, holds: &[Hold]) -> SensorSettings {
        let table = self.table(holds);
        SensorSettings {
            in_use: true,
            nominal_c_farad: table[0].0,
            nominal_r_ohm: self.r_ohm[0] as f32,
            lead_ratio: self.values[0] as f32,
            contact_ohm: self.values[1] as f32,
            parasitic_farad: self.values[2] as f32,
            table,
            calibrated: true,
        }
    }

    /// What the data cannot tell apart, in words (empty: every value
    /// resolved).
    pub fn unresolved(&self) -> Vec<String> {
        let mut out = vec![];
        if self.rho_lead_contact.abs() > DEGENERATE {
            out.push(format!(
                "tab leads and contact trade against each other (correlation {:.3}): holds whose \
                 electrode resistance differs more, or a short across the sensor's far end, would \
                 separate them",
                self.rho_lead_contact
            ));
        }
        // At 0 a value is simply absent; at its upper bound the fit
        // wanted more than the device takes.
        for (g, name) in ["leads", "contact", "parasitic capacitance", "film loss tangent"]
            .iter()
            .enumerate()
        {
            if self.sigma[g].is_nan() && self.values[g] > BOUNDS[g].0 {
                out.push(format!(
                    "{name}: at the device's limit ({}): the fit wanted more",
                    fmt_value(g, self.values[g])
                ));
            }
        }
        out
    }
}

/// A global value in its unit.
fn fmt_value(g: usize, v: f64) -> String {
    match g {
        0 => format!("{v:.4}"),
        1 => format!("{:.2} kΩ", v / 1e3),
        2 => format!("{:.2} pF", v * 1e12),
        _ => format!("{:.2}·10⁻³", v * 1e3),
    }
}

/// Every sensor of `base` in use, fitted from `records`; the set to store
/// (each fitted sensor from its fit, the others as `base` has them), and
/// each sensor's outcome.
pub fn calibrate(
    records: &[link::Record],
    holds: &[Hold],
    base: &Stored,
    opts: &Options,
) -> (Stored, Vec<Outcome>) {
    let mut set = *base;
    let mut outcomes = vec![];
    for s in 0..SENSORS_MAX {
        if !base.sensors[s].in_use {
            outcomes.push(Outcome::NotInUse);
            continue;
        }
        let mine: Vec<&link::Record> = records.iter().filter(|r| usize::from(r.sensor) == s).collect();
        let outcome = match fit_sensor(s as u8, &mine, holds, opts) {
            Ok(fit) => {
                let mut trial = set;
                trial.sensors[s] = fit.settings(holds);
                match trial.check() {
                    Ok(()) => {
                        set = trial;
                        Outcome::Fitted(fit)
                    }
                    Err(r) => Outcome::Refused(format!("the fit breaks the device's rule: {r}")),
                }
            }
            Err(why) => Outcome::Refused(why),
        };
        outcomes.push(outcome);
    }
    (set, outcomes)
}

/// The report of a calibration, Markdown: a row per sensor, then what the
/// data left unresolved and why sensors were refused.
pub fn report(holds: &[Hold], outcomes: &[Outcome]) -> String {
    let mut md = String::new();
    let reference = instrument::calib::REFERENCE;
    let s = SensorFit::stretches(holds);
    let _ = writeln!(
        md,
        "{} holds ({:?} mm). Per sensor: the fitted tab leads ℓ, contact and parasitic capacitance \
         (±1σ), C and R at rest, χ²/dof, how far the uncalibrated reading's C is from the fitted \
         line's (RMS over the holds), and the stretch error the reference sensor's table would give \
         on the uncalibrated reading (RMS over the holds) against the new table's (its points are \
         the fit's, so 0 at the holds: the measurement after the restart is the test).\n",
        holds.len(),
        s
    );
    let open = outcomes
        .iter()
        .any(|o| matches!(o, Outcome::Fitted(f) if f.open_cp.is_some()));
    if open {
        md.push_str(
            "With an open fixture (every sensor unplugged, its cable left on): its records are fitted \
             with the holds, and its C_p alone is in the last column.\n\n",
        );
    }
    md.push_str("| sensor | records | ℓ | contact kΩ | parasitic pF | film tan δ ×10⁻³ | C rest pF | R rest kΩ | χ²/dof | uncalibrated C off | stretch RMS, reference table | outcome |");
    md.push_str(if open { " open fixture pF |\n" } else { "\n" });
    md.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|");
    md.push_str(if open { "---|\n" } else { "\n" });
    let mut notes = vec![];
    for (i, o) in outcomes.iter().enumerate() {
        match o {
            Outcome::NotInUse => {}
            Outcome::Refused(why) => {
                let _ = writeln!(
                    md,
                    "| {i} | | | | | | | | | | | refused |{}",
                    if open { " |" } else { "" }
                );
                notes.push(format!(
                    "sensor {i} refused: {why}; the device keeps its set for it"
                ));
            }
            Outcome::Fitted(f) => {
                let pm = |g: usize, k: f64, d: usize| match f.sigma[g].is_nan() {
                    true if f.values[g] <= BOUNDS[g].0 => "none".to_string(),
                    true => format!("{:.*} (limit)", d, f.values[g] * k),
                    false => format!("{:.*} ± {:.*}", d, f.values[g] * k, d, f.sigma[g] * k),
                };
                let off = rms(f
                    .c_read_farad
                    .iter()
                    .zip(&f.c_farad)
                    .map(|(r, c)| 100.0 * (r / c - 1.0)));
                let before = rms(f
                    .c_read_farad
                    .iter()
                    .zip(&s)
                    .map(|(c, s)| reference.stretch(*c as f32) as f64 - s));
                let _ = write!(
                    md,
                    "| {i} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.2} | {off:.2} % | {before:.2} mm | stored |",
                    f.records,
                    pm(0, 1.0, 4),
                    pm(1, 1e-3, 2),
                    pm(2, 1e12, 3),
                    pm(3, 1e3, 2),
                    f.c_farad[0] * 1e12,
                    f.r_ohm[0] / 1e3,
                    f.chi2_dof,
                );
                let _ = match (open, f.open_cp) {
                    (false, _) => writeln!(md),
                    (true, Some((c, e))) => writeln!(md, " {:.3} ± {:.3} |", c * 1e12, e * 1e12),
                    (true, None) => writeln!(md, " |"),
                };
                for u in f.unresolved() {
                    notes.push(format!("sensor {i}: {u}"));
                }
            }
        }
    }
    if !notes.is_empty() {
        md.push('\n');
        for n in notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    md
}

/// One sensor measured again at known stretches (a device running with
/// its calibration).
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// Sensor.
    pub sensor: u8,
    /// Per hold (in the holds' order): the stretch held, mm, and the mean
    /// stretch of the records whose stretch the device vouched for (NaN:
    /// none).
    pub holds: Vec<(f64, f64)>,
    /// Records in the holds, and those whose stretch is vouched for.
    pub records: (usize, usize),
}

impl Check {
    /// RMS of the holds' errors, mm (NaN where a hold had no vouched
    /// record).
    pub fn rms_mm(&self) -> f64 {
        rms(self.holds.iter().map(|(want, got)| got - want))
    }
}

/// Each sensor's stretch at each hold, as the device read it: what a
/// calibration is judged by after the device restarted with it.
pub fn verify(records: &[link::Record], holds: &[Hold]) -> Vec<Check> {
    let mut sensors: Vec<u8> = records.iter().map(|r| r.sensor).collect();
    sensors.sort_unstable();
    sensors.dedup();
    sensors
        .into_iter()
        .map(|s| {
            let mut all = (0, 0);
            let holds = holds
                .iter()
                .map(|h| {
                    let (mut sum, mut n) = (0.0, 0usize);
                    for r in records.iter().filter(|r| r.sensor == s) {
                        let t = r.t_us as f64 * 1e-6;
                        if t < h.from_s || t >= h.to_s {
                            continue;
                        }
                        all.0 += 1;
                        if Flags(r.flags).stretch_valid() {
                            all.1 += 1;
                            sum += r.stretch_mm as f64;
                            n += 1;
                        }
                    }
                    (h.stretch_mm, if n > 0 { sum / n as f64 } else { f64::NAN })
                })
                .collect();
            Check {
                sensor: s,
                holds,
                records: all,
            }
        })
        .collect()
}

/// The report of a check, Markdown: a row per sensor.
pub fn check_report(holds: &[Hold], checks: &[Check]) -> String {
    let mut md = format!(
        "{} holds ({:?} mm), each sensor's stretch as the device read it (the mean of the records whose \
         stretch it vouched for) against the stretch held.\n\n| sensor | stretch RMS over the holds | worst hold | \
         records vouched for |\n|---|---|---|---|\n",
        holds.len(),
        holds.iter().map(|h| h.stretch_mm).collect::<Vec<_>>()
    );
    for c in checks {
        let worst = c
            .holds
            .iter()
            .filter(|(_, got)| !got.is_nan())
            .max_by(|a, b| (a.1 - a.0).abs().total_cmp(&(b.1 - b.0).abs()))
            .map_or(String::new(), |(want, got)| {
                format!("{:+.3} mm at {want} mm", got - want)
            });
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} of {} |",
            c.sensor,
            match c.rms_mm() {
                v if v.is_nan() => "not vouched for at every hold".to_string(),
                v => format!("{v:.3} mm"),
            },
            worst,
            c.records.1,
            c.records.0
        );
    }
    md
}

/// The records in a recorded stream (frames that fail their check are
/// passed over, as `live` counts them).
pub fn records_of(bytes: &[u8]) -> Vec<link::Record> {
    let mut dec = link::Decoder::new();
    bytes
        .iter()
        .filter_map(|&b| match dec.push(b) {
            Some(Ok(link::Frame {
                body: link::Body::Record(r),
                ..
            })) => Some(r),
            _ => None,
        })
        .collect()
}

/// A device's records as they arrive, and its clock (the newest record's
/// time).
struct Clock<S> {
    port: S,
    dec: link::Decoder,
    enc: link::Encoder,
    records: Vec<link::Record>,
    /// The device's replies to requests sent through the clock.
    replies: Vec<link::Reply>,
    raw: Vec<u8>,
    /// The newest record's time, s since the device's start.
    now_s: f64,
    timeout: std::time::Duration,
}

impl<S: std::io::Read> Clock<S> {
    fn new(port: S, timeout: std::time::Duration) -> Self {
        Self {
            port,
            dec: link::Decoder::new(),
            enc: link::Encoder::new(),
            records: vec![],
            replies: vec![],
            raw: vec![],
            now_s: f64::NEG_INFINITY,
            timeout,
        }
    }

    /// One read: the bytes' records taken, and whether the read filled
    /// its buffer (more is waiting). An error if the device closed the
    /// link or sent nothing for the timeout.
    fn pump(&mut self, quiet_since: &mut std::time::Instant) -> Result<bool> {
        let mut chunk = [0u8; 4096];
        match self.port.read(&mut chunk) {
            Ok(0) => bail!(
                "the device closed the link at {:.2} s of its clock",
                self.now_s.max(0.0)
            ),
            Ok(n) => {
                *quiet_since = std::time::Instant::now();
                self.raw.extend_from_slice(&chunk[..n]);
                for &b in &chunk[..n] {
                    match self.dec.push(b) {
                        Some(Ok(link::Frame {
                            body: link::Body::Record(r),
                            ..
                        })) => {
                            self.now_s = self.now_s.max(r.t_us as f64 * 1e-6);
                            self.records.push(r);
                        }
                        Some(Ok(link::Frame {
                            body: link::Body::Reply(r),
                            ..
                        })) => self.replies.push(r),
                        _ => {}
                    }
                }
                Ok(n == chunk.len())
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                if quiet_since.elapsed() > self.timeout {
                    bail!("no records from the device in {:?}", self.timeout);
                }
                Ok(false)
            }
            Err(e) => Err(e).context("reading from the device"),
        }
    }

    /// Read until the device's clock has passed `t_s`.
    fn until(&mut self, t_s: f64) -> Result<()> {
        let mut quiet = std::time::Instant::now();
        while self.now_s <= t_s {
            self.pump(&mut quiet)?;
        }
        Ok(())
    }

    /// Send `req` (its reply, when it comes, joins `replies`).
    fn request(&mut self, req: link::Request) -> Result<()>
    where
        S: std::io::Write,
    {
        let mut out = [0u8; link::MAX_FRAME];
        let bytes = self
            .enc
            .frame(link::Body::Request(req), &mut out)
            .map_err(|e| anyhow::anyhow!("encoding a request: {e}"))?;
        self.port.write_all(bytes).context("writing to the device")
    }

    /// Read what is waiting, so that the clock is the device's now.
    fn catch_up(&mut self) -> Result<()> {
        let mut quiet = std::time::Instant::now();
        while self.pump(&mut quiet)? || self.now_s == f64::NEG_INFINITY {}
        Ok(())
    }
}

/// Read a recorded stream's worth of records from a device until its
/// clock has passed `until_s`. The records, and the raw bytes read.
pub fn collect(
    port: &mut impl std::io::Read,
    until_s: f64,
    timeout: std::time::Duration,
) -> Result<(Vec<link::Record>, Vec<u8>)> {
    let mut clock = Clock::new(port, timeout);
    clock.until(until_s)?;
    Ok((clock.records, clock.raw))
}

/// A calibration done on a device.
#[derive(Debug)]
pub struct Done {
    /// The holds the fit used.
    pub holds: Vec<Hold>,
    /// The set stored.
    pub set: Stored,
    /// Its generation on the device.
    pub generation: u32,
    /// Each sensor's outcome.
    pub outcomes: Vec<Outcome>,
    /// The raw bytes of the records the fit used.
    pub stream: Vec<u8>,
    /// What the device said of the steps' sweeps: acknowledged, or why
    /// not (measured at the policy's tones then).
    pub sweeps: Vec<String>,
    /// The open fixture's span, if one was measured.
    pub open: Option<Span>,
}

/// Fit the records the clock read, write the set down the link, and stop
/// the device if asked.
fn finish<S: std::io::Read + std::io::Write>(
    clock: Clock<S>,
    holds: Vec<Hold>,
    opts: &Options,
    stop: bool,
) -> Result<Done> {
    let timeout = clock.timeout;
    let mut dev = crate::config::Device::new(clock.port, timeout);
    let base = dev.read()?.map_or_else(Stored::uncalibrated, |(s, _)| s);
    let (set, outcomes) = calibrate(&clock.records, &holds, &base, opts);
    if !outcomes.iter().any(|o| matches!(o, Outcome::Fitted(_))) {
        bail!("no sensor could be calibrated:\n{}", report(&holds, &outcomes));
    }
    let generation = dev.write(&set)?;
    if stop {
        dev.stop()?;
    }
    let sweeps = clock
        .replies
        .iter()
        .map(|r| match r {
            link::Reply::Refused { reason, .. } => {
                format!("sweep refused: {}", crate::config::reason_text(*reason))
            }
            _ => "swept".to_string(),
        })
        .collect();
    Ok(Done {
        holds,
        set,
        generation,
        outcomes,
        stream: clock.raw,
        sweeps,
        open: opts.open,
    })
}

/// Calibrate the device at the other end of `port` while it runs through
/// `holds` (spans of its clock): its records until the last hold ends,
/// each sensor fitted, the set written down the link (the device checks
/// it and stores it; it measures with it from its next start), and, with
/// `stop`, the device stopped.
pub fn on_device<S: std::io::Read + std::io::Write>(
    port: S,
    holds: &[Hold],
    opts: &Options,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<Done> {
    let mut clock = Clock::new(port, timeout);
    clock.until(holds.iter().map(|h| h.to_s).fold(0.0, f64::max))?;
    finish(clock, holds.to_vec(), opts, stop)
}

/// When a guided step's hold begins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ready {
    /// Now (the user pressed Enter).
    Now,
    /// At this time of the device's clock, s (a stage that moves on a
    /// schedule).
    At(f64),
}

/// A step of a guided calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Every sensor unplugged, its cable left on the front end (the open
    /// fixture: first, if asked for).
    Open,
    /// The skin held at this stretch, mm (sensors plugged in).
    Stretch(f64),
}

/// A guided calibration: the stretches to hold in turn, how long each
/// move settles and each hold is measured.
#[derive(Clone, Debug)]
pub struct Guide {
    /// Measure an open fixture first ([`Step::Open`]).
    pub open: bool,
    /// Stretches, mm, in the order held (0 first).
    pub at_mm: Vec<f64>,
    /// Left out after each move, s.
    pub settle_s: f64,
    /// Measured at each stretch, s.
    pub hold_s: f64,
    /// Ask the device to sweep its tone pairs over each hold (a
    /// calibration step: every sensor measured at every tone of the
    /// comb); a device without tone pairs refuses and measures at its
    /// policy's tone.
    pub sweep: bool,
}

/// Blocks per pair of a sweep over `span_s` of the array's clock
/// (`link::Request::Sweep`: four pairs) in blocks of `block_s`
/// ([`block_s_of`]), at most the link's limit.
pub fn sweep_blocks(span_s: f64, block_s: f64) -> u16 {
    let pairs = instrument::sweep::PAIRS.len() as f64;
    ((span_s / (pairs * block_s)).ceil() as u16).clamp(1, link::SWEEP_MAX_BLOCKS)
}

/// A device's block period, s, from its records: the shortest time
/// between two records of one sensor (4 ms blocks give 0.004, 1 ms
/// blocks 0.001; a device reporting one block in n gives n blocks);
/// `None` before a sensor has two.
pub fn block_s_of(records: &[link::Record]) -> Option<f64> {
    let mut last = std::collections::HashMap::new();
    let mut best: Option<u64> = None;
    for r in records {
        if let Some(t0) = last.insert(r.sensor, r.t_us) {
            if r.t_us > t0 {
                let d = r.t_us - t0;
                best = Some(best.map_or(d, |b| b.min(d)));
            }
        }
    }
    best.map(|us| us as f64 * 1e-6)
}

/// Calibrate the device at the other end of `port`, step by step: for
/// each step of `guide` (the open fixture if asked, then each stretch),
/// `ready(k, step, device_now_s)` says when it is in place (after asking
/// the user, or from a schedule); it is measured from then plus the
/// settling for `hold_s` of the device's clock. Then as [`on_device`]:
/// fitted (with the open fixture's span), written, stopped if asked.
pub fn guided<S: std::io::Read + std::io::Write>(
    port: S,
    guide: &Guide,
    ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
    opts: &Options,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<Done> {
    let mut clock = Clock::new(port, timeout);
    let (holds, open) = gather(&mut clock, guide, ready)?;
    let opts = Options {
        open: open.or(opts.open),
        ..*opts
    };
    finish(clock, holds, &opts, stop)
}

/// A device measured again, step by step as [`guided`] (no sweep: the
/// device reads as it will in use), nothing written, stopped after if
/// `stop`: each sensor's stretch at each hold ([`verify`]), the holds,
/// and the raw stream.
pub fn verify_guided<S: std::io::Read + std::io::Write>(
    port: S,
    guide: &Guide,
    ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
    stop: bool,
    timeout: std::time::Duration,
) -> Result<(Vec<Hold>, Vec<Check>, Vec<u8>)> {
    let mut clock = Clock::new(port, timeout);
    let guide = Guide {
        sweep: false,
        open: false,
        ..guide.clone()
    };
    let (holds, _) = gather(&mut clock, &guide, ready)?;
    let checks = verify(&clock.records, &holds);
    if stop {
        crate::config::Device::new(clock.port, timeout).stop()?;
    }
    Ok((holds, checks, clock.raw))
}

/// The holds of a guided run and the open fixture's span, the clock
/// reading through them.
fn gather<S: std::io::Read + std::io::Write>(
    clock: &mut Clock<S>,
    guide: &Guide,
    mut ready: impl FnMut(usize, Step, f64) -> Result<Ready>,
) -> Result<(Vec<Hold>, Option<Span>)> {
    if guide.at_mm.len() < 2 {
        bail!("a calibration needs two stretches at least");
    }
    if !(guide.hold_s > 0.0 && guide.settle_s >= 0.0) {
        bail!("the hold must last, and the settling cannot be negative");
    }
    let mut holds = vec![];
    let mut open = None;
    let steps = guide
        .open
        .then_some(Step::Open)
        .into_iter()
        .chain(guide.at_mm.iter().map(|&s| Step::Stretch(s)));
    for (k, step) in steps.enumerate() {
        clock.catch_up()?;
        let t0 = match ready(k, step, clock.now_s)? {
            Ready::Now => clock.now_s,
            Ready::At(t) => t.max(clock.now_s),
        };
        if guide.sweep {
            clock.until(t0)?;
            // The device's blocks, as its records are spaced (an array
            // device in 4 ms blocks, unless it said otherwise).
            let block_s = block_s_of(&clock.records)
                .unwrap_or(instrument::array::Layout::BLOCK_4MS.block_us() as f64 * 1e-6);
            clock.request(link::Request::Sweep {
                blocks_per_pair: sweep_blocks(guide.settle_s + guide.hold_s, block_s),
            })?;
        }
        let (from_s, to_s) = (t0 + guide.settle_s, t0 + guide.settle_s + guide.hold_s);
        clock.until(to_s)?;
        match step {
            Step::Open => open = Some((from_s, to_s)),
            Step::Stretch(stretch_mm) => holds.push(Hold {
                stretch_mm,
                from_s,
                to_s,
            }),
        }
    }
    Ok((holds, open))
}

/// RMS of `v` (NaN if empty).
fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}

/// Forward-difference Jacobian of `f` at `x` over unknowns `free`:
/// `jac[a][i]` = ∂f_i/∂x_free[a].
fn jacobian(f: &impl Fn(&[f64], &mut Vec<f64>), x: &[f64], free: &[usize]) -> Vec<Vec<f64>> {
    let mut r0 = vec![];
    f(x, &mut r0);
    let mut xp = x.to_vec();
    let mut r1 = vec![];
    free.iter()
        .map(|&i| {
            let h = 1e-6 * x[i].abs().max(1e-3);
            xp[i] = x[i] + h;
            f(&xp, &mut r1);
            xp[i] = x[i];
            r1.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect()
        })
        .collect()
}

/// Levenberg–Marquardt on ½‖f‖² with box bounds (steps projected onto
/// them); unknowns with `active[i − first R] == false` are held. The
/// final cost ‖f‖² and the unknowns.
fn levenberg_marquardt(
    f: &impl Fn(&[f64], &mut Vec<f64>),
    mut x: Vec<f64>,
    bounds: &[(f64, f64)],
    has_part: &[bool],
) -> (f64, Vec<f64>) {
    let n_r = has_part.len();
    let first_r = x.len() - n_r;
    let free: Vec<usize> = (0..x.len())
        .filter(|&i| i < first_r || has_part[i - first_r])
        .collect();
    for (v, b) in x.iter_mut().zip(bounds) {
        *v = v.clamp(b.0, b.1);
    }
    let cost = |x: &[f64]| {
        let mut r = vec![];
        f(x, &mut r);
        let c: f64 = r.iter().map(|v| v * v).sum();
        if c.is_finite() {
            c
        } else {
            f64::INFINITY
        }
    };
    let mut c = cost(&x);
    let mut lambda = 1e-3;
    let mut r = vec![];
    for _ in 0..200 {
        f(&x, &mut r);
        let jac = jacobian(f, &x, &free);
        let n = free.len();
        let mut a = vec![vec![0.0; n]; n];
        let mut g = vec![0.0; n];
        for i in 0..n {
            g[i] = -(0..r.len()).map(|k| jac[i][k] * r[k]).sum::<f64>();
            for j in i..n {
                let v: f64 = (0..r.len()).map(|k| jac[i][k] * jac[j][k]).sum();
                a[i][j] = v;
                a[j][i] = v;
            }
        }
        let mut improved = false;
        for _ in 0..12 {
            let mut m = a.clone();
            for (i, row) in m.iter_mut().enumerate() {
                row[i] += lambda * a[i][i].max(1e-12);
            }
            let Some(step) = host_sim::numerics::solve(m, g.clone()) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn = x.clone();
            for (k, &i) in free.iter().enumerate() {
                xn[i] = (x[i] + step[k]).clamp(bounds[i].0, bounds[i].1);
            }
            let cn = cost(&xn);
            if cn < c {
                let done = (c - cn) <= 1e-10 * c.max(1e-300);
                x = xn;
                c = cn;
                lambda = (lambda / 3.0).max(1e-12);
                improved = !done;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (c, x)
}

/// The inverse of a symmetric positive definite matrix (None: singular).
fn invert(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut cols = vec![];
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        cols.push(host_sim::numerics::solve(a.to_vec(), e)?);
    }
    Some((0..n).map(|i| (0..n).map(|j| cols[j][i]).collect()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records of one sensor at each hold, from the model with known
    /// leads, contact, parasitic capacitance and film loss, with noise.
    fn records(lead: f64, rs: f64, cp: f64, tan_d: f64, holds: &[Hold]) -> Vec<link::Record> {
        let mut out = vec![];
        let mut seed = 0x1234_5678u64;
        let mut noise = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for h in holds {
            let c = 200e-12 * (1.0 + h.stretch_mm / 100.0);
            let mut t = h.from_s;
            while t < h.to_s {
                // The electrodes' resistance falls with stretch and
                // recovers during the hold.
                let r = 700e3 * (1.0 - 0.004 * h.stretch_mm) * (1.0 + 0.05 * (h.from_s - t).exp());
                // The pairs a calibration's sweep steps through, in turn:
                // the loss (a resistance ∝ 1/f) is told from a contact
                // (flat) and a parasitic over 0.5–6 kHz.
                let pair = if out.len() % 2 == 0 {
                    [500.0f32, 2000.0]
                } else {
                    [2000.0, 6000.0]
                };
                let tones = pair.map(|f| {
                    let z = model(f as f64, r, c, lead, rs, cp, tan_d);
                    let z = z * Complex64::new(1.0 + 2e-4 * noise(), 2e-4 * noise());
                    link::Tone {
                        f_hz: f,
                        z_re_ohm: z.re as f32,
                        z_im_ohm: z.im as f32,
                    }
                });
                out.push(link::Record {
                    t_us: (t * 1e6) as u64,
                    sensor: 0,
                    tones,
                    c_farad: (c * 0.97) as f32,
                    r_ohm: r as f32,
                    flags: Flags::UNCALIBRATED | Flags::MODEL,
                    ..Default::default()
                });
                t += 0.004;
            }
        }
        out
    }

    /// The block period from records of two sensors interleaved, 1 ms
    /// or 4 ms apart; a sweep's blocks per pair cover the span in either.
    #[test]
    fn the_block_period_is_read_from_the_records_and_sizes_the_sweep() {
        let at = |t_us: u64, sensor: u8| link::Record {
            t_us,
            sensor,
            ..Default::default()
        };
        assert_eq!(block_s_of(&[]), None);
        assert_eq!(block_s_of(&[at(500, 0), at(500, 1)]), None);
        for period in [1000u64, 4000] {
            let recs: Vec<link::Record> = (0..6u64)
                .flat_map(|b| [at(b * period + period / 2, 0), at(b * period + period / 2, 1)])
                .collect();
            let block_s = block_s_of(&recs).unwrap();
            assert!((block_s - period as f64 * 1e-6).abs() < 1e-12);
            // 2 s over four pairs: 500 ms a pair.
            assert_eq!(u64::from(sweep_blocks(2.0, block_s)) * period, 500_000);
        }
        // A sensor's records out of order, or repeated, are not a period.
        assert_eq!(
            block_s_of(&[at(9000, 0), at(5000, 0), at(5000, 0), at(6000, 0)]),
            Some(1e-3)
        );
        assert_eq!(sweep_blocks(1e9, 1e-3), link::SWEEP_MAX_BLOCKS);
        assert_eq!(sweep_blocks(0.0, 4e-3), 1);
    }

    fn stairs() -> Vec<Hold> {
        (0..11)
            .map(|k| Hold {
                stretch_mm: 3.0 * k as f64,
                from_s: 1.0 * k as f64,
                to_s: 1.0 * k as f64 + 0.6,
            })
            .collect()
    }

    #[test]
    fn the_fit_finds_the_leads_contact_parasitic_and_loss_it_was_given() {
        let holds = stairs();
        for (lead, rs, cp, tan_d) in [
            (0.0, 0.0, 0.0, 2e-3),
            (0.64, 0.0, 12e-12, 3e-3),
            (0.3, 20e3, 5e-12, 1e-3),
            (0.3, 0.0, 5e-12, 2e-2),
        ] {
            let recs = records(lead, rs, cp, tan_d, &holds);
            let refs: Vec<&link::Record> = recs.iter().collect();
            let fit = fit_sensor(0, &refs, &holds, &Options::default()).unwrap();
            println!("{:?} {:?} χ²/dof {:.2}", fit.values, fit.sigma, fit.chi2_dof);
            assert!((fit.values[0] - lead).abs() < 0.02, "{fit:?}");
            assert!((fit.values[1] - rs).abs() < 5e3, "{fit:?}");
            assert!((fit.values[2] - cp).abs() < 0.3e-12, "{fit:?}");
            assert!((fit.values[3] - tan_d).abs() < 3e-4, "{fit:?}");
            for (k, h) in holds.iter().enumerate() {
                let c = 200e-12 * (1.0 + h.stretch_mm / 100.0);
                assert!((fit.c_farad[k] / c - 1.0).abs() < 2e-4, "{k}: {fit:?}");
            }
            assert!(fit.chi2_dof < 2.0);
            let set = fit.settings(&holds);
            assert!(set.table.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1));
            assert_eq!(set.table[POINTS - 1].1, 30.0);
        }
    }

    #[test]
    fn a_sensor_the_model_does_not_explain_is_refused_and_kept() {
        let holds = stairs();
        let mut recs = records(0.3, 0.0, 5e-12, 3e-3, &holds);
        // A stretch that moved during the holds: C off by 2 % in the
        // second half of each.
        for r in recs.iter_mut() {
            let t = r.t_us as f64 * 1e-6;
            if t.fract() > 0.3 {
                for tone in r.tones.iter_mut() {
                    tone.z_im_ohm *= 0.98;
                }
            }
        }
        let base = Stored::uncalibrated();
        let (set, out) = calibrate(&recs, &holds, &base, &Options::default());
        assert!(
            matches!(&out[0], Outcome::Refused(why) if why.contains("does not explain")),
            "{out:?}"
        );
        assert_eq!(set.sensors[0], base.sensors[0]);
        // The other sensors have no records: refused, kept.
        assert!(matches!(&out[1], Outcome::Refused(why) if why.contains("no usable records")));
        assert!(report(&holds, &out).contains("sensor 0 refused"));
    }

    #[test]
    fn holds_files_say_where_they_are_wrong() {
        let ok = "stretch_mm,from_s,to_s\n0,0.2,1\n10,1.5,2\n";
        assert_eq!(parse_holds(ok).unwrap().len(), 2);
        let err = |t: &str| parse_holds(t).unwrap_err().to_string();
        assert!(err("s,f,t\n").starts_with("1:1: the header"));
        assert!(err("stretch_mm,from_s,to_s\n0,0.2,x\n").starts_with("2:7: 'x' is not"));
        assert!(err("stretch_mm,from_s,to_s\n0,0.2,1\n5,0.5,1.5\n").contains("overlaps"));
        assert!(err("stretch_mm,from_s,to_s\n0,0.2,1\n").contains("two stretches"));
        assert!(err("stretch_mm,from_s,to_s\n0,1,0.5\n").contains("end after"));
        assert!(err("stretch_mm,from_s,to_s\n0,0,1\n0,2,3\n").contains("a second hold"));
        assert!(err("stretch_mm,from_s,to_s\n0,0,1,4\n").contains("4 fields"));
        let tmp = tempfile::tempdir().unwrap();
        let p = tmp.path().join("holds.csv");
        let holds = stairs();
        write_holds(&p, &holds).unwrap();
        assert_eq!(read_holds(&p).unwrap(), holds);
    }
}
