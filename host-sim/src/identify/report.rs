//! The verdict and the reports of `identify`: markdown for people, JSON
//! for tools, parameters in each effect's display unit.

use super::{Fit, Report, Verdict};
use crate::model::{Effect, Search};

fn param_value(e: Effect, v: f64) -> String {
    let i = e.info();
    let text = format!("{:.*}", i.display_decimals, i.display(v));
    if i.display_unit.is_empty() {
        text
    } else {
        format!("{text} {}", i.display_unit)
    }
}

/// Is `v` at the far end of `e`'s range in `search` (not at 0, where the
/// effect is absent)? Then the data may want more than the range holds.
pub fn at_limit(search: &Search, e: Effect, v: f64) -> bool {
    let (lo, hi) = search.range(e);
    let tol = 1e-3 * (hi - lo);
    (hi != 0.0 && v >= hi - tol) || (lo != 0.0 && v <= lo + tol)
}

/// The family of a model, in a clause ("" for none).
fn family_text(f: &Fit) -> String {
    super::family::note(f).map_or(String::new(), |n| format!(" [{n}]"))
}

/// A share as a percentage, never rounded up to all of it.
fn percent(share: f64) -> String {
    if (0.999..1.0).contains(&share) {
        "more than 99.9 %".to_string()
    } else {
        format!("{:.1} %", 100.0 * share)
    }
}

/// A value for a table: whole numbers from 100, else two decimals.
fn num(v: f64) -> String {
    if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

/// Where the floor seen through a model differs from the baseline's by
/// more than 10 %: both.
fn through(model: f64, baseline: f64) -> String {
    if (model / baseline - 1.0).abs() > 0.1 {
        format!(" through this model ({baseline:.3} pF through the baseline)")
    } else {
        String::new()
    }
}

/// Parameters of a fit as "name = value ± σ" (or σ undetermined),
/// marked where a value ends at its search range's limit.
pub fn params_text(f: &Fit) -> String {
    f.fitted
        .iter()
        .zip(&f.sigma)
        .map(|(&e, s)| {
            let v = f.params.get(e);
            // A window's offset within it: where the meter stamps.
            let t = f.params.get(Effect::MeterLag);
            let discrete = f.fitted.contains(&Effect::MeterMean) || f.fitted.contains(&Effect::MeterEwma);
            let reading_s = f.search.row_s;
            let span = (f.params.get(Effect::MeterMean) - 1.0).max(0.0) * reading_s;
            let stamp =
                if !f.effects.contains(&e) && e == Effect::TimeOffset && discrete && v > 0.0 && span > 0.0 {
                    format!(
                        " (the stamp, {:.2} of the readings after the oldest)",
                        (1.0 - v / span).clamp(0.0, 1.0)
                    )
                } else if !f.effects.contains(&e) && e == Effect::TimeOffset && discrete {
                    " (the meter's delay)".to_string()
                } else if !f.effects.contains(&e) && e == Effect::TimeOffset {
                    // Named the stamp within the window's tolerance
                    // (`named`); a fraction of it only where it is one.
                    let frac = 1.0 - v / t;
                    if t > 0.0 && frac > 1.05 {
                        format!(
                            " (the meter's delay: its window ends {} before the stamp)",
                            param_value(e, -v)
                        )
                    } else if t > 0.0 && (-0.05..=1.05).contains(&frac) {
                        format!(
                            " (the stamp, {:.2} of the window after its start)",
                            frac.clamp(0.0, 1.0)
                        )
                    } else {
                        " (the stamp: the window is too short to place it in)".to_string()
                    }
                } else {
                    String::new()
                };
            // A singular normal matrix leaves σ undetermined (a
            // parameter the others make moot: an order of no response).
            let sigma = if s.is_finite() {
                format!(" ± {}", param_value(e, *s))
            } else {
                " (σ undetermined: the data do not constrain it)".to_string()
            };
            format!(
                "{} = {}{sigma}{stamp}{}",
                e.info().key,
                param_value(e, v),
                if at_limit(&f.search, e, v) {
                    " (at the end of its search range)"
                } else {
                    ""
                }
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A fit's parameters and their 1σ, keyed by the catalogue's report keys,
/// in display units.
fn fit_json(
    f: &Fit,
) -> (
    serde_json::Map<String, serde_json::Value>,
    serde_json::Map<String, serde_json::Value>,
) {
    use serde_json::json;
    let params = f
        .fitted
        .iter()
        .map(|&e| (e.info().key.to_string(), json!(e.info().display(f.params.get(e)))))
        .collect();
    let sigma = f
        .fitted
        .iter()
        .zip(&f.sigma)
        .map(|(&e, s)| (e.info().key.to_string(), json!(e.info().display(*s))))
        .collect();
    (params, sigma)
}

impl Report {
    /// The JSON report.
    pub fn json(&self) -> serde_json::Value {
        use serde_json::json;
        let fin = self.final_fit();
        let effects = self.effects_json();
        let stats = |f: &Fit| {
            json!({
                "model": f.label(),
                "rms_pf": f.rms_pf, "max_pf": f.max_pf,
                "noise_pf": f.noise_pf,
                "rms_pct": f.rms_pct, "max_pct": f.max_pct,
                "bic": f.bic,
                "files": f.files,
            })
        };
        let candidates = self.candidates_json();
        json!({
            "baseline": stats(self.baseline()),
            "baselines": self.baselines.iter().map(stats).collect::<Vec<_>>(),
            "effects": effects,
            "final": stats(fin),
            "noise_floor_pf": self.noise_floor_pf,
            "noise_pf": self.noise_pf.iter().map(|(f, s)| json!({"file": f, "sigma_pf": s})).collect::<Vec<_>>(),
            "verdict": self.kind(),
            "family": self.named_fit().and_then(super::family::note),
            "unexplained": self.unexplained,
            "remainder": self.remainder,
            "competing": self.competing.iter().map(|c| serde_json::json!({
                "label": c.fit.label(),
                "effects": c.fit.effects.iter().map(|e| e.id()).collect::<Vec<_>>(),
                "parameters": params_text(&c.fit),
                "rms_pf": c.fit.rms_pf,
                "delta_bic": c.delta_bic,
                "separation": c.separation,
                "same_family": c.same_family,
            })).collect::<Vec<_>>(),
            "identifiability": self.named_fit().map_or(vec![], Fit::identifiability),
            "best_attempt": self.best_attempt().map(stats),
            "candidates": candidates,
            "rows": self.rows,
            "decimated": self.decimated.iter().map(|(f, n, k)| json!({"file": f, "rows_read": n, "kept_every": k})).collect::<Vec<_>>(),
            "resistance": self.resistance,
            "flagged_rows": self.flagged.iter().map(|(f, n)| json!({"file": f, "rows": n})).collect::<Vec<_>>(),
            "search": {
                "reach_s": self.search.reach_s,
                "row_s": self.search.row_s,
                "ranges": Effect::library().map(|e| {
                    let (lo, hi) = self.search.range(e);
                    (e.info().key.to_string(), json!([e.info().display(lo), e.info().display(hi)]))
                }).collect::<serde_json::Map<_, _>>(),
            },
            "left_out": self.left_out.iter().map(|(f, a, b)| json!({"file": f, "rows_at_start": a, "rows_at_end": b})).collect::<Vec<_>>(),
            "criterion": {
                "bic": "n·ln(S/n) + k·ln(n)",
                "explained_within_noise": self.options.explained,
                "second_effect_share": self.options.second_share,
                "named_share": self.options.named_share,
                "bic_margin": self.options.bic_margin,
            },
        })
    }

    /// Each named effect (explained, or with a remainder) with its
    /// parameters and their 1σ, for the JSON report.
    fn effects_json(&self) -> Vec<serde_json::Value> {
        use serde_json::json;
        self.named_fit()
            .into_iter()
            .flat_map(|f| {
                let (params, sigma) = fit_json(f);
                f.effects.iter().map(move |&e| {
                    let own = f.params_of(e);
                    let pick = |m: &serde_json::Map<String, serde_json::Value>| {
                        own.iter()
                            .map(|p| (p.info().key.to_string(), m[p.info().key].clone()))
                            .collect::<serde_json::Map<_, _>>()
                    };
                    json!({
                        "id": e.id(),
                        "params": pick(&params),
                        "uncertainty": pick(&sigma),
                        "static": e.is_static(),
                        "at_limit": own.iter().any(|&p| at_limit(&f.search, p, f.params.get(p))),
                        "averaging": f.averaging.filter(|_| !e.is_static()),
                        "rms_pf_after": f.rms_pf,
                    })
                })
            })
            .collect()
    }

    /// Every candidate fitted, for the JSON report.
    fn candidates_json(&self) -> Vec<serde_json::Value> {
        use serde_json::json;
        self
            .singles
            .iter()
            .chain(&self.pairs)
            .map(|f| {
                let (params, sigma) = fit_json(f);
                json!({
                    "ids": f.effects.iter().map(|e| e.id()).collect::<Vec<_>>(),
                    "params": params, "uncertainty": sigma,
                    "averaging": f.averaging,
                    "unresolved": f.unresolved,
                    "at_limit": f.fitted.iter().filter(|&&e| at_limit(&f.search, e, f.params.get(e))).map(|e| e.info().key).collect::<Vec<_>>(),
                    "rms_pf": f.rms_pf, "noise_pf": f.noise_pf, "bic": f.bic,
                    "identifiability": f.identifiability(),
                    "delta_bic": f.bic - self.baseline().bic,
                })
            })
            .collect()
    }

    /// The noise floor seen through the named model, or through the
    /// baseline.
    pub fn final_noise_pf(&self) -> f64 {
        self.named_fit().map_or(self.noise_floor_pf, |f| f.noise_pf)
    }

    /// The outcome in a word: "unexplained", "clean", the accepted
    /// model's label, or the named one's with "+ remainder".
    pub fn outcome(&self) -> String {
        match (self.kind(), self.named_fit()) {
            (Verdict::Explained, Some(f)) => f.label(),
            (Verdict::Named, Some(f)) => format!("{} + remainder", f.label()),
            (k, _) => k.name().to_string(),
        }
    }

    /// A short verdict line.
    pub fn verdict(&self) -> String {
        let nf = self.noise_floor_pf;
        if let (Some(f), Some(rem)) = (&self.named, &self.remainder) {
            return self.named_text(f, rem);
        }
        match (&self.accepted, self.unexplained) {
            (Some(f), _) => format!(
                "explained by {} ({}){}: RMS {:.3} → {:.3} pF, noise floor {:.3} pF{}{}",
                f.label(),
                params_text(f),
                family_text(f),
                self.baseline().rms_pf,
                f.rms_pf,
                f.noise_pf,
                through(f.noise_pf, nf),
                self.competing_text()
            ),
            (None, false) => format!(
                "clean: the {} explains the data (RMS {:.3} pF, noise floor {:.3} pF)",
                self.baseline().line,
                self.baseline().rms_pf,
                nf
            ),
            (None, true) => format!(
                "unexplained: RMS {:.3} pF is {:.1}× the noise floor ({:.3} pF), and no candidate the data vouch for brings it within {}× (best attempt: {} at {:.3} pF, {:.2}× its floor)",
                self.baseline().rms_pf,
                self.baseline().rms_pf / nf,
                nf,
                self.options.explained,
                self.best_attempt().map_or("none".into(), Fit::label),
                self.best_attempt().map_or(f64::NAN, |f| f.rms_pf),
                self.best_attempt().map_or(f64::NAN, |f| f.rms_pf / f.noise_pf)
            ),
        }
    }

    /// The verdict of a model named with a remainder.
    fn named_text(&self, f: &Fit, rem: &crate::identify::remainder::Remainder) -> String {
        let beyond = rem
            .files
            .iter()
            .filter(|x| x.beyond(self.options.explained))
            .count();
        format!(
            "named with a remainder: {} ({}){} takes {} of the misfit beyond the noise, RMS {:.3} → {:.3} pF ({:.2}× the noise floor of {:.3} pF{}); {beyond} of {} files stay beyond {}× their noise{}",
            f.label(),
            params_text(f),
            family_text(f),
            percent(rem.taken),
            self.baseline().rms_pf,
            f.rms_pf,
            f.rms_pf / f.noise_pf,
            f.noise_pf,
            through(f.noise_pf, self.noise_floor_pf),
            rem.files.len(),
            self.options.explained,
            self.competing_text()
        )
    }

    /// The remainder's section: per file, where it lies; what could
    /// leave it.
    fn remainder_md(&self, md: &mut String) {
        use std::fmt::Write as _;
        let Some(rem) = &self.remainder else {
            return;
        };
        let _ = writeln!(
            md,
            "## What is left

{} takes {:.1} % of the baseline's misfit beyond the noise (RMS² − floor²). What it leaves, per file: its RMS against the file's noise, its share of the remainder, and where it gathers (the tenth of the time, the fifth of the stretch range, of a sweep the fifth of its log-frequency range holding the most of it, with the share an even spread would put there), and how it grows with the stretch rate (mean square in the fastest third of the motion over the slowest).
",
            self.final_fit().label(),
            percent(rem.taken)
        );
        let _ = writeln!(
            md,
            "| file | f | RMS | noise | RMS / noise | mean | share | time | stretch | fast / slow |\n|---|---|---:|---:|---:|---:|---:|---|---|---:|"
        );
        let span = |s: &Option<super::remainder::Span>, unit: &str| {
            s.map_or("–".to_string(), |s| {
                format!(
                    "{}–{} {unit}: {:.0} % (even {:.0} %)",
                    num(s.from),
                    num(s.to),
                    100.0 * s.share,
                    100.0 * s.even
                )
            })
        };
        for x in &rem.files {
            let _ = writeln!(
                md,
                "| {} | {} | {:.3} pF | {:.3} pF | {:.2} | {:+.3} pF | {:.0} % | {} | {} | {} |",
                x.file,
                match &x.frequency_span_hz {
                    Some(_) => span(&x.frequency_span_hz, "Hz"),
                    None => format!("{:.0} Hz", x.frequency_hz),
                },
                x.rms_pf,
                x.noise_pf,
                x.rms_pf / x.noise_pf,
                x.mean_pf,
                100.0 * x.share,
                span(&x.time_s, "s"),
                span(&x.stretch_mm, "mm"),
                x.rate_ratio.map_or("–".to_string(), |q| format!("{q:.1}"))
            );
        }
        let _ = writeln!(
            md,
            "
What could leave it:
"
        );
        for h in &rem.hints {
            let _ = writeln!(md, "- {h}");
        }
        md.push('\n');
    }

    /// The competitors in a clause ("" when there are none).
    fn competing_text(&self) -> String {
        if self.competing.is_empty() {
            return String::new();
        }
        let others: Vec<String> = self
            .competing
            .iter()
            .map(|c| format!("{} (ΔBIC {:+.1}; {})", c.fit.label(), c.delta_bic, c.separation))
            .collect();
        format!(
            "; but as well by {}: these data cannot tell them apart",
            others.join("; or ")
        )
    }

    /// The error before and after, per file and overall.
    fn errors_md(&self, md: &mut String) {
        use std::fmt::Write as _;
        let b = self.baseline();
        let f = self.final_fit();
        let _ = writeln!(md, "## Error before and after\n");
        let _ = writeln!(
            md,
            "Before: {}. After: {}. Noise floor: {:.3} pF through the baseline, {:.3} pF through the final model ({} rows). Electrode resistance: {}.\n",
            b.label(),
            f.label(),
            self.noise_floor_pf,
            self.final_noise_pf(),
            self.rows,
            self.resistance
        );
        let _ = writeln!(
            md,
            "| file | noise | RMS before | max before | RMS after | max after | RMS % before | RMS % after |"
        );
        let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|");
        for ((x, y), (_, n)) in b.files.iter().zip(&f.files).zip(&self.noise_pf) {
            let _ = writeln!(
                md,
                "| {} | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} % | {:.3} % |",
                x.file, n, x.rms_pf, x.max_pf, y.rms_pf, y.max_pf, x.rms_pct, y.rms_pct
            );
        }
        let _ = writeln!(
            md,
            "| **all** | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} pF | {:.3} % | {:.3} % |\n",
            self.noise_floor_pf, b.rms_pf, b.max_pf, f.rms_pf, f.max_pf, b.rms_pct, f.rms_pct
        );
        self.coverage_md(md);
    }

    /// What the statistics cover: decimated traces, the time effects'
    /// search, the rows left out.
    fn coverage_md(&self, md: &mut String) {
        use std::fmt::Write as _;
        for (file, n) in &self.flagged {
            let _ = writeln!(
                md,
                "{file}: {n} rows the instrument flagged, left out of every fit.\n"
            );
        }
        for (file, n, k) in &self.decimated {
            let _ = writeln!(
                md,
                "{file}: {n} rows, decimated to every {k}th (at most {} rows per trace; time effects resolved to {k} sampling intervals).\n",
                crate::model::prepared::MAX_TRACE_ROWS
            );
        }
        if self.search.reach_s > 0.0 {
            let r = |e: Effect| self.search.range(e).1 * 1e3;
            let _ = writeln!(
                md,
                "Time effects searched as far as the traces hold (the rows a reading could reach past the recording from, {:.0} % of the shortest trace, left out): offsets ±{:.0} ms, windows to {:.0} ms, first-order τ to {:.0} ms, from half a row interval ({:.1} ms).\n",
                100.0 * crate::model::search::EDGE_BUDGET,
                r(Effect::TimeOffset),
                r(Effect::MeterLag),
                r(Effect::MeterResponse),
                0.5 * self.search.row_s * 1e3
            );
        }
        // Traces with the same rows left out, on one line.
        let mut groups: Vec<((usize, usize), Vec<&str>)> = vec![];
        for (file, a, b) in &self.left_out {
            match groups.iter_mut().find(|g| g.0 == (*a, *b)) {
                Some(g) => g.1.push(file),
                None => groups.push(((*a, *b), vec![file])),
            }
        }
        for ((a, b), files) in groups {
            let _ = writeln!(
                md,
                "{}: {a} rows at the start and {b} at the end left out of the statistics.\n",
                files.join(", ")
            );
        }
    }

    /// The baselines and every candidate fitted.
    fn models_md(&self, md: &mut String) {
        use std::fmt::Write as _;
        let b = self.baseline();
        let _ = writeln!(
            md,
            "## Baselines\n\n| model | RMS | max | BIC |\n|---|---:|---:|---:|"
        );
        for x in &self.baselines {
            let _ = writeln!(
                md,
                "| {} | {:.3} pF | {:.3} pF | {:.0} |",
                x.line, x.rms_pf, x.max_pf, x.bic
            );
        }
        if !self.singles.is_empty() {
            let _ = writeln!(
                md,
                "\n## Candidates\n\nModel selection by BIC = n·ln(S/n) + k·ln n; an effect is accepted when it lowers BIC by more than {} and leaves the RMS within {}× the noise floor seen through the model (the point-to-point scatter of its residual: the Cs noise and the recorded resistances' noise as the model carries it); a second effect, when it takes at least {:.0} % of the misfit the first leaves beyond the noise (RMS² − floor²).\n\n| effects | parameters (± 1σ) | RMS | noise through it | RMS / noise | ΔBIC vs baseline |\n|---|---|---:|---:|---:|---:|",
                self.options.bic_margin,
                self.options.explained,
                100.0 * self.options.second_share
            );
            for x in self.singles.iter().chain(&self.pairs) {
                let _ = writeln!(
                    md,
                    "| {}{} | {} | {:.3} pF | {:.3} pF | {:.2} | {:.0} |",
                    x.label(),
                    x.unresolved.as_ref().map_or(String::new(), |u| format!(" ({u})")),
                    params_text(x),
                    x.rms_pf,
                    x.noise_pf,
                    x.rms_pf / x.noise_pf,
                    x.bic - b.bic
                );
            }
        }
    }

    /// The markdown report; `plot` is the residual figure's file name.
    pub fn markdown(&self, data: &str, plot: Option<&str>) -> String {
        use std::fmt::Write as _;
        let mut md = format!("# identify: {data}\n\n**{}**\n\n", self.verdict());
        // What the data cannot pin down, of the model found (or tried).
        if let Some(x) = self.named_fit().or(self.best_attempt()) {
            let notes = x.identifiability();
            if !notes.is_empty() {
                let _ = writeln!(md, "Identifiability ({}):\n", x.label());
                for n in notes {
                    let _ = writeln!(md, "- {n}");
                }
                md.push('\n');
            }
        }
        self.errors_md(&mut md);
        self.remainder_md(&mut md);
        if let Some(p) = plot {
            let _ = writeln!(md, "![residual before and after]({p})\n");
        }
        self.models_md(&mut md);
        md
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_at_the_far_end_of_its_range_is_marked() {
        let search = Search {
            reach_s: 3.0,
            row_s: 0.02,
        };
        let at = |e, v| at_limit(&search, e, v);
        let (lo, hi) = search.range(Effect::TimeOffset);
        assert_eq!(hi, 3.0);
        assert!(at(Effect::TimeOffset, hi) && at(Effect::TimeOffset, lo));
        assert!(!at(Effect::TimeOffset, 0.0) && !at(Effect::TimeOffset, 0.5 * hi));
        // The catalogue's 0.5 s is no limit on a trace that holds 3 s.
        assert!(!at(Effect::TimeOffset, 0.5));
        // Zero is where an effect is absent, not a limit.
        assert!(!at(Effect::ContactResistance, 0.0));
        assert!(at(
            Effect::ContactResistance,
            Effect::ContactResistance.info().search.1
        ));
    }
}
