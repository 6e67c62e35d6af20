//! What a named model leaves: the remainder beyond the noise per file,
//! where it lies (in time, stretch, stretch rate and frequency), and what
//! kind of effect could leave it.
//!
//! A model is *named with a remainder* when it takes most of the misfit
//! ([`super::Options::named_share`] of the baseline's RMS² − floor²) but
//! does not bring every file within its noise. The remainder is then
//! the scientist's next lead: its place says which kind of effect is
//! missing (one that grows with the stretch rate is in time, one at a
//! frequency is a dispersion, one at a stretch is in the profile), and
//! the named effect's family says what its shape may differ by.

use super::{Fit, Report, KERNELS};
use crate::dataset::Kind;
use crate::model::{Effect, Prepared};

/// A span of a quantity holding a share of a file's squared remainder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Span {
    /// Start, in the quantity's unit.
    pub from: f64,
    /// End, in the quantity's unit.
    pub to: f64,
    /// Share of the file's Σ(residual²) in it, 0…1.
    pub share: f64,
    /// The share a remainder spread evenly would put in it, 0…1.
    pub even: f64,
}

impl Span {
    /// The remainder gathers here: at least twice the even share.
    pub fn gathers(&self) -> bool {
        self.share >= 2.0 * self.even
    }
}

/// The remainder of one file.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FileRemainder {
    /// File name.
    pub file: String,
    /// Rows in the statistics.
    pub rows: usize,
    /// RMS of the residual under the named model, pF.
    pub rms_pf: f64,
    /// The file's noise floor, pF.
    pub noise_pf: f64,
    /// Mean of the residual (a bias the model leaves), pF.
    pub mean_pf: f64,
    /// This file's share of the remainder beyond the noise over all
    /// files (rows·(RMS² − floor²), 0 where within the noise), 0…1.
    pub share: f64,
    /// The file's excitation frequency (median of its rows), Hz.
    pub frequency_hz: f64,
    /// A sweep's: the fifth of its log-frequency range holding the most
    /// of it, Hz.
    pub frequency_span_hz: Option<Span>,
    /// The tenth of a trace's time holding the most of it, s.
    pub time_s: Option<Span>,
    /// The fifth of the stretch range holding the most of it, mm.
    pub stretch_mm: Option<Span>,
    /// Mean square in the fastest third of a trace's stretch rate over
    /// that in the slowest third (1: rate-blind).
    pub rate_ratio: Option<f64>,
}

impl FileRemainder {
    /// Beyond the noise: RMS above [`super::Options::explained`]× floor.
    pub fn beyond(&self, explained: f64) -> bool {
        self.rms_pf > explained * self.noise_pf
    }
}

/// What the named model leaves, and what could leave it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Remainder {
    /// The share of the baseline's misfit beyond the noise the named
    /// model takes, 0…1.
    pub taken: f64,
    /// Per file.
    pub files: Vec<FileRemainder>,
    /// What kind of effect could leave it, in words.
    pub hints: Vec<String>,
}

/// A rate ratio beyond which the remainder grows with the stretch rate.
const RATE_BOUND: f64 = 2.0;

/// The remainder `named` leaves on `prep`, each file against its floor
/// in `noise_pf`; `report` gives the other candidates for the hints.
pub fn of(prep: &Prepared, named: &Fit, report: &Report, taken: f64) -> Remainder {
    let mut files: Vec<FileRemainder> = prep
        .files
        .iter()
        .zip(&named.residual)
        .zip(&report.noise_pf)
        .map(|((f, r), (_, noise))| file_remainder(f, r, *noise))
        .collect();
    let excess = |x: &FileRemainder| x.rows as f64 * (x.rms_pf * x.rms_pf - x.noise_pf * x.noise_pf).max(0.0);
    let total: f64 = files.iter().map(excess).sum();
    for x in &mut files {
        x.share = if total > 0.0 { excess(x) / total } else { 0.0 };
    }
    let hints = hints(named, report, &files);
    Remainder { taken, files, hints }
}

/// One file's remainder: `r` the residual per row (pF), `noise` its
/// floor.
fn file_remainder(f: &crate::model::File, r: &[f64], noise: f64) -> FileRemainder {
    let rows: Vec<usize> = (0..r.len()).filter(|&i| f.used.get(i) == Some(&true)).collect();
    let n = rows.len().max(1) as f64;
    let ss: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    let mut fs: Vec<f64> = rows.iter().map(|&i| f.f[i]).collect();
    fs.sort_by(f64::total_cmp);
    let trace = f.kind == Kind::Trace && rows.len() >= 10;
    FileRemainder {
        file: f.name.clone(),
        rows: rows.len(),
        rms_pf: (ss / n).sqrt(),
        noise_pf: noise,
        mean_pf: rows.iter().map(|&i| r[i]).sum::<f64>() / n,
        share: 0.0,
        frequency_hz: fs.get(fs.len() / 2).copied().unwrap_or(f64::NAN),
        frequency_span_hz: (f.kind != Kind::Trace && rows.len() >= 5)
            .then(|| densest(&rows, |i| f.f[i].max(f64::MIN_POSITIVE).log10(), r, 5))
            .flatten()
            .map(|s| Span {
                from: 10f64.powf(s.from),
                to: 10f64.powf(s.to),
                ..s
            }),
        time_s: trace.then(|| densest(&rows, |i| f.t[i], r, 10)).flatten(),
        stretch_mm: (rows.len() >= 10)
            .then(|| densest(&rows, |i| f.s[i], r, 5))
            .flatten(),
        rate_ratio: trace.then(|| rate_ratio(f, &rows, r)).flatten(),
    }
}

/// Of `bins` equal spans of `x` over `rows`, the one holding the largest
/// share of Σr² (None: no spread in `x`, or no residual).
fn densest(rows: &[usize], x: impl Fn(usize) -> f64, r: &[f64], bins: usize) -> Option<Span> {
    let (lo, hi) = rows
        .iter()
        .map(|&i| x(i))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let total: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    // No spread (or NaN), or nothing to place.
    let spread = hi > lo;
    if !spread || total.is_nan() || total <= 0.0 {
        return None;
    }
    let width = (hi - lo) / bins as f64;
    let (mut sum, mut count) = (vec![0.0; bins], vec![0usize; bins]);
    for &i in rows {
        let b = (((x(i) - lo) / width) as usize).min(bins - 1);
        sum[b] += r[i] * r[i];
        count[b] += 1;
    }
    let b = (0..bins).max_by(|&a, &b| sum[a].total_cmp(&sum[b]))?;
    Some(Span {
        from: lo + b as f64 * width,
        to: lo + (b + 1) as f64 * width,
        share: sum[b] / total,
        even: count[b] as f64 / rows.len() as f64,
    })
}

/// Mean square of the residual in the fastest third of the stretch rate
/// over the slowest third's (None: no motion, or nothing at rest to
/// compare with).
fn rate_ratio(f: &crate::model::File, rows: &[usize], r: &[f64]) -> Option<f64> {
    let rate = |i: usize| {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(f.t.len() - 1));
        let dt = f.t[b] - f.t[a];
        if dt > 0.0 {
            ((f.s[b] - f.s[a]) / dt).abs()
        } else {
            0.0
        }
    };
    let mut by: Vec<(f64, f64)> = rows.iter().map(|&i| (rate(i), r[i] * r[i])).collect();
    by.sort_by(|a, b| a.0.total_cmp(&b.0));
    let third = by.len() / 3;
    if third == 0 || by[by.len() - 1].0 <= 0.0 {
        return None;
    }
    let ms = |s: &[(f64, f64)]| s.iter().map(|x| x.1).sum::<f64>() / s.len() as f64;
    let (slow, fast) = (ms(&by[..third]), ms(&by[by.len() - third..]));
    (slow > 0.0).then(|| fast / slow)
}

/// The quantities whose profile along the sensor the library shapes.
const STRETCH_SHAPES: [Effect; 3] = [
    Effect::NonuniformStretch,
    Effect::StretchBulge,
    Effect::StretchBump,
];
const RESISTANCE_SHAPES: [Effect; 3] = [
    Effect::ResistanceGradient,
    Effect::ResistanceBulge,
    Effect::ResistanceBump,
];

/// What kind of effect could leave this remainder: by the named
/// effects' family, then by where the remainder lies.
fn hints(named: &Fit, report: &Report, files: &[FileRemainder]) -> Vec<String> {
    let mut out = vec![];
    let has = |set: &[Effect]| named.effects.iter().any(|e| set.contains(e));
    if has(&KERNELS) {
        out.push(format!(
            "the meter's kernel's shape differs from {}: a plain mean, an exponential mean and a cascade of first-order responses weigh the past differently, and the stamp may lie elsewhere in the window",
            named.label()
        ));
    }
    for (set, what) in [(STRETCH_SHAPES, "stretch"), (RESISTANCE_SHAPES, "resistance")] {
        if has(&set) {
            out.push(shape_hint(named, report, &set, what));
        }
    }
    if named.effects.contains(&Effect::TimeOffset) {
        out.push(
            "a delay that varies, or a meter that averages as well as delays (a kernel beside the offset)"
                .to_string(),
        );
    }
    let moving: Vec<&FileRemainder> = files.iter().filter(|x| x.rate_ratio.is_some()).collect();
    let rate_bound = |x: &&&FileRemainder| x.rate_ratio.is_some_and(|q| q >= RATE_BOUND);
    if !moving.is_empty() && moving.iter().filter(rate_bound).count() * 2 > moving.len() && !has(&KERNELS) {
        out.push(format!(
            "it grows with the stretch rate (its mean square {:.1}× larger in the fastest third of the motion than in the slowest, median over the traces): an effect in time the model lacks, the meter's averaging or the film's dynamics",
            median(moving.iter().filter_map(|x| x.rate_ratio))
        ));
    }
    if let Some(h) = frequency_hint(files) {
        out.push(h);
    }
    if out.is_empty() {
        out.push(
            "it follows neither the stretch rate nor the frequency: a static dependence on stretch the named effect's shape lacks"
                .to_string(),
        );
    }
    out
}

/// A profile's shape between the library's: what each shape of the
/// quantity left, alone.
fn shape_hint(named: &Fit, report: &Report, set: &[Effect], what: &str) -> String {
    let others: Vec<String> = report
        .singles
        .iter()
        .filter(|f| {
            f.effects.len() == 1 && set.contains(&f.effects[0]) && !named.effects.contains(&f.effects[0])
        })
        .map(|f| format!("{} left {:.3} pF", f.label(), f.rms_pf))
        .collect();
    let mut s = format!(
        "the {what} profile's shape lies between the library's shapes of it (a gradient, a symmetric bulge, a localized bump): {} left {:.3} pF",
        named.label(),
        named.rms_pf
    );
    if !others.is_empty() {
        s.push_str(&format!(", {}", others.join(", ")));
    }
    s
}

/// The remainder sits at some of the traces' frequencies and not at
/// others, or in part of a sweep's range.
fn frequency_hint(files: &[FileRemainder]) -> Option<String> {
    let mut by: Vec<(f64, f64)> = vec![];
    let sweep = files
        .iter()
        .find_map(|x| x.frequency_span_hz.filter(Span::gathers));
    for x in files
        .iter()
        .filter(|x| x.frequency_hz.is_finite() && x.frequency_span_hz.is_none())
    {
        match by.iter_mut().find(|b| (b.0 / x.frequency_hz - 1.0).abs() < 0.01) {
            Some(b) => b.1 += x.share,
            None => by.push((x.frequency_hz, x.share)),
        }
    }
    let total: f64 = by.iter().map(|b| b.1).sum();
    let top = by
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|t| by.len() >= 2 && total > 0.0 && t.1 / total >= (2.0 / by.len() as f64).max(0.5));
    let mut parts = vec![];
    if let Some(t) = top {
        parts.push(format!(
            "{:.0} % of the traces' remainder is at {} of the {} frequencies they were read at",
            100.0 * t.1 / total,
            hz(t.0),
            by.len()
        ));
    }
    if let Some(s) = sweep {
        parts.push(format!(
            "the sweep's gathers at {}–{} ({:.0} % of it, even {:.0} %)",
            hz(s.from),
            hz(s.to),
            100.0 * s.share,
            100.0 * s.even
        ));
    }
    (!parts.is_empty()).then(|| {
        format!(
            "{}: a dependence on frequency the model lacks (a dispersion or a relaxation of the film, a contact that is not a pure resistance)",
            parts.join("; ")
        )
    })
}

fn hz(f: f64) -> String {
    if f >= 1e3 {
        format!("{:.3} kHz", f / 1e3)
    } else {
        format!("{f:.0} Hz")
    }
}

fn median(it: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = it.collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The span holding a burst of residual is found with its share; an
    /// even residual gathers nowhere.
    #[test]
    fn the_densest_span_holds_the_burst() {
        let rows: Vec<usize> = (0..100).collect();
        let mut r = vec![0.1; 100];
        for v in &mut r[30..40] {
            *v = 1.0;
        }
        let s = densest(&rows, |i| i as f64, &r, 10).unwrap();
        assert!(s.from <= 30.0 && s.to >= 38.0, "{s:?}");
        let want = 10.0 / (10.0 + 90.0 * 0.01);
        assert!((s.share - want).abs() < 0.1, "{s:?}");
        assert!(s.gathers());
        let even = densest(&rows, |i| i as f64, &[0.5; 100], 10).unwrap();
        assert!(!even.gathers(), "{even:?}");
        assert!(densest(&rows, |_| 1.0, &r, 10).is_none());
    }
}
