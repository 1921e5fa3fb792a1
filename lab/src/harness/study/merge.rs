//! The results of a study or trials run, made from per-trial records: of one directory (a run in
//! one process, finished or interrupted) or of several (`waggle study merge`: the shards of one
//! run). Every file is a function of the records and the definition alone — records sorted by
//! index, no wall-clock value — so merging shards gives the bytes a single process gives.
//! Costs are summed from each directory's `run-cost.json` into `cost.json` and `cost.md`.
//!
//! Refused: directories of different runs, a trial recorded differently twice, a damaged record,
//! records of different binaries; unless asked to accept them, records of different CPU models
//! or renderers and missing trials (named, with the shard that should hold them).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use proto::RenderPath;

use crate::harness::flight::air::PointTracking;
use crate::harness::runs::files::{RunCost, RunKind, RunManifest};
pub use crate::harness::runs::merge_records::MergeOptions;
use crate::harness::runs::merge_records::{Makers, check_makers, gather_records};
use crate::harness::runs::records::{write_atomic, write_json};
use crate::harness::runs::shard::Shard;
use crate::harness::study::report::{cost_md, figure, marginals, report};
use crate::harness::study::run::header;
use crate::harness::study::{Point, PointResult, StudyFile, StudyPlan, figure_name};
use crate::harness::trials::{ObserverTrial, TrialRecord, TrialsHeader, TrialsOut};

/// What a merge made.
#[derive(Debug)]
pub enum Merged {
    Study(Vec<PointResult>),
    Baselines(Vec<crate::harness::study::baselines::ArmResult>),
    Missions(Box<crate::harness::mission::trials::MissionTrialsOut>),
    Trials(Box<TrialsOut>),
}

/// The directories' common manifest, checked: one run, each shard once.
fn common_manifest(sources: &[PathBuf]) -> Result<RunManifest> {
    let mut first: Option<(RunManifest, &Path)> = None;
    let mut shards = BTreeMap::new();
    for dir in sources {
        let m = RunManifest::read(dir)
            .with_context(|| format!("{} is not a study or trials directory", dir.display()))?;
        if let Some(s) = &m.shard
            && let Some(other) = shards.insert(s.clone(), dir)
        {
            bail!(
                "{} and {} both hold shard {s}",
                other.display(),
                dir.display()
            );
        }
        match &first {
            None => first = Some((m, dir)),
            Some((f, fdir)) => {
                let same_run = f.kind == m.kind
                    && f.definition == m.definition
                    && f.requested == m.requested
                    && f.shard.is_some() == m.shard.is_some();
                if !same_run {
                    bail!(
                        "{} and {} are not parts of the same run (their run.json differ)",
                        fdir.display(),
                        dir.display()
                    );
                }
            }
        }
    }
    let (m, _) = first.context("nothing to merge: give at least one directory")?;
    Ok(m)
}

/// The shards of `n` that no source holds, as `K/N` (for a readable refusal).
fn missing_shards(sources: &[PathBuf]) -> String {
    let held: Vec<Shard> = sources
        .iter()
        .filter_map(|d| RunManifest::read(d).ok()?.shard?.parse().ok())
        .collect();
    let Some(n) = held.first().map(|s| s.n) else {
        return String::new();
    };
    let missing: Vec<String> = (1..=n)
        .filter(|k| !held.iter().any(|s| s.k == *k))
        .map(|k| format!("{k}/{n}"))
        .collect();
    if missing.is_empty() {
        String::new()
    } else {
        format!("; no directory given holds shard {}", missing.join(", "))
    }
}

/// One point's header and records over every source.
fn gather(
    sources: &[PathBuf],
    rel: &str,
    requested: u64,
    makers: &mut Makers,
) -> Result<(Option<TrialsHeader>, Vec<TrialRecord>)> {
    let mut head: Option<TrialsHeader> = None;
    for src in sources {
        let dir = src.join(rel);
        if let Some(h) = header(&dir) {
            if head.as_ref().is_some_and(|g| *g != h) {
                bail!(
                    "{}: this point's header differs between the directories",
                    dir.display()
                );
            }
            head = Some(h);
        }
    }
    Ok((head, gather_records(sources, rel, requested, makers)?))
}

/// The run's costs: every source's `run-cost.json`, summed.
fn costs(sources: &[PathBuf]) -> Result<RunCost> {
    let mut total = RunCost::default();
    for src in sources {
        total.add(&RunCost::read(src)?);
    }
    Ok(total)
}

/// Writes the results of the run(s) in `sources` into `out` (which may be one of them).
pub fn merge(sources: &[PathBuf], out: &Path, options: MergeOptions) -> Result<Merged> {
    let manifest = common_manifest(sources)?;
    if !sources.iter().any(|s| s == out)
        && out
            .join(crate::harness::runs::records::MANIFEST_FILE)
            .exists()
    {
        bail!(
            "{} is a run directory that is not among those merged: choose another --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut makers = Makers::default();
    let cost = costs(sources)?;
    let incomplete = |what: &str, have: usize| -> Result<()> {
        if !options.partial && have as u64 != manifest.requested {
            bail!(
                "{what}: {have} of {} trials recorded{}",
                manifest.requested,
                missing_shards(sources)
            );
        }
        Ok(())
    };
    match manifest.kind {
        RunKind::Baselines => {
            let study: crate::harness::study::baselines::BaselineStudy =
                toml::from_str(&manifest.definition)
                    .context("run.json: the study's definition does not parse")?;
            let results =
                crate::harness::study::baselines_run::write_results(&study, sources, out, options)
                    .map_err(|e| anyhow::anyhow!("{e:#}{}", missing_shards(sources)))?;
            write_json(&out.join("cost.json"), &cost)?;
            Ok(Merged::Baselines(results))
        }
        RunKind::Missions => {
            use crate::harness::mission::trials::{
                MissionTrial, MissionsDefinition, mission_trials_out,
            };
            let opts = MissionsDefinition::options(&manifest.definition, manifest.requested)?;
            let records: Vec<MissionTrial> =
                gather_records(sources, ".", manifest.requested, &mut makers)?;
            incomplete("the missions", records.len())?;
            check_makers(&makers, options)?;
            let trials = mission_trials_out(&opts, records);
            write_json(&out.join("trials.json"), &trials)?;
            write_json(&out.join("cost.json"), &cost)?;
            write_json(&out.join("provenance.json"), &makers)?;
            Ok(Merged::Missions(Box::new(trials)))
        }
        RunKind::Trials => {
            let (head, records) = gather(sources, ".", manifest.requested, &mut makers)?;
            incomplete("the trials", records.len())?;
            check_makers(&makers, options)?;
            let head = head.context("no directory holds the trials' header (point.json)")?;
            let trials = TrialsOut::assemble(head, manifest.requested, records);
            write_json(&out.join("trials.json"), &trials)?;
            let point = cost.points.get(".").copied().unwrap_or_default();
            write_json(&out.join("cost.json"), &point)?;
            write_json(&out.join("provenance.json"), &makers)?;
            Ok(Merged::Trials(Box::new(trials)))
        }
        RunKind::Study => {
            let study: StudyFile = toml::from_str(&manifest.definition)
                .context("run.json: the study's definition does not parse")?;
            let points = study.points(RenderPath::default(), 1)?;
            let mut results = Vec::new();
            for point in &points {
                let (head, records) = gather(sources, &point.dir, manifest.requested, &mut makers)?;
                incomplete(&format!("point {}", point.dir), records.len())?;
                let Some(head) = head else {
                    continue; // an interrupted run that never reached this point
                };
                let trials = TrialsOut::assemble(head, manifest.requested, records);
                let dir = out.join(&point.dir);
                write_json(&dir.join("trials.json"), &trials)?;
                let point_cost = cost.points.get(&point.dir).copied().unwrap_or_default();
                write_json(&dir.join("cost.json"), &point_cost)?;
                results.push(point_result(point, &trials));
            }
            check_makers(&makers, options)?;
            write_study(&study, &results, out, &cost)?;
            write_json(&out.join("provenance.json"), &makers)?;
            Ok(Merged::Study(results))
        }
    }
}

/// `study.json`, one figure per condition, `report.md`, `cost.json` and `cost.md`.
fn write_study(
    study: &StudyFile,
    results: &[PointResult],
    out: &Path,
    cost: &RunCost,
) -> Result<()> {
    write_json(&out.join("study.json"), &results)?;
    let pooled = marginals(study, results);
    for vary in &study.vary {
        write_atomic(
            &out.join(figure_name(&vary.key)),
            figure(study, vary, &pooled)?.as_bytes(),
        )?;
    }
    write_atomic(&out.join("report.md"), report(study, results).as_bytes())?;
    write_json(&out.join("cost.json"), cost)?;
    write_atomic(
        &out.join("cost.md"),
        cost_md(study, results, cost).as_bytes(),
    )
}

fn point_result(point: &Point, t: &TrialsOut) -> PointResult {
    PointResult {
        key: point.key.clone(),
        modality: point.series.clone(),
        level: point.level,
        factors: point.factors.clone(),
        trials: t.tally.trials,
        successes: t.tally.successes,
        success_rate: t.tally.success_rate,
        ci95: t.tally.ci95,
        dir: point.dir.clone(),
        decoded_messages: observer_sum(t, |o| o.released.len() as u64),
        sensor_messages: observer_sum(t, |o| o.messages),
        events: observer_sum(t, |o| o.events_received.unwrap_or(0)),
        tracking: PointTracking::pooled(t.per_trial.iter().filter_map(|r| {
            r.flight.map(|f| {
                (
                    1,
                    PointTracking {
                        mean_rms_m: f.performer_tracking.rms_m,
                        max_m: f.performer_tracking.max_m,
                        contact_trials: u64::from(f.contact_steps > 0),
                    },
                )
            })
        })),
    }
}

fn observer_sum(t: &TrialsOut, f: impl Fn(&ObserverTrial) -> u64) -> u64 {
    t.per_trial
        .iter()
        .flat_map(|r| r.observers.values())
        .map(f)
        .sum()
}
