//! The line as a series Cs–Rs meter sees it, and back.

use anyhow::{bail, Result};
use dsp_core::invert::{InvertError, Inverter, Line};
use dsp_core::lumped::SeriesRc;
use dsp_core::tline::LineModel;
use dsp_core::Complex32;

/// Parse a model name: `continuous` (or `c`, `inf`) or a ladder size `1`..`64`.
pub fn parse_model(s: &str) -> Result<LineModel, String> {
    match s.trim() {
        "continuous" | "c" | "inf" => Ok(LineModel::Continuous),
        n => match n.parse::<u8>() {
            Ok(n) if (1..=dsp_core::tline::N_MAX).contains(&n) => Ok(LineModel::Ladder(n)),
            _ => Err(format!(
                "model '{s}': expected 'continuous' or a ladder size 1..=64"
            )),
        },
    }
}

/// Human name of a model.
pub fn model_name(m: LineModel) -> String {
    match m {
        LineModel::Ladder(1) => "lumped (n=1)".into(),
        LineModel::Ladder(n) => format!("ladder n={n}"),
        LineModel::Continuous => "continuous".into(),
    }
}

/// What a series meter reads on a line.
#[derive(Clone, Copy, Debug)]
pub struct Reading {
    /// The model evaluated.
    pub model: LineModel,
    /// Excitation frequency, Hz.
    pub f_hz: f64,
    /// x = ωRC.
    pub x: f64,
    /// Line impedance, Ω.
    pub z: Complex32,
    /// The meter's series reading.
    pub series: SeriesRc,
}

/// Evaluate `model` for a line R (Ω), C (F) at `f_hz`.
pub fn read(model: LineModel, r_ohm: f64, c_farad: f64, f_hz: f64) -> Result<Reading> {
    let z = match model.impedance(r_ohm as f32, c_farad as f32, f_hz as f32) {
        Ok(z) => z,
        Err(e) => bail!(
            "cannot evaluate {} at R={r_ohm} Ω, C={c_farad} F, f={f_hz} Hz: {e:?} \
             (supported: ωRC in [{}, {}], i.e. R 1 kΩ–10 MΩ, C 10 pF–1 nF, f 100 Hz–50 kHz)",
            model_name(model),
            dsp_core::tline::X_MIN,
            dsp_core::tline::X_MAX
        ),
    };
    let series = SeriesRc::from_impedance(z, f_hz as f32).map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(Reading {
        model,
        f_hz,
        x: std::f64::consts::TAU * f_hz * r_ohm * c_farad,
        z,
        series,
    })
}

/// The line behind a series reading Cs (F), Rs (Ω) at `f_hz`; with
/// `c_hint`, the branch closest to it where two lines fit.
pub fn invert(model: LineModel, cs_farad: f64, rs_ohm: f64, f_hz: f64, c_hint: Option<f64>) -> Result<Line> {
    invert_with_leads(model, 0.0, cs_farad, rs_ohm, f_hz, c_hint)
}

/// [`invert`] for a sensor with tab leads: a fraction `lead_fraction` of
/// each electrode's end-to-end resistance lies in its leads, outside the
/// capacitor (the catalogue's `lead_resistance`, as `identify` reports
/// it); the line returned is the capacitor's, the leads taken out.
pub fn invert_with_leads(
    model: LineModel,
    lead_fraction: f64,
    cs_farad: f64,
    rs_ohm: f64,
    f_hz: f64,
    c_hint: Option<f64>,
) -> Result<Line> {
    anyhow::ensure!(
        (0.0..1.0).contains(&lead_fraction),
        "--lead-resistance {lead_fraction}: the fraction of each electrode's resistance in its leads is within 0..1"
    );
    let lead_ratio = instrument::effects::EffectSet::NONE
        .with(instrument::effects::Effect::LeadResistance, lead_fraction)
        .lead_ratio();
    let series = SeriesRc {
        cs_farad: cs_farad as f32,
        rs_ohm: rs_ohm as f32,
    };
    let z: Complex32 = series.impedance(f_hz as f32);
    let inv = Inverter::with_leads(model, dsp_core::invert::X_MAX_DEFAULT, lead_ratio)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let r = match c_hint {
        Some(c) => inv.invert_near(z, f_hz as f32, c as f32),
        None => inv.invert(z, f_hz as f32),
    };
    r.map_err(|e| match e {
        InvertError::Ambiguous => anyhow::anyhow!(
            "more than one line fits this reading (one line per reading only for ωRC ≤ {:.2} with {}){}",
            inv.x_unique(),
            model_name(model),
            if c_hint.is_some() {
                ", and the expected capacitance given does not tell them apart"
            } else {
                "; pass --c-hint with the expected capacitance"
            }
        ),
        InvertError::OutOfRange => anyhow::anyhow!(
            "no line of {} with ωRC ≤ {} explains Cs = {cs_farad:e} F, Rs = {rs_ohm:e} Ω at {f_hz} Hz (D = Rs·ωCs = {:.4}{}): lower the frequency",
            model_name(model),
            inv.x_max(),
            rs_ohm * std::f64::consts::TAU * f_hz * cs_farad,
            if (std::f64::consts::TAU * f_hz * cs_farad) < 1e-30 {
                "; |Z| is beyond single precision"
            } else {
                ""
            }
        ),
        InvertError::NotCapacitive => anyhow::anyhow!("Cs and Rs must be positive"),
        other => anyhow::anyhow!("cannot invert: {other}"),
    })
}
