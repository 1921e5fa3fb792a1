//! Running a link study, whole or one shard of it, resumably: every trial is recorded as it
//! ends ([`crate::harness::runs::records`]); a rerun into the same directory runs only the trials of
//! its part that are not recorded (damaged records are set aside and rerun). The results
//! (`trials.json`, `study.json`, report, figures) are then made from the records by
//! [`crate::harness::study::merge`], for one directory or for all of a study's shards.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use anyhow::{Context, Result, bail};
use proto::RenderPath;
use sim::sensor::EVENT_RENDER_PERIOD_NS;

use crate::harness::flight::cache::{Fetched, RenderCache, fly_through};
use crate::harness::flight::rendered::RenderedFlight;
use crate::harness::runs::files::{PointCostSum, RunCost, RunKind, RunManifest, cpu_s};
pub use crate::harness::runs::records::recorded;
use crate::harness::runs::records::{HEADER_FILE, write_json};
use crate::harness::runs::records::{read_json, write_record};
use crate::harness::runs::shard::{Shard, part_of};
use crate::harness::study::{Point, StudyFile, StudyPlan};
use crate::harness::trials::{TrialsHeader, TrialsOptions, TrialsRun, run_trials};

/// What a run of a study (or of one shard) did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Trials in this run's part (the whole study, or the shard's block).
    pub part: u64,
    /// Found recorded (not run again).
    pub recorded: u64,
    /// Run now.
    pub ran: u64,
    /// Records found damaged (set aside and rerun).
    pub damaged: u64,
    /// Shared flights used, and how many of them were read from the render cache on disk.
    pub shared_flights: u64,
    pub shared_flights_from_cache: u64,
}

/// The study's definition as `run.json` records it (the TOML a merge reads back).
pub fn study_manifest(study: &StudyFile, shard: Option<Shard>) -> Result<RunManifest> {
    Ok(RunManifest {
        kind: RunKind::Study,
        definition: toml::to_string(study).context("writing the study as TOML")?,
        requested: study.trials,
        shard: shard.map(|s| s.to_string()),
    })
}

/// The header of the point in `dir`, if recorded and readable.
pub fn header(dir: &Path) -> Option<TrialsHeader> {
    read_json(&dir.join(HEADER_FILE)).ok()
}

/// Where a point's flight comes from: a flight shared with other points, else flown for it
/// (through the render cache on disk, if any).
#[derive(Debug, Clone, Copy, Default)]
pub struct FlightSource<'a> {
    pub shared: Option<&'a RenderedFlight>,
    pub cache: Option<&'a RenderCache>,
}

/// Runs `opts`' trials `missing` into `dir` (records as they end, header once flown) and
/// returns the run's cost of them.
pub fn run_point(
    opts: &TrialsOptions,
    dir: &Path,
    name: &str,
    FlightSource { shared, cache }: FlightSource<'_>,
    missing: &[u64],
    stop: &AtomicBool,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<PointCostSum> {
    let before = cpu_s();
    let TrialsRun {
        header: made,
        records,
        cost,
    } = run_trials(
        opts,
        shared,
        cache,
        missing,
        stop,
        |r| write_record(dir, name, opts.render, r),
        progress,
    )?;
    let path = dir.join(HEADER_FILE);
    match header(dir) {
        Some(h) if h == made => {}
        Some(_) => bail!(
            "{}: the recorded header differs from this run's (another flight?): remove the \
             directory or use the binary that recorded it",
            path.display()
        ),
        None => write_json(&path, &made)?,
    }
    Ok(PointCostSum::of(
        &cost,
        records.len() as u64,
        cpu_s() - before,
    ))
}

/// How a run of a study's part goes: its cameras' render path, trials at once, which shard (all
/// when none), and the render cache on disk (none: flights are kept in memory only).
#[derive(Debug, Clone, Copy)]
pub struct PartRun<'a> {
    pub render: RenderPath,
    pub jobs: usize,
    pub shard: Option<Shard>,
    pub cache: Option<&'a RenderCache>,
}

/// Runs the study's trials (all, or shard `shard`'s block) that `out` does not hold yet.
/// `progress(done, part)` counts this part's trials, recorded ones included. The cost of this
/// run is added to `out/run-cost.json`, also when `stop` interrupts it.
pub fn run_study_part(
    study: &StudyFile,
    out: &Path,
    PartRun {
        render,
        jobs,
        shard,
        cache,
    }: PartRun<'_>,
    stop: &AtomicBool,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<RunCounts> {
    let started = std::time::Instant::now();
    let cpu_before = cpu_s();
    let points = study.points(render, jobs)?;
    study_manifest(study, shard)?.claim(out)?;
    let (parts, part) = part_of(points.len(), study.trials, shard);
    let mut counts = RunCounts {
        part,
        ..RunCounts::default()
    };
    // What each point still needs: its missing trials, and its header when not recorded.
    let mut work = Vec::new();
    for (p, indices) in &parts {
        let point = &points[*p];
        let dir = out.join(&point.dir);
        let (found, damaged) = recorded::<crate::harness::trials::out::TrialRecord>(
            &dir,
            &point.dir,
            study.trials,
            point.options.render,
        )?;
        counts.damaged += damaged;
        let missing: Vec<u64> = indices
            .iter()
            .copied()
            .filter(|i| !found.records.contains_key(i))
            .collect();
        counts.recorded += indices.len() as u64 - missing.len() as u64;
        if !missing.is_empty() || header(&dir).is_none() {
            work.push((*p, missing));
        }
    }
    let done = AtomicU64::new(counts.recorded);
    progress(counts.recorded, counts.part);
    let mut cost = RunCost {
        runs: 1,
        ..RunCost::default()
    };
    let result = run_work(
        out,
        &points,
        &work,
        cache,
        stop,
        |n| {
            progress(done.fetch_add(n, Ordering::SeqCst) + n, counts.part);
        },
        &mut cost,
    );
    counts.ran = cost.trials_run;
    counts.shared_flights = cost.shared_flights;
    counts.shared_flights_from_cache = cost.shared_flights_from_cache;
    cost.wall_s = started.elapsed().as_secs_f64();
    cost.cpu_s = cpu_s() - cpu_before;
    cost.add_to(out)?;
    result.map(|()| counts)
}

/// Flies and runs `work` (point index, missing trials), adding each point's cost to `cost`.
fn run_work(
    out: &Path,
    points: &[Point],
    work: &[(usize, Vec<u64>)],
    cache: Option<&RenderCache>,
    stop: &AtomicBool,
    one_done: impl Fn(u64) + Sync,
    cost: &mut RunCost,
) -> Result<()> {
    // Sensor and link terms do not change what the cameras see: every point on one formation
    // (all of them, unless a viewpoint axis is varied) replays one flight of the broadcast,
    // rendered at the shortest period any of the study's points on it needs — the same flight
    // whichever shard flies it. It is kept while consecutive points use it.
    let mut flight: Option<(String, RenderedFlight)> = None;
    for (p, missing) in work {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let point = &points[*p];
        let shared = if point.options.perturbation.reflies() {
            None
        } else {
            let key = flight_key(point);
            if flight.as_ref().is_none_or(|(k, _)| *k != key) {
                drop(flight.take()); // free the last renders before flying the next
                let period_ns = points
                    .iter()
                    .filter(|q| flight_key(q) == key)
                    .map(|q| q.options.render_period_ns())
                    .min()
                    .unwrap_or(EVENT_RENDER_PERIOD_NS);
                let spec = point.options.shared_flight_spec(period_ns)?;
                let started = std::time::Instant::now();
                let (flown, fetched) = fly_through(cache, spec)?;
                flight = Some((key, flown));
                cost.shared_flights += 1;
                cost.shared_flights_from_cache += u64::from(fetched == Fetched::Hit);
                cost.shared_fly_s += started.elapsed().as_secs_f64();
            }
            flight.as_ref().map(|(_, f)| f)
        };
        let dir = out.join(&point.dir);
        let c = run_point(
            &point.options,
            &dir,
            &point.dir,
            FlightSource { shared, cache },
            missing,
            stop,
            |_, _| {
                one_done(1);
            },
        )
        .with_context(|| format!("point {}", point.dir))?;
        cost.trials_run += c.trials_run;
        cost.points.entry(point.dir.clone()).or_default().add(&c);
    }
    Ok(())
}

/// Which shared flight a point replays: its observers' placements (the broadcast, render path
/// and rectification are the study's).
fn flight_key(point: &Point) -> String {
    format!("{:?}", point.options.formation.placements())
}
