//! The fit of one sensor: its line at each hold, its tab leads, contact,
//! parasitic capacitance and film loss, weighted least squares
//! (Levenberg–Marquardt) on each part of a hold's mean impedance per
//! tone.

use super::*;
use anyhow::Result;
use instrument::calib::POINTS;
use instrument::faults::Flags;
use instrument::stored::SensorSettings;
use num_complex::Complex64;
use std::f64::consts::TAU;

/// The floor of each mean impedance's σ, relative to |Z|: below it the
/// front end's own calibration, not the noise, limits (a transimpedance
/// and a phase known to 10⁻⁴).
pub const SIGMA_FLOOR: f64 = 1e-4;

/// The largest χ²/dof a sensor's fit may leave: beyond it the model does
/// not explain the data and the sensor is refused.
pub const CHI2_MAX: f64 = 4.0;

/// The largest 1σ of a sensor's fitted tan δ that is stored as its film's
/// (`SensorSettings::loss_tangent`): half the material's spread
/// (`dsp_core::dielectric::Dielectric::SILICONE`, 1·10⁻³), so that what
/// is stored knows the film better than its material does. A sensor
/// whose fit knows less keeps the material's.
pub const LOSS_SIGMA_MAX: f64 = 0.5e-3;

/// Correlation beyond which two fitted values are reported as trading
/// against each other.
pub const DEGENERATE: f64 = 0.95;

/// Flags of records whose impedances are not used (biased tones, no
/// tones, or the block after a tone switch).
pub(crate) const UNUSABLE: u16 =
    Flags::CLIPPED | Flags::OPEN | Flags::SHORTED | Flags::DISTURBED | Flags::SETTLING;

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
pub(crate) const UNUSABLE_OPEN: u16 = Flags::CLIPPED | Flags::DISTURBED | Flags::SETTLING;

/// The impedances of a part of a hold, per tone (Hz as the records
/// carry it).
pub(crate) type Tones = Vec<(f32, Vec<Complex64>)>;

/// One mean impedance: a part of a hold, at one tone; or the open
/// fixture's mean admittance at one tone.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Obs {
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
pub(crate) fn push_at(tones: &mut Tones, f_hz: f32, z: Complex64) {
    match tones.iter_mut().find(|(f, _)| *f == f_hz) {
        Some((_, v)) => v.push(z),
        None => tones.push((f_hz, vec![z])),
    }
}

/// The mean of `v` (at least two values) and the 1σ of each of its
/// components, from their scatter.
pub(crate) fn mean_sigma(v: &[Complex64]) -> (Complex64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<Complex64>() / n;
    let var = v.iter().map(|z| (z - mean).norm_sqr()).sum::<f64>() / (2.0 * (n - 1.0));
    (mean, (var / n).sqrt())
}

/// A span of the device's clock: from, to, s.
pub type Span = (f64, f64);

/// [`Obs::hold`] of the open fixture.
pub(crate) const OPEN: usize = usize::MAX;

/// The line's impedance on a film of loss tangent `tan_d` (C·(1 − j·tan δ)),
/// with leads, contact and parasitic capacitance.
pub(crate) fn model(f_hz: f64, r: f64, c: f64, lead: f64, rs: f64, cp: f64, tan_d: f64) -> Complex64 {
    let w = TAU * f_hz;
    let g = (Complex64::new(0.0, w * r * c) * Complex64::new(1.0, -tan_d)).sqrt();
    let line = r * (g.cosh() / g.sinh()) / g;
    let zs = line + lead * r + rs;
    (zs.inv() + Complex64::new(0.0, w * cp)).inv()
}

/// The global unknowns of a sensor's fit: ℓ, R_s, C_p, and the film's
/// loss tangent tan δ (each tone's sweep at every hold tells a loss,
/// a resistance ∝ 1/f, from a contact, flat in f; the device fits each
/// record's line with its film's tan δ as the prior's mean: this
/// sensor's where the fit measured it, [`LOSS_SIGMA_MAX`]).
pub(crate) const GLOBALS: usize = 4;
/// Scale of the global unknowns in the fit's vector: ℓ, R_s/100 kΩ,
/// C_p/pF, tan δ/10⁻³.
pub(crate) const SCALE: [f64; GLOBALS] = [1.0, 1e5, 1e-12, 1e-3];
/// Their bounds, SI (the device's ranges, `instrument::stored`; tan δ
/// to 0.1, the lossiest films).
pub(crate) const BOUNDS: [(f64, f64); GLOBALS] = [
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
    let mut seen = observe_holds(records, holds, &order, opts)?;
    if let Some(span) = opts.open {
        seen.used += observe_open(records, span, opts, &mut seen.obs)?;
    }
    let open_cp = open_cp(&seen.obs);
    let n_holds = order.len();
    let n_parts = seen.part_hold.len();
    let misfits = Misfits::new(&seen.obs, n_holds, seen.part_hold.len());
    let (cost, x) = solve(&misfits, start(&seen.obs, n_holds, &seen.part_hold))
        .ok_or("the fit could not evaluate its model at any start")?;
    let bounds = &misfits.bounds;
    // Free unknowns: globals off their bounds, every C, every R (every
    // part has observations).
    let free: Vec<usize> = (0..x.len())
        .filter(|&i| i >= GLOBALS || (x[i] > bounds[i].0 + 1e-9 && x[i] < bounds[i].1 - 1e-9))
        .collect();
    let m = 2 * seen.obs.len();
    if m <= free.len() {
        return Err(format!(
            "{} mean impedances for {} unknowns: hold longer, or at more stretches",
            seen.obs.len(),
            free.len()
        ));
    }
    let dof = m - free.len();
    let chi2_dof = cost / dof as f64;
    let (sigma, rho) = uncertainty(&misfits, &x, &free, chi2_dof);
    let r: Vec<f64> = (0..n_holds)
        .map(|k| {
            let rs: Vec<f64> = (0..n_parts)
                .filter(|&p| seen.part_hold[p] == k)
                .map(|p| x[GLOBALS + n_holds + p].exp())
                .collect();
            rs.iter().sum::<f64>() / rs.len() as f64
        })
        .collect();
    let fit = SensorFit {
        sensor,
        records: seen.used,
        values: core::array::from_fn(|g| x[g] * SCALE[g]),
        sigma,
        rho_lead_contact: rho,
        c_farad: (0..n_holds).map(|k| x[GLOBALS + k].exp()).collect(),
        r_ohm: r,
        chi2_dof,
        dof,
        c_read_farad: seen.c_read,
        open_cp,
    };
    fit.check(holds, &order)?;
    Ok(fit)
}

/// What a sensor's records say at its holds.
struct Observed {
    /// The mean impedances.
    obs: Vec<Obs>,
    /// The hold of each part (a slice of a hold at one pair of tones).
    part_hold: Vec<usize>,
    /// Records used.
    used: usize,
    /// Each hold's C as the device read it (its records' mean), F.
    c_read: Vec<f64>,
}

/// The mean impedances of each part of each hold (in the holds' order of
/// stretch, `order`), per pair of tones and tone; an error for a hold
/// with no usable records.
fn observe_holds(
    records: &[&link::Record],
    holds: &[Hold],
    order: &[usize],
    opts: &Options,
) -> Result<Observed, String> {
    let parts = opts.parts.max(1);
    let mut seen = Observed {
        obs: vec![],
        part_hold: vec![],
        used: 0,
        c_read: vec![],
    };
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
            let groups = tone_groups(records, (a, b), &mut seen.used, &mut c_sum);
            for (_, tones) in groups {
                if part_means(&mut seen.obs, k, seen.part_hold.len(), tones, opts) {
                    seen.part_hold.push(k);
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
        seen.c_read.push(if c_sum.1 > 0 {
            c_sum.0 / c_sum.1 as f64
        } else {
            f64::NAN
        });
    }
    Ok(seen)
}

/// The usable records within `span`, per pair of tones (a sweep steps
/// through them; each pair's records were taken at their own time of the
/// hold, so each has its own resistance), per tone: their impedances.
/// Counts them into `used`, and their C into `c_sum` (sum, count).
fn tone_groups(
    records: &[&link::Record],
    (a, b): Span,
    used: &mut usize,
    c_sum: &mut (f64, usize),
) -> Vec<([u32; 2], Tones)> {
    let mut groups: Vec<([u32; 2], Tones)> = vec![];
    for r in records {
        let t = r.t_us as f64 * 1e-6;
        if !(t >= a && t < b) || r.flags & UNUSABLE != 0 {
            continue;
        }
        *used += 1;
        if r.c_farad > 0.0 {
            *c_sum = (c_sum.0 + r.c_farad as f64, c_sum.1 + 1);
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
    groups
}

/// One part's mean impedance per tone with enough records, as
/// observations of hold `hold`, part `part`; whether it had any.
fn part_means(obs: &mut Vec<Obs>, hold: usize, part: usize, tones: Tones, opts: &Options) -> bool {
    let mut seen = false;
    for (f, zs) in tones {
        if zs.len() < opts.min_records {
            continue;
        }
        let (mean, sigma) = mean_sigma(&zs);
        let sigma = sigma.max(SIGMA_FLOOR * mean.norm());
        obs.push(Obs {
            hold,
            part,
            f_hz: f as f64,
            z: mean,
            sigma,
        });
        seen = true;
    }
    seen
}

/// The open fixture: per tone, the mean admittance (an open's impedance
/// is large and its noise is not; its admittance is small, and its noise
/// additive), as observations of [`OPEN`]; the records used, or an error
/// if none could be.
fn observe_open(
    records: &[&link::Record],
    (a, b): Span,
    opts: &Options,
    obs: &mut Vec<Obs>,
) -> Result<usize, String> {
    let mut open_records = 0;
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
    Ok(open_records)
}

/// The open fixture's C_p alone (Im Y/ω over its tones, weighted) and its
/// 1σ, F; None without an open fixture.
fn open_cp(obs: &[Obs]) -> Option<(f64, f64)> {
    let (mut sw, mut swx) = (0.0, 0.0);
    for o in obs.iter().filter(|o| o.hold == OPEN) {
        let w = TAU * o.f_hz;
        let weight = (w / o.sigma).powi(2);
        sw += weight;
        swx += weight * o.z.im / w;
    }
    (sw > 0.0).then(|| (swx / sw, sw.sqrt().recip()))
}

/// The fit's start (unknowns: the globals, ln C per hold, ln R per
/// part): each part's lumped reading at its lowest tone (C = −1/(ωX),
/// R = 3·Re Z, the line's low-frequency resistance).
fn start(obs: &[Obs], n_holds: usize, part_hold: &[usize]) -> Vec<f64> {
    let n_parts = part_hold.len();
    let mut start = vec![0.0; GLOBALS + n_holds + n_parts];
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
    start
}

/// Each observation's misfit at `x`, in units of its σ (real, then
/// imaginary part), into `out`.
fn residuals(obs: &[Obs], n_holds: usize, x: &[f64], out: &mut Vec<f64>) {
    out.clear();
    let (lead, rs, cp, tan_d) = (x[0] * SCALE[0], x[1] * SCALE[1], x[2] * SCALE[2], x[3] * SCALE[3]);
    for o in obs {
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
}

/// A sensor's unknowns as a least-squares problem: every observation's
/// misfit ([`residuals`]); the globals within the device's ranges
/// ([`BOUNDS`]), each line's ln C within 1 pF … 100 nF and ln R within
/// 100 Ω … 1 GΩ (no sensor of this kind lies beyond).
struct Misfits<'a> {
    obs: &'a [Obs],
    n_holds: usize,
    bounds: Vec<(f64, f64)>,
}

impl<'a> Misfits<'a> {
    fn new(obs: &'a [Obs], n_holds: usize, n_parts: usize) -> Self {
        let globals = (0..GLOBALS).map(|g| (BOUNDS[g].0 / SCALE[g], BOUNDS[g].1 / SCALE[g]));
        let c = std::iter::repeat_n((1e-12f64.ln(), 1e-7f64.ln()), n_holds);
        let r = std::iter::repeat_n((1e2f64.ln(), 1e9f64.ln()), n_parts);
        Self {
            obs,
            n_holds,
            bounds: globals.chain(c).chain(r).collect(),
        }
    }
}

impl host_sim::lsq::Problem for Misfits<'_> {
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }

    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        let mut out = Vec::with_capacity(2 * self.obs.len());
        residuals(self.obs, self.n_holds, x, &mut out);
        Some(out)
    }
}

/// The bounded fit ([`host_sim::lsq::fit`]) from several starts of the
/// globals (it is not convex in them): the lowest cost and its unknowns;
/// None where no start can be evaluated.
fn solve(misfits: &Misfits, start: Vec<f64>) -> Option<(f64, Vec<f64>)> {
    let mut best: Option<host_sim::lsq::Point> = None;
    for lead in [0.0, 0.3, 1.0] {
        for cp in [0.0, 10.0] {
            // None, and a silicone's (`Dielectric::SILICONE`), in 10⁻³.
            for loss in [0.0, 3.0] {
                let mut x = start.clone();
                x[0] = lead;
                x[2] = cp;
                x[3] = loss;
                for (v, b) in x.iter_mut().zip(&misfits.bounds) {
                    *v = v.clamp(b.0, b.1);
                }
                let Some(at) = host_sim::lsq::Point::at(misfits, x) else {
                    continue;
                };
                let fitted = host_sim::lsq::fit(misfits, at, LM_STEPS).best;
                if best.as_ref().is_none_or(|b| fitted.s < b.s) {
                    best = Some(fitted);
                }
            }
        }
    }
    best.map(|b| (b.s, b.x))
}

/// The fit's most iterations from each start.
const LM_STEPS: usize = 200;

/// The globals' 1σ (NaN where not free) and the correlation of leads and
/// contact, from the covariance of the `free` unknowns at `x`, scaled by
/// χ²/dof when above 1.
fn uncertainty(misfits: &Misfits, x: &[f64], free: &[usize], chi2_dof: f64) -> ([f64; GLOBALS], f64) {
    let mut sigma = [f64::NAN; GLOBALS];
    let mut rho = f64::NAN;
    let jtj = host_sim::lsq::Point::at(misfits, x.to_vec())
        .and_then(|at| host_sim::lsq::normal_equations(misfits, &at));
    let Some((jtj, _)) = jtj else {
        return (sigma, rho);
    };
    let sub: Vec<Vec<f64>> = free
        .iter()
        .map(|&a| free.iter().map(|&b| jtj[a][b]).collect())
        .collect();
    if let Some(cov) = host_sim::lsq::covariance(&sub, chi2_dof.max(1.0)) {
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
    (sigma, rho)
}

impl SensorFit {
    /// Refuse a fit that does not explain its data (χ²/dof above
    /// [`CHI2_MAX`]) or whose C does not grow with stretch (holds in the
    /// order of stretch, `order`).
    fn check(&self, holds: &[Hold], order: &[usize]) -> Result<(), String> {
        let chi2_dof = self.chi2_dof;
        if chi2_dof.is_nan() || chi2_dof > CHI2_MAX {
            return Err(format!(
                "the line with leads, contact, parasitic capacitance and its film's loss does not explain its data \
                 (χ²/dof = {chi2_dof:.1} > {CHI2_MAX}): an effect it lacks, or a stretch that moved during a hold"
            ));
        }
        if let Some(k) = (1..self.c_farad.len()).find(|&k| self.c_farad[k] <= self.c_farad[k - 1]) {
            return Err(format!(
                "C does not grow with stretch: {:.2} pF at {} mm, {:.2} pF at {} mm",
                self.c_farad[k - 1] * 1e12,
                holds[order[k - 1]].stretch_mm,
                self.c_farad[k] * 1e12,
                holds[order[k]].stretch_mm
            ));
        }
        Ok(())
    }

    /// The stretches of the holds, ascending (as `c_farad`).
    pub(crate) fn stretches(holds: &[Hold]) -> Vec<f64> {
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
            loss_tangent: self.loss_tangent(),
        }
    }

    /// The film's tan δ to store: the fitted one where it is free (not
    /// at a bound) and known within [`LOSS_SIGMA_MAX`]; else None, the
    /// material's.
    pub fn loss_tangent(&self) -> Option<f32> {
        let (t, sigma) = (self.values[3], self.sigma[3]);
        let (lo, hi) = BOUNDS[3];
        (sigma <= LOSS_SIGMA_MAX && t > lo && t <= hi).then_some(t as f32)
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
