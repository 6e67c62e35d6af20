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
    /// How far a number may be off and still match: the paper's printed
    /// precision (half a step, √3·σ), for every number alike (a band of
    /// 20 % around the relaxed 180 pF, ±36 pF, would test nothing). A
    /// statement of order (unit `order`) holds or not.
    pub fn tolerance(&self) -> f64 {
        3f64.sqrt() * self.sigma
    }

    /// A number the model predicts (`predict`): the only ones judged. The
    /// others went into the model (`input`), were fitted (`fit`), or set
    /// its parameters (`dynamic`): matching them says nothing of it.
    pub fn predicted(&self) -> bool {
        self.role == "predict"
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

    /// What the table says of it: a prediction within or off; for the
    /// rest, where the number came into the model (never judged).
    pub fn verdict(&self) -> &'static str {
        match (self.claim.predicted(), self.within(), self.claim.role.as_str()) {
            (true, true, _) => "within",
            (true, false, _) => "**off**",
            (false, _, "input") => "an input",
            (false, _, "fit") => "fitted",
            (false, _, _) => "set the dynamics",
        }
    }
}

/// The predictions of `outcomes` the model misses, by name.
pub fn misses(outcomes: &[Outcome]) -> Vec<&str> {
    outcomes
        .iter()
        .filter(|o| o.claim.predicted() && !o.within())
        .map(|o| o.claim.id.as_str())
        .collect()
}

/// Fig. 13's statement as a number: 1 when the paper's simulation with
/// n = 1, 2, 4, 30 elements comes nearer the measurement (RMS of Cs) in
/// that order and 60 elements do not come noticeably nearer than 30
/// (not by a tenth), else 0; and the RMS values, pF.
pub fn fig13_order(readings: &[Reading], cal: &[(f64, f64)]) -> (f64, Vec<(u8, f64)>) {
    let rms: Vec<(u8, f64)> = [1u8, 2, 4, 30, 60]
        .iter()
        .map(|&n| {
            let d = readings.iter().map(|r| pf(paper_simulation(cal, r, n) - r.cs));
            (n, crate::numerics::rms_max(d).0)
        })
        .collect();
    let ordered = rms[..4].windows(2).all(|w| w[1].1 < w[0].1);
    let flat = rms[4].1 > 0.9 * rms[3].1;
    (if ordered && flat { 1.0 } else { 0.0 }, rms)
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
            (_, "fig13_order") => fig13_order(run(c.rate_mm_s, f)?, cal).0,
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
         Use: `fit`, the static points `identify` fits (the tab-lead fraction); `input`, measured inputs of the model; `dynamic`, the numbers that set the simulated electrodes' resistance under cycling (the text gives none); `predict`, numbers no parameter was set from: the only ones judged, within the paper's printed precision (half a step of its last digit) or off. The others are shown for what the model reproduces of what it was given.\n\n\
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
        let v = |x: f64| match c.unit.as_str() {
            "Ω" => format!("{:.0} kΩ", x / 1e3),
            "order" => (if x == 1.0 { "holds" } else { "fails" }).to_string(),
            _ => format!("{x:.2}{unit}"),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} mm | {} mm/s | {} Hz | {} | {} | {} | {} | {} |",
            c.id,
            c.role,
            c.quantity,
            c.stretch_mm,
            c.rate_mm_s,
            c.freq_hz,
            v(c.value),
            v(o.sim),
            if c.unit == "order" {
                "–".to_string()
            } else {
                v(o.deviation())
            },
            if c.unit == "order" {
                "–".to_string()
            } else {
                format!("±{}", v(c.tolerance()))
            },
            o.verdict()
        );
    }
    let predicted = outcomes.iter().filter(|o| o.claim.predicted()).count();
    let missed = misses(outcomes);
    let _ = writeln!(
        md,
        "\n{} of {predicted} predictions within the paper's precision{}",
        predicted - missed.len(),
        if missed.is_empty() {
            ".".to_string()
        } else {
            format!("; the model misses {}.", missed.join(", "))
        }
    );
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
    let total = out.iter().filter(|o| o.claim.predicted()).count();
    let missed = misses(&out);
    let mut md = format!(
        "## Prediction out of fit (the paper's dynamic numbers)\n\n\
         The paper's sensor (its text's R and C, resistance dynamics set from the `dynamic` rows) with the effects fitted above. \
         `predict` rows set no parameter and are judged against the paper's printed precision: {} of {total} within{}. \
         The `dynamic` rows set the dynamics and are not judged.\n\n\
         | claim | use | quantity | rate | f | paper | predicted | deviation | tolerance | |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|---|\n",
        total - missed.len(),
        if missed.is_empty() {
            String::new()
        } else {
            format!(" (missed: {})", missed.join(", "))
        }
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
            o.verdict(),
            u = c.unit
        );
    }
    Ok((md, out))
}

/// How the model knows a parameter of the paper's sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Known {
    /// Printed in the paper's text (or follows from printed numbers).
    Measured,
    /// Fitted to printed numbers that determine it.
    Fitted,
    /// Chosen: the text does not determine it.
    Assumed,
}

impl Known {
    fn word(self) -> &'static str {
        match self {
            Known::Measured => "measured",
            Known::Fitted => "fitted",
            Known::Assumed => "**assumed**",
        }
    }
}

/// Every parameter of the paper's sensor as the model holds it, with how
/// it is known and from what: (parameter, value, how known, from what).
pub fn provenance(p: &SensorParams) -> Vec<(&'static str, String, Known, &'static str)> {
    let (t, b) = (&p.top, &p.bottom);
    let lead = p.effects.get(instrument::effects::Effect::LeadResistance);
    vec![
        (
            "C at 0 mm (15 mm prestretch)",
            format!("{:.1} pF", p.c_rest_farad * 1e12),
            Known::Measured,
            "175 pF unstretched (`c_unstretched`) through C = 175 pF·λ^1.13, the exponent set so that 0 mm reads ~205 pF at 2 kHz (`static_2k_0`)",
        ),
        (
            "C slope (C ∝ 1 + s/L)",
            format!("L = {:.1} mm", p.rest_length_mm),
            Known::Fitted,
            "the stretch law above, linear over 0…30 mm within 0.3 %",
        ),
        (
            "electrode R at rest, top / bottom",
            format!("{:.0} / {:.0} kΩ", t.r_rest_ohm / 1e3, b.r_rest_ohm / 1e3),
            Known::Measured,
            "`r_top_0`, `r_bottom_0`",
        ),
        (
            "static R drop at 30 mm, top / bottom; flat to",
            format!(
                "{:.0} / {:.0} %; {:.0} mm",
                t.static_drop * 100.0,
                b.static_drop * 100.0,
                t.knee_mm
            ),
            Known::Measured,
            "`r_top_30`, `r_bottom_30`, `r_top_15` (\"approximately the same\" at 15 mm)",
        ),
        (
            "breakdown gain, top / bottom; cycling excess",
            format!(
                "{:.3} / {:.3} per mm; {:.1}",
                t.breakdown_per_mm, b.breakdown_per_mm, t.cycling_excess
            ),
            Known::Fitted,
            "the three `dynamic` numbers (relaxed 180 pF, 16 and 30 pF undershoots at 2 kHz): three numbers for three parameters, so matching them tests nothing",
        ),
        (
            "breakdown τ; recovery τ top / bottom; recovery gain",
            format!(
                "{:.2} s; {:.1} / {:.1} s; {:.1}",
                t.tau_breakdown_s, t.tau_recovery_s, b.tau_recovery_s, t.recovery_gain
            ),
            Known::Assumed,
            "the shape the text gives Fig. 9 (a peak before the motion ends, then a transient decay); it prints no time constant",
        ),
        (
            "tab leads (share of each electrode's end-to-end R)",
            format!("{lead:.4}"),
            Known::Assumed,
            "fitted to the static 6 kHz ratios (`sweep_6k_*`), but on capacitance alone it is degenerate with a line resistance scaled by ≈ 0.36, leads at the far end and resistance packed at the ends: only a measured split of the resistance would separate them. The paper's own n = 30 simulation, with all the recorded resistance in the line, is 3–5 % from its measurement (`sim_diff_*`), which argues against leads",
        ),
    ]
}

/// [`provenance`] as a Markdown section.
pub fn provenance_table(p: &SensorParams) -> String {
    let mut md = String::from(
        "### The paper's sensor in the model: what is measured, fitted or assumed\n\n\
         | parameter | value | known | from |\n|---|---|---|---|\n",
    );
    for (name, value, known, from) in provenance(p) {
        let _ = writeln!(md, "| {name} | {value} | {} | {from} |", known.word());
    }
    md
}
