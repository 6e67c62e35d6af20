//! Every mechanism `identify` tried on the paper's static sweep against
//! all of the paper's printed numbers at once: the static points it was
//! fitted on (each within its printed precision?) and the dynamic
//! numbers it predicts out of fit ([`predict_paper`]). A mechanism is
//! consistent when no number excludes it; the survivors are set side by
//! side with the measurement that would separate them.

use super::claims::{predict_paper, Outcome};
use crate::dataset::{DataSet, Kind};
use crate::identify::{compete, params_text, Fit, Report};
use crate::model::Prepared;
use anyhow::Result;
use std::fmt::Write as _;

/// One mechanism against the paper's numbers.
#[derive(Clone, Debug)]
pub struct Mechanism {
    /// Its label (the baseline's, or the effects').
    pub label: String,
    /// Its fitted parameters, ± 1σ.
    pub params: String,
    /// Why the data cannot vouch for its fit (None: they can).
    pub unresolved: Option<String>,
    /// Static points fitted.
    pub static_points: usize,
    /// The static points outside their printed precision: (point,
    /// measured − model, tolerance), pF.
    pub statics_off: Vec<(String, f64, f64)>,
    /// The paper's dynamic numbers it predicts out of fit.
    pub dynamics: Vec<Outcome>,
}

impl Mechanism {
    /// The numbers that exclude it: static points off, predictions off.
    pub fn excluded_by(&self) -> Vec<String> {
        self.statics_off
            .iter()
            .map(|s| s.0.clone())
            .chain(
                self.dynamics
                    .iter()
                    .filter(|o| o.claim.predicted() && !o.within())
                    .map(|o| o.claim.id.clone()),
            )
            .collect()
    }

    /// No printed number excludes it.
    pub fn consistent(&self) -> bool {
        self.excluded_by().is_empty()
    }
}

/// The table of every mechanism of `report` (the baseline, each single
/// effect, each pair), fitted on the static data set `ds`, against the
/// paper's numbers; the markdown section and the rows.
pub fn consistency(ds: &DataSet, report: &Report) -> Result<(String, Vec<Mechanism>)> {
    let prep = Prepared::new(ds, report.options.sweep)?;
    let fits: Vec<&Fit> = std::iter::once(report.baseline())
        .chain(&report.singles)
        .chain(&report.pairs)
        .collect();
    let mut rows = vec![];
    for f in &fits {
        rows.push(mechanism(&prep, f)?);
    }
    let md = markdown(&prep, &fits, &rows, report.noise_floor_pf);
    Ok((md, rows))
}

/// One fit's row.
fn mechanism(prep: &Prepared, f: &Fit) -> Result<Mechanism> {
    let mut statics_off = vec![];
    let mut static_points = 0;
    for (file, r) in prep.files.iter().zip(&f.residual) {
        if file.kind == Kind::Trace {
            continue;
        }
        for (i, e) in r.iter().enumerate() {
            static_points += 1;
            // The printed precision: half a step, √3·σ (as the claims).
            let tol = 3f64.sqrt() * file.sigma[i];
            if tol.is_finite() && e.abs() > tol {
                statics_off.push((format!("{:.0} Hz at {:.0} mm", file.f[i], file.s[i]), *e, tol));
            }
        }
    }
    let (_, dynamics) = predict_paper(&f.params)?;
    Ok(Mechanism {
        label: f.label(),
        params: params_text(f),
        unresolved: f.unresolved.clone(),
        static_points,
        statics_off,
        dynamics,
    })
}

/// The section: a row per mechanism, then the survivors and what would
/// separate them.
fn markdown(prep: &Prepared, fits: &[&Fit], rows: &[Mechanism], noise_pf: f64) -> String {
    let predicted = rows
        .first()
        .map_or(0, |m| m.dynamics.iter().filter(|o| o.claim.predicted()).count());
    let mut md = format!(
        "## Every mechanism against the paper's numbers\n\n\
         Each mechanism fitted to the static sweep, then judged against every printed number at once: \
         its static points (within √3·σ of the printed precision?) and the {predicted} dynamic numbers it predicts out of fit \
         (the `predict` rows above). Excluded by: the numbers it misses.\n\n\
         | mechanism | parameters (± 1σ) | static points off | predictions off | verdict |\n|---|---|---:|---:|---|\n"
    );
    for m in rows {
        let off = m
            .dynamics
            .iter()
            .filter(|o| o.claim.predicted() && !o.within())
            .count();
        let ex = m.excluded_by();
        let _ = writeln!(
            md,
            "| {}{} | {} | {} of {} | {off} of {predicted} | {} |",
            m.label,
            m.unresolved
                .as_ref()
                .map_or(String::new(), |_| " (not pinned down)".into()),
            if m.params.is_empty() { "–" } else { &m.params },
            m.statics_off.len(),
            m.static_points,
            if ex.is_empty() {
                "**consistent**".to_string()
            } else {
                format!("excluded by {}", ex.join(", "))
            }
        );
    }
    survivors_md(&mut md, prep, fits, rows, noise_pf);
    md
}

/// The survivors (or the least excluded) and what would separate them,
/// appended to `md`.
fn survivors_md(md: &mut String, prep: &Prepared, fits: &[&Fit], rows: &[Mechanism], noise_pf: f64) {
    let survivors: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].consistent()).collect();
    match survivors.as_slice() {
        [] => {
            let fewest = rows.iter().map(|m| m.excluded_by().len()).min().unwrap_or(0);
            let least: Vec<&str> = rows
                .iter()
                .filter(|m| m.excluded_by().len() == fewest)
                .map(|m| m.label.as_str())
                .collect();
            let _ = writeln!(
                md,
                "\nNo mechanism of the library is consistent with every printed number: the least excluded, by {fewest}, {} {}. What the paper's numbers ask is outside the library, or in its dynamics (the resistance's response to the stretch rate, set from the `dynamic` rows) rather than in the static sensor.",
                if least.len() == 1 { "is" } else { "are" },
                least.join(", ")
            );
            let idx: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i].excluded_by().len() == fewest && rows[i].unresolved.is_none())
                .collect();
            if let [a, b, ..] = idx.as_slice() {
                let _ = writeln!(
                    md,
                    "\nWhat would separate the two least excluded the data vouch for, {} and {}: {}.",
                    rows[*a].label,
                    rows[*b].label,
                    compete::separation(prep, fits[*a], fits[*b], noise_pf)
                );
            }
        }
        [one] => {
            let _ = writeln!(
                md,
                "\nOne mechanism is consistent with every printed number: {}.",
                rows[*one].label
            );
        }
        [first, rest @ ..] => {
            let _ = writeln!(
                md,
                "\nConsistent with every printed number, and what would separate them:\n"
            );
            for &i in rest {
                let _ = writeln!(
                    md,
                    "- {} against {}: {}",
                    rows[i].label,
                    rows[*first].label,
                    compete::separation(prep, fits[*first], fits[i], noise_pf)
                );
            }
        }
    }
}
