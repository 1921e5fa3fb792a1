//! Running a baselines study (whole missions per case × arm × level) as a link study runs:
//! resumably, in shards, merged. Every mission is recorded as it ends
//! (`<point>/trials/NNNNNN.json`, [`crate::harness::runs::records`]); a rerun flies only what is
//! missing; `trials.json` of every point, `study.json`, `report.md` and the figures are always
//! made from the records, in one process as in `waggle study merge`, so the merge of shards is
//! the single run byte for byte.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use anyhow::{Context, Result, bail};
use proto::RenderPath;

use crate::harness::mission::trials::{
    MissionTrial, MissionTrialsOptions, mission_trials_out, run_mission_trials_on,
};
use crate::harness::runs::files::{RunCost, RunKind, RunManifest, cpu_s};
use crate::harness::runs::merge_records::{Makers, MergeOptions, check_makers, gather_records};
use crate::harness::runs::records::{recorded, write_json, write_record};
use crate::harness::runs::shard::{Shard, part_of};
use crate::harness::study::baselines::{ArmResult, BaselineStudy, arm_result, write_report};
use crate::harness::study::run::RunCounts;
use run_format::case::Case;

/// One case × arm at one level of the study's varied term.
pub struct BaselinePoint {
    /// Its directory: `<case>-<arm>` or `<case>-<arm>-<key>-<level>`.
    pub dir: String,
    pub arm: crate::harness::study::baselines::Arm,
    pub level: Option<f64>,
    pub opts: MissionTrialsOptions,
}

/// The study's points, level by level, case by case, arm by arm (the order of its trials).
///
/// # Errors
///
/// A study that does not check, a case that does not load.
pub fn points(
    study: &BaselineStudy,
    render: RenderPath,
    jobs: usize,
) -> Result<Vec<BaselinePoint>> {
    let perturbation = study.check()?;
    let levels: Vec<Option<f64>> = match study.vary.first() {
        Some(v) => v.levels.iter().map(|&l| Some(l)).collect(),
        None => vec![None],
    };
    let mut out = Vec::new();
    for level in levels {
        for case_name in &study.cases {
            let case = Case::load(case_name)?;
            for &arm in &study.arms {
                let (modality, policy) = arm.receiver_and_policy();
                let mut p = perturbation.clone();
                if let (Some(v), Some(l)) = (study.vary.first(), level) {
                    p.set(&v.key, l).context("vary")?;
                }
                let dir = match (study.vary.first(), level) {
                    (Some(v), Some(l)) => format!("{}-{}-{}-{l}", case.name, arm.label(), v.key),
                    _ => format!("{}-{}", case.name, arm.label()),
                };
                out.push(BaselinePoint {
                    dir,
                    arm,
                    level,
                    opts: MissionTrialsOptions {
                        case: case.clone(),
                        modality,
                        policy,
                        trials: study.trials,
                        seed: study.seed,
                        perturbation: p,
                        jobs,
                        render,
                    },
                });
            }
        }
    }
    Ok(out)
}

/// `run.json` of a baselines run (the study as TOML).
pub fn manifest(study: &BaselineStudy, shard: Option<Shard>) -> Result<RunManifest> {
    Ok(RunManifest {
        kind: RunKind::Baselines,
        definition: toml::to_string(study).context("writing the study as TOML")?,
        requested: study.trials,
        shard: shard.map(|s| s.to_string()),
    })
}

/// Flies the study's missions (all, or shard `shard`'s block) that `out` does not hold yet,
/// recording each as it ends. `progress(done, part)` counts this part's missions, recorded ones
/// included.
pub fn run_part(
    study: &BaselineStudy,
    out: &Path,
    (render, jobs, shard): (RenderPath, usize, Option<Shard>),
    stop: &Arc<AtomicBool>,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<RunCounts> {
    let (started, cpu_before) = (std::time::Instant::now(), cpu_s());
    let points = points(study, render, jobs)?;
    manifest(study, shard)?.claim(out)?;
    let (parts, part) = part_of(points.len(), study.trials, shard);
    let mut counts = RunCounts {
        part,
        ..RunCounts::default()
    };
    let mut work = Vec::new();
    for (p, indices) in parts {
        let point = &points[p];
        let dir = out.join(&point.dir);
        let (found, damaged) =
            recorded::<MissionTrial>(&dir, &point.dir, study.trials, point.opts.render)?;
        counts.damaged += damaged;
        let missing: Vec<u64> = indices
            .into_iter()
            .filter(|i| !found.records.contains_key(i))
            .collect();
        work.push((p, missing));
    }
    counts.recorded = counts.part - work.iter().map(|(_, m)| m.len() as u64).sum::<u64>();
    let done = AtomicU64::new(counts.recorded);
    progress(counts.recorded, counts.part);
    for (p, missing) in work {
        if stop.load(Ordering::SeqCst) || missing.is_empty() {
            continue;
        }
        let point = &points[p];
        let dir = out.join(&point.dir);
        let flown = run_mission_trials_on(
            &point.opts,
            &missing,
            stop,
            |t| write_record(&dir, &point.dir, point.opts.render, t),
            |_, _| progress(done.fetch_add(1, Ordering::SeqCst) + 1, counts.part),
        )
        .with_context(|| format!("point {}", point.dir))?;
        counts.ran += flown.len() as u64;
    }
    // What this run cost, summed into the study's cost.json (by the merge, over shards and
    // resumed runs too).
    RunCost {
        runs: 1,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: cpu_s() - cpu_before,
        trials_run: counts.ran,
        ..RunCost::default()
    }
    .add_to(out)?;
    Ok(counts)
}

/// Writes every point's `trials.json`, `study.json`, `report.md`, the figures and
/// `provenance.json` into `out` from the records in `sources` (one directory, or the shards of
/// one run); returns the results.
pub fn write_results(
    study: &BaselineStudy,
    sources: &[PathBuf],
    out: &Path,
    options: MergeOptions,
) -> Result<Vec<ArmResult>> {
    let points = points(study, RenderPath::default(), 1)?;
    let mut makers = Makers::default();
    let mut results = Vec::new();
    for point in &points {
        let records: Vec<MissionTrial> =
            gather_records(sources, &point.dir, study.trials, &mut makers)?;
        if !options.partial && records.len() as u64 != study.trials {
            bail!(
                "point {}: {} of {} missions recorded",
                point.dir,
                records.len(),
                study.trials
            );
        }
        if records.is_empty() {
            continue; // an interrupted run that never reached this point
        }
        let trials = mission_trials_out(&point.opts, records);
        write_json(&out.join(&point.dir).join("trials.json"), &trials)?;
        results.push(arm_result(
            &point.opts.case.name,
            point.arm,
            point.level,
            &trials,
        ));
    }
    check_makers(&makers, options)?;
    write_report(study, &results, out)?;
    write_json(&out.join("provenance.json"), &makers)?;
    Ok(results)
}
