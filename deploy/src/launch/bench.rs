//! `waggle bench`: one case run as processes once per render path in a single invocation, so
//! the figures are a side-by-side ratio on the same machine in the same minutes rather than an
//! absolute time. Runs alternate (damage, raster, damage, raster, …) so slow drift in the
//! machine's load falls on every path alike; each path's figures are divided by the first
//! path's (the baseline, MuJoCo's damage path unless `--paths` says otherwise).

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use bus::Endpoints;
use proto::{Modality, RenderPath};
use serde::{Deserialize, Serialize};

use super::{RunOptions, run_case, run_modality};
use crate::case::Case;
use crate::fault::ExtraFaults;
use crate::run_dir::{CameraRenders, RunSummary};

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Built-in case name or case file.
    pub case: String,
    pub modality: Option<Modality>,
    /// The render paths compared, the first the baseline (at least two, none twice).
    pub paths: Vec<RenderPath>,
    /// Rounds of runs (one per path each).
    pub repeat: usize,
    /// Each run's directory goes under here, `bench.json` too.
    pub out: PathBuf,
    pub bin_dir: Option<PathBuf>,
    pub quiet: bool,
}

/// The machine while the benchmark ran.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MachineState {
    pub cores: usize,
    /// 1, 5 and 15 minute load averages before the first run and after the last.
    pub load_before: [f32; 3],
    pub load_after: [f32; 3],
}

/// One run's figures.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchRun {
    pub render: RenderPath,
    pub dir: PathBuf,
    pub pass: bool,
    pub sim_s: f64,
    pub wall_over_sim: f64,
    /// CPU seconds of all camera processes together.
    pub camera_cpu_s: f64,
    pub camera_cpu_per_sim_s: f64,
    pub cpu_s: BTreeMap<String, f64>,
    pub renders: BTreeMap<String, CameraRenders>,
    pub sensor_digests: BTreeMap<String, String>,
}

impl BenchRun {
    fn of(summary: &RunSummary, render: RenderPath, dir: PathBuf) -> Self {
        let sim_s = summary.mission.mission_time_s;
        let camera_cpu_s: f64 = summary
            .processes
            .iter()
            .filter(|(name, _)| name.starts_with("camera-"))
            .map(|(_, p)| p.cpu_s)
            .sum();
        Self {
            render,
            dir,
            pass: summary.mission.pass,
            sim_s,
            wall_over_sim: summary.wall_over_sim,
            camera_cpu_s,
            camera_cpu_per_sim_s: camera_cpu_s / sim_s,
            cpu_s: summary
                .processes
                .iter()
                .map(|(n, p)| (n.clone(), p.cpu_s))
                .collect(),
            renders: summary.camera_renders.clone(),
            sensor_digests: summary.sensor_digests.clone(),
        }
    }
}

/// Every path's runs and the ratios of their means to the baseline's.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchReport {
    pub case: String,
    pub modality: Modality,
    pub machine: MachineState,
    /// The path the others are divided by.
    pub baseline: RenderPath,
    pub runs: Vec<BenchRun>,
    /// Mean over the runs of each path.
    pub wall_over_sim: BTreeMap<RenderPath, f64>,
    pub camera_cpu_per_sim_s: BTreeMap<RenderPath, f64>,
    /// Each path's mean ÷ the baseline's.
    pub wall_over_sim_ratio: BTreeMap<RenderPath, f64>,
    pub camera_cpu_ratio: BTreeMap<RenderPath, f64>,
    /// Every run of one renderer published the same sensor bytes: MuJoCo's full and damage
    /// paths among themselves, Waggle's renderer among its own runs (the two renderers draw
    /// different pixels, so their digests are not compared with each other).
    pub digests_equal: bool,
}

/// File the report is written to in the bench directory.
pub const BENCH_FILE: &str = "bench.json";

fn load_average() -> [f32; 3] {
    use procfs::Current;
    procfs::LoadAverage::current().map_or([f32::NAN; 3], |l| [l.one, l.five, l.fifteen])
}

/// Runs the case `repeat` times per path, alternating, and compares.
pub fn run_bench(opts: &BenchOptions) -> Result<BenchReport> {
    if opts.repeat == 0 {
        bail!("--repeat must be at least 1");
    }
    if opts.paths.len() < 2 {
        bail!("--paths needs at least two render paths to compare");
    }
    if let Some(p) = opts
        .paths
        .iter()
        .find(|p| opts.paths.iter().filter(|q| q == p).count() > 1)
    {
        bail!("--paths names {p} twice");
    }
    let case = Case::load(&opts.case)?;
    let modality = run_modality(&case, opts.modality)?;
    std::fs::create_dir_all(&opts.out)
        .with_context(|| format!("creating {}", opts.out.display()))?;
    let load_before = load_average();
    let mut runs = Vec::new();
    for k in 0..opts.repeat {
        for &render in &opts.paths {
            let dir = opts.out.join(format!("{}-{k}", render.as_str()));
            if !opts.quiet {
                eprintln!(
                    "bench: run {} of {} — {} {} --render {render}",
                    runs.len() + 1,
                    opts.paths.len() * opts.repeat,
                    case.name,
                    modality.as_str()
                );
            }
            let done = run_case(
                &case,
                modality,
                &RunOptions {
                    case_arg: opts.case.clone(),
                    out: Some(dir.clone()),
                    session: None,
                    bin_dir: opts.bin_dir.clone(),
                    grace_ms: node_args::DEFAULT_GRACE_MS,
                    extra_faults: ExtraFaults::default(),
                    observer_acl: false,
                    no_auth: false,
                    plain_tcp: false,
                    quiet: opts.quiet,
                    no_record: true,
                    record_all_rgb: false,
                    record_events: Default::default(),
                    endpoints: Endpoints::default(),
                    render,
                    live: None,
                    ros2: None,
                    ros2_cameras: Default::default(),
                    sensor: node_args::SensorArgs::default(),
                    receivers: Default::default(),
                    plugin_time_limit_ms: None,
                    rss_every_s: None,
                },
            )?;
            if done.summary.interrupted {
                bail!("interrupted");
            }
            runs.push(BenchRun::of(&done.summary, render, dir));
        }
    }
    let report = compare(&case.name, modality, opts.paths[0], runs, load_before);
    let path = opts.out.join(BENCH_FILE);
    std::fs::write(&path, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(report)
}

fn compare(
    case: &str,
    modality: Modality,
    baseline: RenderPath,
    runs: Vec<BenchRun>,
    load_before: [f32; 3],
) -> BenchReport {
    let per_path = |f: fn(&BenchRun) -> f64| -> BTreeMap<RenderPath, f64> {
        let mut sums: BTreeMap<RenderPath, (f64, f64)> = BTreeMap::new();
        for r in &runs {
            let e = sums.entry(r.render).or_default();
            *e = (e.0 + f(r), e.1 + 1.0);
        }
        sums.into_iter().map(|(p, (s, n))| (p, s / n)).collect()
    };
    let wall_over_sim = per_path(|r| r.wall_over_sim);
    let camera_cpu_per_sim_s = per_path(|r| r.camera_cpu_per_sim_s);
    let ratio = |m: &BTreeMap<RenderPath, f64>| -> BTreeMap<RenderPath, f64> {
        m.iter().map(|(p, v)| (*p, v / m[&baseline])).collect()
    };
    let digests_equal = [true, false].into_iter().all(|mujoco| {
        let mut of_renderer = runs.iter().filter(|r| r.render.is_mujoco() == mujoco);
        of_renderer
            .next()
            .is_none_or(|first| of_renderer.all(|r| r.sensor_digests == first.sensor_digests))
    });
    BenchReport {
        case: case.to_string(),
        modality,
        machine: MachineState {
            cores: std::thread::available_parallelism().map_or(0, usize::from),
            load_before,
            load_after: load_average(),
        },
        baseline,
        wall_over_sim_ratio: ratio(&wall_over_sim),
        camera_cpu_ratio: ratio(&camera_cpu_per_sim_s),
        wall_over_sim,
        camera_cpu_per_sim_s,
        runs,
        digests_equal,
    }
}

/// The report as the terminal shows it.
pub fn print_report(r: &BenchReport) {
    let load = |l: [f32; 3]| format!("{:.2} {:.2} {:.2}", l[0], l[1], l[2]);
    println!(
        "bench {} · {} · {} cores · load {} before, {} after",
        r.case,
        r.modality,
        r.machine.cores,
        load(r.machine.load_before),
        load(r.machine.load_after)
    );
    println!(
        "render  pass  wall/sim  camera CPU-s  camera CPU-s per sim-s  renders full/damage/skipped"
    );
    for run in &r.runs {
        let routes = run.renders.values().fold([0u64; 3], |a, c| {
            [a[0] + c.full, a[1] + c.damage, a[2] + c.skipped]
        });
        println!(
            "{:<7} {:<5} {:>8.3}  {:>12.1}  {:>22.3}  {}/{}/{}",
            run.render.as_str(),
            run.pass,
            run.wall_over_sim,
            run.camera_cpu_s,
            run.camera_cpu_per_sim_s,
            routes[0],
            routes[1],
            routes[2]
        );
    }
    for (path, ratio) in &r.wall_over_sim_ratio {
        if *path == r.baseline {
            continue;
        }
        println!(
            "{path} ÷ {}: wall/sim {ratio:.3} ({:.3} vs {:.3}) · camera CPU {:.3} ({:.3} vs {:.3} CPU-s per sim-s)",
            r.baseline,
            r.wall_over_sim[path],
            r.wall_over_sim[&r.baseline],
            r.camera_cpu_ratio[path],
            r.camera_cpu_per_sim_s[path],
            r.camera_cpu_per_sim_s[&r.baseline],
        );
    }
    println!(
        "sensor digests {}",
        if r.digests_equal {
            "equal in every run of each renderer"
        } else {
            "DIFFER between runs of one renderer"
        }
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(render: RenderPath, wall: f64, cpu: f64, digest: &str) -> BenchRun {
        BenchRun {
            render,
            dir: PathBuf::from(render.as_str()),
            pass: true,
            sim_s: 100.0,
            wall_over_sim: wall,
            camera_cpu_s: cpu * 100.0,
            camera_cpu_per_sim_s: cpu,
            cpu_s: BTreeMap::new(),
            renders: BTreeMap::new(),
            sensor_digests: BTreeMap::from([("O1".to_string(), digest.to_string())]),
        }
    }

    #[test]
    fn ratios_are_over_the_baselines_mean_and_digests_agree_within_a_renderer() {
        let runs = vec![
            run(RenderPath::Damage, 0.6, 1.0, "d"),
            run(RenderPath::Full, 0.9, 2.0, "d"),
            run(RenderPath::Raster, 0.3, 0.1, "r"),
            run(RenderPath::Damage, 0.8, 1.2, "d"),
            run(RenderPath::Full, 1.1, 2.4, "d"),
            run(RenderPath::Raster, 0.3, 0.12, "r"),
        ];
        let r = compare(
            "c",
            Modality::Events,
            RenderPath::Damage,
            runs.clone(),
            [0.0; 3],
        );
        let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(near(r.wall_over_sim_ratio[&RenderPath::Damage], 1.0));
        assert!(near(r.wall_over_sim_ratio[&RenderPath::Raster], 0.3 / 0.7));
        assert!(near(r.wall_over_sim_ratio[&RenderPath::Full], 1.0 / 0.7));
        assert!(near(r.camera_cpu_ratio[&RenderPath::Raster], 0.11 / 1.1));
        assert!(
            r.digests_equal,
            "raster's bytes are not compared with MuJoCo's"
        );
        let mut differ = runs.clone();
        differ[4] = run(RenderPath::Full, 1.1, 2.4, "e");
        assert!(
            !compare("c", Modality::Events, RenderPath::Damage, differ, [0.0; 3]).digests_equal,
            "MuJoCo's full and damage paths must agree"
        );
        let mut differ = runs;
        differ[5] = run(RenderPath::Raster, 0.3, 0.12, "s");
        assert!(
            !compare("c", Modality::Events, RenderPath::Damage, differ, [0.0; 3]).digests_equal,
            "two raster runs must agree"
        );
    }
}
