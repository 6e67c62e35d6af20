//! The residual figure of `identify`.

use super::Report;
use crate::dataset::{DataSet, Kind};
use crate::model::Prepared;
use anyhow::Result;

/// Residual figure: per file, measured − model before (baseline) and after
/// (final model) against time (traces) or frequency (sweep).
pub fn plot(report: &Report, ds: &DataSet, path: &std::path::Path) -> Result<()> {
    use crate::plot::{figure, Panel, Series};
    let prep = Prepared::new(ds, report.options.sweep)?;
    let (b, f) = (report.baseline(), report.final_fit());
    let panels: Vec<Panel> = prep
        .files
        .iter()
        .enumerate()
        .map(|(i, file)| {
            let x: Vec<f64> = if file.kind == Kind::Trace {
                file.t.clone()
            } else {
                file.f.clone()
            };
            let pts = |r: &[f64]| x.iter().copied().zip(r.iter().copied()).collect::<Vec<_>>();
            let mut series = vec![Series::new(format!("before: {}", b.label()), pts(&b.residual[i]))];
            if report.named_fit().is_some() {
                series.push(Series::new(format!("after: {}", f.label()), pts(&f.residual[i])));
            }
            Panel {
                title: file.name.clone(),
                x_label: if file.kind == Kind::Trace {
                    "time (s)"
                } else {
                    "frequency (Hz)"
                }
                .into(),
                y_label: "measured − model (pF)".into(),
                log_x: file.kind != Kind::Trace,
                series,
            }
        })
        .collect();
    figure(path, "identify: residual before and after", &panels)
}
