//! The survey's tally, shared by the generators' surveys
//! (`second_generator.rs`, `third_generator.rs`): a row per set as it
//! comes, then per family how many sets were detectable and named right,
//! and the summary against the goals of identify's survey.

use host_sim::identify::{Report, Verdict};

/// What a set held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hidden {
    /// Nothing beyond the uniform line.
    Clean,
    /// An effect outside the library.
    Outside,
    /// An effect the library covers.
    InLibrary,
}

/// One family's sets.
#[derive(Default)]
struct Family {
    name: String,
    sets: usize,
    detectable: usize,
    right: usize,
    /// After over the noise seen through the final model, per
    /// detectable set.
    after: Vec<f64>,
    /// Error drop (baseline RMS over final RMS), per detectable set.
    drop: Vec<f64>,
}

/// The survey's counts for one generator.
pub struct Tally {
    generator: &'static str,
    families: Vec<Family>,
    pub clean: usize,
    pub clean_ok: usize,
    pub outside: usize,
    /// Outside sets not called explained.
    pub outside_ok: usize,
    /// Outside sets named with a remainder.
    pub outside_named: usize,
    /// In-library sets named right with a remainder.
    pub with_remainder: usize,
    /// Sets where an effect was named that is not the one generated.
    pub wrong: usize,
    /// Of those, where the right one is listed as competing.
    pub wrong_but_listed: usize,
    pub sets: usize,
}

/// The ids of the effects a report names (explained or with a
/// remainder).
pub fn named(r: &Report) -> Vec<&'static str> {
    r.named_fit()
        .into_iter()
        .flat_map(|a| a.effects.iter().map(|e| e.id()))
        .collect()
}

impl Tally {
    pub fn new(generator: &'static str) -> Self {
        println!("| seed | family | value (SI) | baseline/noise | named | after/noise | drop | s |");
        println!("|---|---|---:|---:|---|---:|---:|---:|");
        Self {
            generator,
            families: vec![],
            clean: 0,
            clean_ok: 0,
            outside: 0,
            outside_ok: 0,
            outside_named: 0,
            with_remainder: 0,
            wrong: 0,
            wrong_but_listed: 0,
            sets: 0,
        }
    }

    /// Count set `seed` of `family` (`value` its strength, SI), whose
    /// report is `r`; `right(ids)` says whether a list of named ids is
    /// right for it; `secs` the time it took.
    pub fn add(
        &mut self,
        seed: u64,
        (family, hidden, value): (&str, Hidden, f64),
        r: &Report,
        right: &dyn Fn(&[&str]) -> bool,
        secs: f64,
    ) {
        let (nf, fnf) = (r.noise_floor_pf, r.final_noise_pf());
        let (base, fin) = (r.baseline().rms_pf, r.final_fit().rms_pf);
        println!(
            "| {seed} | {family} | {value:.4e} | {:.1} | {} | {:.2} | {:.1} | {secs:.0} |",
            base / nf,
            r.outcome(),
            fin / fnf,
            base / fin,
        );
        self.sets += 1;
        let ids = named(r);
        match hidden {
            Hidden::Clean => {
                self.clean += 1;
                self.clean_ok += usize::from(r.kind() == Verdict::Clean);
                self.wrong += usize::from(r.named_fit().is_some());
            }
            Hidden::Outside => {
                self.outside += 1;
                self.outside_ok += usize::from(r.kind() != Verdict::Explained);
                self.outside_named += usize::from(r.kind() == Verdict::Named);
            }
            Hidden::InLibrary => self.in_library(family, r, &ids, right, (base, fin, nf, fnf)),
        }
    }

    fn in_library(
        &mut self,
        family: &str,
        r: &Report,
        ids: &[&str],
        right: &dyn Fn(&[&str]) -> bool,
        (base, fin, nf, fnf): (f64, f64, f64, f64),
    ) {
        let k = match self.families.iter().position(|b| b.name == family) {
            Some(k) => k,
            None => {
                self.families.push(Family {
                    name: family.to_string(),
                    ..Default::default()
                });
                self.families.len() - 1
            }
        };
        let is_right = right(ids);
        let named = r.named_fit().is_some();
        self.wrong += usize::from(named && !is_right);
        self.with_remainder += usize::from(is_right && r.kind() == Verdict::Named);
        self.wrong_but_listed += usize::from(
            named
                && !is_right
                && r.competing.iter().any(|c| {
                    let ids: Vec<&str> = c.fit.effects.iter().map(|e| e.id()).collect();
                    right(&ids)
                }),
        );
        let f = &mut self.families[k];
        f.sets += 1;
        if base > 1.5 * nf {
            f.detectable += 1;
            f.right += usize::from(is_right);
            f.after.push(fin / fnf);
            f.drop.push(base / fin);
        }
    }

    /// Detectable in-library sets and of those named right.
    pub fn in_library_named(&self) -> (usize, usize) {
        let det = self.families.iter().map(|f| f.detectable).sum();
        let right = self.families.iter().map(|f| f.right).sum();
        (det, right)
    }

    /// Print the per-family table and the summary.
    pub fn print(&self) {
        let median = |v: &[f64]| {
            let mut v = v.to_vec();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        println!("\n{}:\n", self.generator);
        println!("| family | sets | detectable | named right | after/noise (max) | drop (median) |");
        println!("|---|---:|---:|---:|---:|---:|");
        let mut drops = vec![];
        for f in &self.families {
            drops.extend(f.drop.iter().copied());
            let mx = f.after.iter().copied().fold(f64::NAN, f64::max);
            println!(
                "| {} | {} | {} | {} | {mx:.2} | {:.1} |",
                f.name,
                f.sets,
                f.detectable,
                f.right,
                median(&f.drop)
            );
        }
        let (det, right) = self.in_library_named();
        println!(
            "\n{}: in library {right}/{det} detectable named right ({} of them with a remainder), median drop {:.1}x; outside: {}/{} not called explained ({} named with a remainder); clean: {}/{} clean; a wrong effect named in {} of {} sets ({} with the right one listed as competing: the data cannot tell them apart)",
            self.generator,
            self.with_remainder,
            median(&drops),
            self.outside_ok,
            self.outside,
            self.outside_named,
            self.clean_ok,
            self.clean,
            self.wrong,
            self.sets,
            self.wrong_but_listed,
        );
    }
}
