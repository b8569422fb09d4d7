//! The database's estimate on members nobody tuned it to (`haptex db
//! validate --random N --seed S`): FE runs at random members of each
//! template's family, with the database's own FE settings, against the
//! estimate `haptex predict` gives for them.
//!
//! A member's parameters are drawn uniformly over the database's input
//! ranges (r_w, r_h, velocity) by haptex's own SplitMix64
//! ([`haptex_core::recording::rng`], fixed in every version), seeded with
//! the seed and the template, so the members of one template do not depend on
//! which other templates are validated, and a seed gives the same members
//! on every machine. Values are rounded to 1e-4 mm and 0.01 mm/s, so a
//! member can be run again from the printed table (`haptex db loo
//! --surface S --width W --height H --velocity V`).
//!
//! The error of a member is the RMS difference between estimate and FE
//! profile over the database's grid of xi, and that RMS relative to the FE
//! profile's range (max - min): the figure a user compares with what the
//! profile is meant to show.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use haptex_core::database::{Estimator, Metadata, Template, TemplateModel, Validation, ValidationEntry};
use haptex_core::io::write_atomic;
use haptex_core::recording::rng::SplitMix64;
use rayon::prelude::*;

use crate::sweep::{DatabaseSpec, Run, SweepError};

/// `n` random members of `template`'s family over `ranges` ((min, max) of
/// r_w, r_h and velocity), from `seed`.
pub fn random_members(template: Template, ranges: [(f64, f64); 3], n: usize, seed: u64) -> Vec<Run> {
    let stream = match template {
        Template::Bump => 1u64,
        Template::Edge => 2,
        Template::Sine => 3,
    };
    let mut rng = SplitMix64::new(seed ^ stream.wrapping_mul(0xd1b5_4a32_d192_ed03));
    let mut draw = |(lo, hi): (f64, f64), step: f64| (rng.range(lo, hi) / step).round() * step;
    (0..n)
        .map(|_| {
            let width_mm = draw(ranges[0], 1e-4);
            let height_mm = draw(ranges[1], 1e-4);
            let velocity_mm_s = draw(ranges[2], 1e-2);
            Run { template, width_mm, height_mm, velocity_mm_s }
        })
        .collect()
}

/// One member: its FE profile against the estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    pub run: Run,
    /// RMS of estimate - FE over the grid (Ft/Fn).
    pub rms: f64,
    /// max - min of the FE profile over the grid.
    pub range: f64,
    /// rms / range.
    pub relative: f64,
}

impl Member {
    /// Whether the crests of this member's surface are resolved by `mesh`
    /// ([`haptex_core::crests`]): for a sine, true or false; `None` for
    /// the other templates, to which the rule does not apply.
    pub fn crests_resolved(&self, mesh: &str) -> Option<bool> {
        self.run.template.crests_resolved(mesh, self.run.width_mm, self.run.height_mm)
    }
}

/// The members of one template, summarized.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The template and its errors' medians and maxima, as `--record`
    /// stores them (with the resolved members' figures, `resolved` below).
    pub errors: ValidationEntry,
    pub members: usize,
    /// The member with the largest relative error.
    pub worst: Run,
    /// The same over the members whose crests the mesh resolves
    /// ([`haptex_core::crests`]), where that leaves some out and keeps some
    /// (a sine's sharpest members): against the others the FE reference
    /// itself is not mesh-converged. Its own `resolved` is `None`.
    pub resolved: Option<Box<Summary>>,
}

/// The error of `estimate` against `fe` (same grid).
pub fn member_error(run: Run, fe: &[f64], estimate: &[f64]) -> Member {
    let n = fe.len().max(1) as f64;
    let rms = (fe.iter().zip(estimate).map(|(f, e)| (e - f) * (e - f)).sum::<f64>() / n).sqrt();
    let (lo, hi) = fe.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let range = hi - lo;
    Member { run, rms, range, relative: if range > 0.0 { rms / range } else { f64::INFINITY } }
}

/// Validates `estimator` over the database in `dir` on `n` random members
/// of each of `templates` from `seed`, `jobs` FE runs at a time, calling
/// `progress(done, total)` after each run. Members in template order, each
/// template's in the order drawn.
#[allow(clippy::too_many_arguments)]
pub fn validate(
    dir: &Path,
    metadata: &Metadata,
    templates: &[Template],
    estimator: Estimator,
    n: usize,
    seed: u64,
    jobs: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Member>, SweepError> {
    let spec = DatabaseSpec::from_metadata(metadata)?;
    let models = templates
        .iter()
        .map(|&t| TemplateModel::load_with(dir, metadata, t))
        .collect::<Result<Vec<_>, _>>()
        .map_err(SweepError::from)?;
    let runs: Vec<(usize, Run)> = models
        .iter()
        .enumerate()
        .flat_map(|(i, m)| random_members(m.template, m.input_ranges(), n, seed).into_iter().map(move |r| (i, r)))
        .collect();
    for (_, run) in &runs {
        spec.scenario(run).validate().map_err(|error| SweepError::Run { run: run.describe(), error })?;
    }
    let done = AtomicUsize::new(0);
    progress(0, runs.len());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.max(1))
        .build()
        .map_err(|e| SweepError::Invalid(format!("cannot start {jobs} threads: {e}")))?;
    pool.install(|| {
        runs.par_iter()
            .map(|&(i, run)| -> Result<Member, SweepError> {
                let fe = spec.simulate(&run)?;
                let estimate = models[i]
                    .predict_with(estimator, 0.0, run.width_mm, run.height_mm, run.velocity_mm_s)
                    .map_err(SweepError::from)?;
                progress(done.fetch_add(1, Ordering::SeqCst) + 1, runs.len());
                Ok(member_error(run, &fe, &estimate.mu))
            })
            .collect()
    })
}

/// Median and maximum per template, in the members' template order, and
/// the same over the members whose crests `mesh` (the database's) resolves
/// where that differs ([`Summary::resolved`], also put into
/// `errors.resolved`, where `--record` stores it).
pub fn summarize(members: &[Member], mesh: &str) -> Vec<Summary> {
    let mut templates: Vec<Template> = Vec::new();
    for m in members {
        if !templates.contains(&m.run.template) {
            templates.push(m.run.template);
        }
    }
    templates
        .into_iter()
        .map(|template| {
            let of: Vec<&Member> = members.iter().filter(|m| m.run.template == template).collect();
            let mut summary = summary_of(template, &of);
            let resolved: Vec<&Member> =
                of.iter().copied().filter(|m| m.crests_resolved(mesh) != Some(false)).collect();
            if !resolved.is_empty() && resolved.len() < of.len() {
                let subset = summary_of(template, &resolved);
                summary.errors.resolved = Some(subset.errors.figures_over(subset.members));
                summary.resolved = Some(Box::new(subset));
            }
            summary
        })
        .collect()
}

/// Median and maximum of `of`, members of `template` (at least one).
fn summary_of(template: Template, of: &[&Member]) -> Summary {
    let rms: Vec<f64> = of.iter().map(|m| m.rms).collect();
    let relative: Vec<f64> = of.iter().map(|m| m.relative).collect();
    let worst = of.iter().max_by(|a, b| a.relative.total_cmp(&b.relative)).expect("one member at least").run;
    Summary {
        errors: ValidationEntry {
            template,
            rms_median: median(&rms),
            rms_max: rms.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            relative_median: median(&relative),
            relative_max: relative.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            resolved: None,
        },
        members: of.len(),
        worst,
        resolved: None,
    }
}

/// Records `summary` (of `estimator`, `members` members per template from
/// `seed`) in the database's `metadata.json`, replacing an earlier
/// validation, and makes `estimator` the database's; the file is rewritten
/// atomically. `metadata` must be the directory's own.
pub fn record(
    dir: &Path,
    metadata: &Metadata,
    estimator: Estimator,
    seed: u64,
    members: usize,
    summary: &[Summary],
) -> Result<Metadata, SweepError> {
    let mut metadata = metadata.clone();
    metadata.estimator = Some(estimator);
    metadata.validation = Some(Validation {
        created: haptex_core::database::utc_now_rfc3339(),
        seed,
        members,
        estimator,
        templates: summary.iter().map(|s| s.errors.clone()).collect(),
    });
    let json = serde_json::to_string_pretty(&metadata).expect("metadata serializes");
    write_atomic(&dir.join("metadata.json"), |w| writeln!(w, "{json}"))?;
    Ok(metadata)
}

/// The median (the mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Members lie in the ranges, on their rounding steps, the same for a
    /// seed, other for another seed, and a template's do not depend on the others.
    #[test]
    fn members_are_reproducible_and_in_range() {
        let ranges = [(0.5, 2.5), (0.1, 0.5), (10.0, 100.0)];
        let a = random_members(Template::Sine, ranges, 50, 7);
        assert_eq!(a, random_members(Template::Sine, ranges, 50, 7));
        assert_ne!(a, random_members(Template::Sine, ranges, 50, 8));
        assert_ne!(a[0].width_mm, random_members(Template::Bump, ranges, 1, 7)[0].width_mm);
        for r in &a {
            assert!((0.5..=2.5).contains(&r.width_mm) && (0.1..=0.5).contains(&r.height_mm), "{r:?}");
            assert!((10.0..=100.0).contains(&r.velocity_mm_s), "{r:?}");
            assert!((r.width_mm * 1e4 - (r.width_mm * 1e4).round()).abs() < 1e-6, "{r:?}");
        }
    }

    #[test]
    fn errors_and_medians() {
        let run = Run { template: Template::Bump, width_mm: 1.0, height_mm: 0.2, velocity_mm_s: 20.0 };
        let m = member_error(run, &[0.5, 0.7, 0.5, 0.3], &[0.5, 0.6, 0.5, 0.3]);
        assert!((m.rms - 0.05).abs() < 1e-15 && (m.range - 0.4).abs() < 1e-15);
        assert!((m.relative - 0.125).abs() < 1e-12);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    /// The members the fine mesh resolves (crest radius at least 0.25 mm)
    /// are summarized apart, for the sine only, and only when that leaves
    /// some out.
    #[test]
    fn resolved_members_are_summarized_apart() {
        let member = |template, width_mm, height_mm, relative| Member {
            run: Run { template, width_mm, height_mm, velocity_mm_s: 20.0 },
            rms: relative,
            range: 1.0,
            relative,
        };
        let members = [
            member(Template::Bump, 0.6, 0.5, 0.02),
            member(Template::Sine, 0.7, 0.48, 0.6),   // R = 0.026 mm: not resolved
            member(Template::Sine, 2.3, 0.15, 0.05),  // R = 0.89 mm
            member(Template::Sine, 1.57, 0.21, 0.09), // R = 0.297 mm
        ];
        assert_eq!(members[1].crests_resolved("fine"), Some(false));
        assert_eq!(members[3].crests_resolved("fine"), Some(true));
        assert_eq!(members[3].crests_resolved("default"), Some(false));
        assert_eq!(members[0].crests_resolved("fine"), None);
        let summary = summarize(&members, "fine");
        let [bump, all] = &summary[..] else { panic!("{summary:?}") };
        assert!(bump.resolved.is_none() && bump.errors.resolved.is_none(), "{bump:?}");
        let sine = all.resolved.as_deref().expect("the sine's resolved members apart");
        assert_eq!((sine.errors.template, sine.members, all.members), (Template::Sine, 2, 3));
        assert_eq!((sine.errors.relative_median, sine.errors.relative_max), (0.07, 0.09));
        assert_eq!((sine.worst.width_mm, all.worst.width_mm), (1.57, 0.7));
        // What --record stores: the subset's figures in the sine's entry.
        let stored = all.errors.resolved.expect("recorded");
        assert_eq!((stored.members, stored.relative_median, stored.relative_max), (2, 0.07, 0.09));
        // The coarse mesh resolves none (nothing to summarize apart), the
        // default one the bluntest, the extra-fine one all but the first.
        let resolved = |mesh| summarize(&members, mesh)[1].resolved.as_ref().map(|r| r.members);
        assert_eq!((resolved("coarse"), resolved("default"), resolved("extra-fine")), (None, Some(1), Some(2)));
    }
}
