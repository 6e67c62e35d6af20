//! The most records any reader of the array could keep valid: what one
//! record's comb tells of C, by the Cramér–Rao bound.
//!
//! However a record is read, its block carries a bounded amount of
//! information about C. For the model the instrument reads (a uniform
//! line with its tab leads, on a film whose tan δ is known to its
//! material's spread), each tone's impedance measured in the front end's
//! noise, the Fisher information of (ln R, ln C, tan δ) over every tone
//! of the comb bounds the variance of any unbiased estimate of ln C from
//! below:
//!
//! ```text
//! σ_k    = |Z_k|·√(2/N)·n·√(1/A_v,k² + 1/A_i,k²)     (Ω, each component; n the ADC's noise, counts)
//! F      = Σ_k J_kᵀ·J_k/σ_k² + e₃·e₃ᵀ/σ_t²           (J_k = ∂(Re Z_k, Im Z_k)/∂(ln R, ln C, tan δ))
//! σ_lnC ≥ √(F⁻¹)₂₂
//! ```
//!
//! (A_v,k and A_i,k: tone k's amplitude on the excitation's input and on
//! the sensor's, counts; N the instants the record reads.)
//!
//! A reader that vouches for a record within 1 % where its σ exceeds
//! 1/[`NOISE_SIGMAS`] of that leaves one record in 10⁵ past 1 % by noise
//! alone. The **noise ceiling** of a case is the share of its records with
//! [`NOISE_SIGMAS`]·σ_lnC ≤ 1 %: what no reader exceeds and keeps the
//! availability goal's zero records past 1 %.
//!
//! A reader must also bound what it cannot see: an interferer in one
//! tone's bin moves that tone alone, and only the model check's χ² shows
//! it, in part (`instrument::joint::hidden`). Per unit of a one-tone
//! error's share of √χ², with every tone fitted, C moves by at most
//!
//! ```text
//! h = max_k √(g_kᵀ·M_k⁻¹·g_k)
//! ```
//!
//! (whitened: g_k tone k's two entries of ∂ln C/∂z, F⁻¹·Aᵀ's row of
//! ln C; M_k tone k's 2×2 block of I − A·F⁻¹·Aᵀ). The **checked ceiling**
//! takes the reader's five σ and [`CHECK_SHARE`] of that error:
//! 5·σ_lnC + h·[`CHECK_SHARE`] ≤ 1 %.
//!
//! Each case is [`crate::availability`]'s, its sensors and their
//! trajectories the same, each record's σ at the truth of its block's
//! middle. Besides the comb a layout plays, [`Probe::OVER_TWO_BLOCKS`]
//! asks what the same comb an octave lower, each record read over its
//! block and the one before, would allow (not built): the same waveform
//! stretched in time, so the same peak at the buffer and, at half the
//! frequency, at most the same current through each stage. And
//! [`Probe::RANGED`] asks what stages that switch their transimpedance
//! per sensor would allow (not built; [`RANGED_OHM`]): where a sensor's
//! current is small, the ADC's noise weighs less against it.

use crate::availability::{blocks_of, Case, Skin, SETTLE_S};
use crate::model::{continuous, Effect};
use instrument::array::{Layout, SENSORS, TONES};
use num_complex::Complex64;
use skin_sim::array::ArrayFrontEnd;
use std::f64::consts::TAU;

/// Standard deviations of the noise within 1 % that a record vouched for
/// must keep, at the least: beyond 4.4 σ lies one record in 10⁵
/// (two-sided), a third of a record past 1 % in the 32,000 of an
/// availability case at 1,000 records/s.
pub const NOISE_SIGMAS: f64 = 4.4;

/// The share of √χ² an error at one tone that nothing sees is granted by
/// the checked ceiling: about what the reader's history of calm blocks
/// allows after a second (`instrument::joint::Quiet`; a block alone
/// grants 2).
pub const CHECK_SHARE: f64 = 1.0;

/// The film's spread of tan δ (1σ) a record reads on: the material's
/// (`dsp_core::dielectric::Dielectric::SILICONE`).
pub const FILM_SPREAD: f64 = 1e-3;

/// Transimpedances a ranged stage could switch between, Ω
/// ([`Probe::RANGED`]): the array's 330 kΩ, and 3 and 10 times it.
pub const RANGED_OHM: [f64; 3] = [330e3, 1e6, 3.3e6];

/// What a record of a layout reads: its comb, over one block or (an
/// octave lower) over two, through the array's stages or ranged ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// Blocks a record reads (1: the layout's comb; 2: an octave lower).
    pub blocks: u32,
    /// Each record's stage takes the largest of [`RANGED_OHM`] whose
    /// output stays within the stage's swing (false: the array's).
    pub ranged: bool,
}

impl Probe {
    /// The comb the layout plays, each record read over its block.
    pub const COMB: Self = Self {
        blocks: 1,
        ranged: false,
    };

    /// The layout's comb an octave lower, each record read over its
    /// block and the one before (not built).
    pub const OVER_TWO_BLOCKS: Self = Self {
        blocks: 2,
        ranged: false,
    };

    /// The layout's comb through stages that each record ranges (not
    /// built): the largest transimpedance of [`RANGED_OHM`] whose output,
    /// every tone's amplitude summed, stays within
    /// [`instrument::array::TIA_PEAK_VOLT`]. Chosen per record with the
    /// truth, an upper bound on what a stage ranged from its last
    /// records keeps; the noise is the ADC's alone, as for the array's
    /// stages (a 3.3 MΩ resistor's own, over the 12.5 kHz the results
    /// span, is half a count).
    pub const RANGED: Self = Self {
        blocks: 1,
        ranged: true,
    };

    /// Both: ranged stages and the comb an octave lower over two blocks.
    pub const BOTH: Self = Self {
        blocks: 2,
        ranged: true,
    };

    /// The tones a record of `layout` reads, Hz.
    pub fn tones_hz(&self, layout: &Layout) -> [f64; TONES] {
        layout.tones_hz().map(|f| f as f64 / self.blocks as f64)
    }

    /// Instants a record of `layout` reads.
    pub fn instants(&self, layout: &Layout) -> usize {
        layout.instants() * self.blocks as usize
    }

    /// The front end `fe` as it reads a sensor of impedances `z` (Ω, at
    /// [`Probe::tones_hz`]): its stage ranged where this probe ranges.
    pub fn front_end(&self, fe: &ArrayFrontEnd, z: &[Complex64; TONES]) -> ArrayFrontEnd {
        if !self.ranged {
            return *fe;
        }
        let volts = fe.layout.tone_volts();
        let peak = |ohm: f64| (0..TONES).map(|k| volts[k] / z[k].norm() * ohm).sum::<f64>();
        let tia_ohm = RANGED_OHM
            .iter()
            .copied()
            .filter(|&ohm| peak(ohm) <= instrument::array::TIA_PEAK_VOLT)
            .fold(fe.tia_ohm, f64::max);
        ArrayFrontEnd { tia_ohm, ..*fe }
    }
}

/// The model a record is read on, in f64: a uniform line of `r_ohm` and
/// `c_farad` with tab leads of `lead_ratio` times its resistance in
/// series, on a film of `loss_tangent` (C·(1 − j·tan δ)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// The line's resistance, Ω.
    pub r_ohm: f64,
    /// Its capacitance, F.
    pub c_farad: f64,
    /// The tab leads' resistance over the line's.
    pub lead_ratio: f64,
    /// The film's tan δ.
    pub loss_tangent: f64,
}

impl Line {
    /// The impedance at `f_hz`, Ω.
    pub fn impedance(&self, f_hz: f64) -> Complex64 {
        let w = TAU * f_hz;
        let y = Complex64::new(w * self.c_farad * self.loss_tangent, w * self.c_farad);
        continuous(self.r_ohm, y) + self.lead_ratio * self.r_ohm
    }

    /// ∂Z/∂(ln R, ln C, tan δ) at `f_hz` (central differences), Ω.
    fn slopes(&self, f_hz: f64) -> [Complex64; 3] {
        const H: f64 = 1e-5;
        const H_T: f64 = 1e-6;
        let at = |dr: f64, dc: f64, dt: f64| {
            Line {
                r_ohm: self.r_ohm * dr.exp(),
                c_farad: self.c_farad * dc.exp(),
                loss_tangent: self.loss_tangent + dt,
                ..*self
            }
            .impedance(f_hz)
        };
        [
            (at(H, 0.0, 0.0) - at(-H, 0.0, 0.0)) / (2.0 * H),
            (at(0.0, H, 0.0) - at(0.0, -H, 0.0)) / (2.0 * H),
            (at(0.0, 0.0, H_T) - at(0.0, 0.0, -H_T)) / (2.0 * H_T),
        ]
    }
}

/// 1σ of each component of a tone's impedance `z` (Ω) at `volts` over
/// `instants`, through the array's front end `fe` (each input's noise
/// its own, the excitation read at its gain, the current through the
/// stage's transimpedance).
pub fn z_sigma(fe: &ArrayFrontEnd, z: Complex64, volts: f64, instants: usize) -> f64 {
    let counts_per_volt = instrument::array::HALF_SCALE as f64 / fe.half_scale_volt;
    let a_v = volts * fe.v_gain * counts_per_volt;
    let a_i = volts / z.norm() * fe.tia_ohm * counts_per_volt;
    let relative =
        (2.0 / instants as f64).sqrt() * fe.noise_counts * (1.0 / (a_v * a_v) + 1.0 / (a_i * a_i)).sqrt();
    z.norm() * relative
}

/// What one record can know of C.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Information {
    /// The least 1σ of ln C any unbiased reading reaches.
    pub sigma_ln_c: f64,
    /// The most ln C moves per unit of a one-tone error's share of √χ²
    /// (∞ where a tone's error leaves no residual).
    pub hidden_ln_c: f64,
}

/// What a record of `tones` (Hz) with each component's σ `sigma_ohm`
/// (Ω) knows of C on `line`, tan δ within `film_spread` (1σ; 0: known);
/// None where the information is singular.
pub fn information(line: &Line, tones: &[(f64, f64)], film_spread: f64) -> Option<Information> {
    let p = if film_spread > 0.0 { 3 } else { 2 };
    // The whitened design: two rows a tone, and the film's prior.
    let mut a: Vec<Vec<f64>> = vec![];
    for &(f, sigma) in tones {
        let j = line.slopes(f);
        a.push((0..p).map(|i| j[i].re / sigma).collect());
        a.push((0..p).map(|i| j[i].im / sigma).collect());
    }
    if p == 3 {
        a.push(vec![0.0, 0.0, 1.0 / film_spread]);
    }
    let fisher: Vec<Vec<f64>> = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| a.iter().map(|row| row[i] * row[j]).sum())
                .collect()
        })
        .collect();
    let cov = crate::lsq::covariance(&fisher, 1.0)?;
    let sigma_ln_c = cov[1][1].sqrt();
    // g: ∂ln C/∂(whitened data), F⁻¹·Aᵀ's row of ln C.
    let g: Vec<f64> = a
        .iter()
        .map(|row| (0..p).map(|i| cov[1][i] * row[i]).sum())
        .collect();
    // Tone k's block of the residual's projector I − A·F⁻¹·Aᵀ.
    let proj = |r: usize, s: usize| {
        let h: f64 = (0..p)
            .map(|i| (0..p).map(|j| a[r][i] * cov[i][j] * a[s][j]).sum::<f64>())
            .sum();
        f64::from(r == s) - h
    };
    let mut hidden_ln_c: f64 = 0.0;
    for k in 0..tones.len() {
        let (r, s) = (2 * k, 2 * k + 1);
        let m = [[proj(r, r), proj(r, s)], [proj(s, r), proj(s, s)]];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let (gr, gs) = (g[r], g[s]);
        // gᵀ·M⁻¹·g with M⁻¹ = adj(M)/det.
        let quad = (gr * gr * m[1][1] - 2.0 * gr * gs * m[0][1] + gs * gs * m[0][0]) / det;
        hidden_ln_c = hidden_ln_c.max(if det > 1e-12 { quad.sqrt() } else { f64::INFINITY });
    }
    Some(Information {
        sigma_ln_c,
        hidden_ln_c,
    })
}

/// A share of records, over every sensor and of the least.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Share {
    /// Of every sensor's records.
    pub all: f64,
    /// Of the least sensor's.
    pub least: f64,
}

impl Share {
    /// From each sensor's count of records that pass, of `records` each.
    fn of(pass: &[u64], records: u64) -> Self {
        let least = pass.iter().copied().min().unwrap_or(0);
        let all = pass.iter().sum::<u64>() as f64 / (records * pass.len() as u64).max(1) as f64;
        Self {
            all,
            least: least as f64 / records.max(1) as f64,
        }
    }
}

/// The ceilings of one case read by one probe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ceiling {
    /// The case (its layout's records).
    pub case: Case,
    /// What a record reads.
    pub probe: Probe,
    /// Records with [`NOISE_SIGMAS`]·σ_lnC ≤ 1 %.
    pub noise: Share,
    /// Records with 5·σ_lnC + [`CHECK_SHARE`]·h ≤ 1 %.
    pub checked: Share,
    /// The largest σ_lnC of the case's records.
    pub sigma_max: f64,
}

/// The ceilings of `case` read by `probe`.
pub fn run(case: Case, probe: Probe) -> Ceiling {
    let layout = case.layout;
    let fe = ArrayFrontEnd::reference(layout);
    let mut skin = Skin::new(&case);
    let lead_ratio = f64::from(skin.params.effects.lead_ratio());
    let loss_tangent = skin.params.effects.get(Effect::DielectricLoss);
    let block_s = layout.block_us() as f64 * 1e-6;
    let (hz, volts, instants) = (
        probe.tones_hz(&layout),
        layout.tone_volts(),
        probe.instants(&layout),
    );
    let (mut noise, mut checked, mut records) = ([0u64; SENSORS], [0u64; SENSORS], 0);
    let mut sigma_max: f64 = 0.0;
    for b in 0..blocks_of(&layout) {
        let t = b as f64 * block_s;
        let sensors = skin.at(t + 0.5 * block_s);
        if t < SETTLE_S {
            continue;
        }
        records += 1;
        for (s, sensor) in sensors.iter().enumerate() {
            let truth = sensor.truth();
            let line = Line {
                r_ohm: truth.r_line_ohm,
                c_farad: truth.c_farad,
                lead_ratio,
                loss_tangent,
            };
            let z = hz.map(|f| line.impedance(f));
            let read = probe.front_end(&fe, &z);
            let tones: Vec<(f64, f64)> = (0..TONES)
                .map(|k| (hz[k], z_sigma(&read, z[k], volts[k], instants)))
                .collect();
            let info = information(&line, &tones, FILM_SPREAD);
            let (sigma, hidden) =
                info.map_or((f64::INFINITY, f64::INFINITY), |i| (i.sigma_ln_c, i.hidden_ln_c));
            sigma_max = sigma_max.max(sigma);
            noise[s] += u64::from(NOISE_SIGMAS * sigma <= 0.01);
            checked[s] += u64::from(5.0 * sigma + CHECK_SHARE * hidden <= 0.01);
        }
    }
    Ceiling {
        case,
        probe,
        noise: Share::of(&noise, records),
        checked: Share::of(&checked, records),
        sigma_max,
    }
}

/// The probes of the table: the layout's comb, an octave lower over two
/// blocks, through ranged stages, and both.
pub const PROBES: [Probe; 4] = [Probe::COMB, Probe::OVER_TWO_BLOCKS, Probe::RANGED, Probe::BOTH];

/// [`crate::availability::cases`], each read by every one of [`PROBES`].
pub fn rows() -> Vec<[Ceiling; 4]> {
    crate::availability::cases()
        .into_iter()
        .map(|case| PROBES.map(|p| run(case, p)))
        .collect()
}

/// The ceilings as a Markdown table, a row a case.
pub fn markdown(rows: &[[Ceiling; 4]]) -> String {
    let mut md = String::from(
        "| records/s | electrodes | stretching | largest σ of C | noise ceiling | checked ceiling | an octave lower over two blocks: noise; checked | ranged stages: noise; checked | both: noise; checked |\n\
         |---:|---:|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for [own, lower, ranged, both] in rows {
        let c = own.case;
        md += &format!(
            "| {} | {}× the paper's | {} | {:.3} % | {} | {} | {} | {} | {} |\n",
            c.layout.records_per_s(),
            c.r_scale,
            crate::availability::stretching(c.rate_mm_s),
            100.0 * own.sigma_max,
            share_cell(own.noise),
            share_cell(own.checked),
            pair_cell(lower),
            pair_cell(ranged),
            pair_cell(both),
        );
    }
    md
}

/// "noise; checked" of `c`.
fn pair_cell(c: &Ceiling) -> String {
    format!("{}; {}", share_cell(c.noise), share_cell(c.checked))
}

/// "all % (least sensor %)".
fn share_cell(s: Share) -> String {
    format!("{:.1} % ({:.1} %)", 100.0 * s.all, 100.0 * s.least)
}
