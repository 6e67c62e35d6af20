//! Every number of the paper's text (`data/paper/claims.csv`, embedded)
//! against what the simulated skin gives for it: the static points the
//! model is fitted on, the measured inputs, and the dynamic numbers it
//! predicts out of fit.

use super::elements::paper_simulation;
use super::*;
use serde::Deserialize;

/// The paper's numbers, as transcribed (`data/paper/claims.csv`).
pub const CLAIMS_CSV: &str = include_str!("../../../data/paper/claims.csv");

/// One number of the paper's text.
#[derive(Clone, Debug, Deserialize)]
pub struct Claim {
    /// Name.
    pub id: String,
    /// `fit`, `input`, `dynamic`, `predict`, `geometry` or `setup`.
    #[serde(rename = "use")]
    pub role: String,
    /// What it is.
    pub quantity: String,
    /// Value as printed.
    pub value: f64,
    /// Its unit.
    pub unit: String,
    /// Stretch, mm (0: the paper's prestretched rest).
    pub stretch_mm: f64,
    /// Stretch rate, mm/s (0: static).
    pub rate_mm_s: f64,
    /// Excitation frequency, Hz (0: not stated).
    pub freq_hz: f64,
    /// 1σ implied by the printed precision.
    pub sigma: f64,
    /// Where in the text.
    #[serde(rename = "where")]
    pub place: String,
}

impl Claim {
    /// How far the simulation may be off and still match: the printed
    /// precision (half a step, √3·σ) for a static point or an input; for
    /// a dynamic number, 20 % of it (or the printed precision, if larger).
    pub fn tolerance(&self) -> f64 {
        let printed = 3f64.sqrt() * self.sigma;
        if self.rate_mm_s > 0.0 {
            printed.max(0.2 * self.value.abs())
        } else {
            printed
        }
    }
}

/// Parse claims (CSV with `#` comments); errors name the line.
pub fn parse_claims(text: &str) -> Result<Vec<Claim>> {
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let mut out = vec![];
    for rec in rd.deserialize() {
        let c: Claim = rec.context("data/paper/claims.csv")?;
        anyhow::ensure!(
            c.value.is_finite() && c.sigma.is_finite() && c.sigma >= 0.0,
            "data/paper/claims.csv: {}: value and sigma must be finite, sigma ≥ 0",
            c.id
        );
        out.push(c);
    }
    Ok(out)
}

/// One claim beside the simulation.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The claim.
    pub claim: Claim,
    /// What the simulated skin gives, in the claim's unit.
    pub sim: f64,
}

impl Outcome {
    /// Simulation − paper.
    pub fn deviation(&self) -> f64 {
        self.sim - self.claim.value
    }

    /// Within the claim's tolerance?
    pub fn within(&self) -> bool {
        self.deviation().abs() <= self.claim.tolerance()
    }
}

/// The simulated skin's value for every claim it can model (`geometry`
/// and `setup` rows are not modelled), using the LCR runs of Fig. 10 and
/// the static calibration for the paper's own n = 30 simulation.
pub fn compare(ctx: &Ctx, claims: &[Claim], runs: &[Run], cal: &[(f64, f64)]) -> Result<Vec<Outcome>> {
    let p = ctx.sensor;
    let cs_at = |s: f64, f: f64| pf(series_cs(static_sensor(p, s).impedance(f), f));
    let run = |rate: f64, f: f64| -> Result<&[Reading]> {
        Ok(&runs
            .iter()
            .find(|x| x.rate == rate && x.freq_hz == f)
            .with_context(|| format!("no {rate} mm/s {f} Hz run"))?
            .readings)
    };
    let mut out = vec![];
    for c in claims {
        let (s, f) = (c.stretch_mm, c.freq_hz);
        let sim = match (c.role.as_str(), c.id.as_str()) {
            ("geometry" | "setup", _) => continue,
            (_, id) if id.starts_with("sweep_6k") => 100.0 * (cs_at(s, 6000.0) / cs_at(s, 500.0) - 1.0),
            (_, "static_2k_0") => cs_at(s, f),
            (_, "c_unstretched") => pf(p.capacitance(s)),
            (_, id) if id.starts_with("r_top") || id.starts_with("r_bottom") => {
                let r = |s: f64| {
                    let t = static_sensor(p, s).truth();
                    if id.starts_with("r_top") {
                        t.r_top_ohm
                    } else {
                        t.r_bottom_ohm
                    }
                };
                if c.unit == "%" {
                    100.0 * (r(s) / r(0.0) - 1.0)
                } else {
                    r(s)
                }
            }
            (_, "relaxed_2k_20") => pf(run(c.rate_mm_s, f)?[0].cs),
            (_, id) if id.starts_with("undershoot") => {
                pf(undershoot(first_period(run(c.rate_mm_s, f)?), |x| x.cs))
            }
            (_, id) if id.starts_with("sim_diff") => {
                // The paper's n = 30 simulation against the measurement,
                // in % of C, where the sensor rests at 0 mm.
                let rs = run(c.rate_mm_s, f)?;
                let d: Vec<f64> = rs
                    .iter()
                    .filter(|r| r.stretch_mm.abs() < 1e-9)
                    .map(|r| 100.0 * (paper_simulation(cal, r, 30) / r.cs - 1.0).abs())
                    .collect();
                anyhow::ensure!(!d.is_empty(), "{}: no reading at rest", c.id);
                d.iter().sum::<f64>() / d.len() as f64
            }
            (_, id) => anyhow::bail!("claim {id}: no simulation for it"),
        };
        out.push(Outcome {
            claim: c.clone(),
            sim,
        });
    }
    Ok(out)
}

/// The markdown table of `outcomes`.
pub fn table(outcomes: &[Outcome]) -> String {
    let mut md = String::from(
        "### Every number of the paper's text against the simulated skin\n\n\
         Use: `fit`, the static points `identify` fits (the tab-lead fraction); `input`, measured inputs of the model; `dynamic`, the numbers that set the simulated electrodes' resistance under cycling (the text gives none); `predict`, numbers no parameter was set from. Tolerance: the printed precision for static numbers, 20 % for dynamic ones.\n\n\
         | claim | use | quantity | stretch | rate | f | paper | simulation | deviation | tolerance | |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    for o in outcomes {
        let c = &o.claim;
        let unit = if c.unit == "%" {
            " %".to_string()
        } else {
            format!(" {}", c.unit)
        };
        let v = |x: f64| {
            if c.unit == "Ω" {
                format!("{:.0} kΩ", x / 1e3)
            } else {
                format!("{x:.2}{unit}")
            }
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} mm | {} mm/s | {} Hz | {} | {} | {} | ±{} | {} |",
            c.id,
            c.role,
            c.quantity,
            c.stretch_mm,
            c.rate_mm_s,
            c.freq_hz,
            v(c.value),
            v(o.sim),
            v(o.deviation()),
            v(c.tolerance()),
            if o.within() { "within" } else { "**off**" }
        );
    }
    md
}

/// The paper's dynamic numbers predicted from a fit of its static sweep:
/// the paper's sensor (`SensorParams::PAPER`: the text's R and C and the
/// resistance dynamics set from its three `dynamic` numbers) with the
/// static effects `fitted` in place of its own, read by the LCR meter as
/// in Fig. 10 (one period per run). Returns the markdown section and the
/// outcomes of every `dynamic` and `predict` claim.
pub fn predict_paper(fitted: &EffectSet) -> Result<(String, Vec<Outcome>)> {
    let dir = tempfile::tempdir().context("a scratch folder")?;
    let mut ctx = Ctx::new(dir.path(), 1)?;
    ctx.periods = 1;
    ctx.sensor = SensorParams {
        effects: fitted.statics(),
        ..SensorParams::PAPER
    };
    let claims = parse_claims(CLAIMS_CSV)?;
    let runs = lcr_runs(&ctx);
    let cal = calibration(&ctx)?;
    let out: Vec<Outcome> = compare(&ctx, &claims, &runs, &cal)?
        .into_iter()
        .filter(|o| o.claim.role == "dynamic" || o.claim.role == "predict")
        .collect();
    let within = out
        .iter()
        .filter(|o| o.claim.role == "predict" && o.within())
        .count();
    let total = out.iter().filter(|o| o.claim.role == "predict").count();
    let mut md = format!(
        "## Prediction out of fit (the paper's dynamic numbers)\n\n\
         The paper's sensor (its text's R and C, resistance dynamics set from the `dynamic` rows) with the effects fitted above. \
         `predict` rows set no parameter: {within} of {total} within their tolerance (20 %, or the printed precision where larger).\n\n\
         | claim | use | quantity | rate | f | paper | predicted | deviation | tolerance | |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|---|\n"
    );
    for o in &out {
        let c = &o.claim;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} mm/s | {} Hz | {:.2} {u} | {:.2} {u} | {:+.2} {u} | ±{:.2} {u} | {} |",
            c.id,
            c.role,
            c.quantity,
            c.rate_mm_s,
            c.freq_hz,
            c.value,
            o.sim,
            o.deviation(),
            c.tolerance(),
            if o.within() { "within" } else { "**off**" },
            u = c.unit
        );
    }
    Ok((md, out))
}
