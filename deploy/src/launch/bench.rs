//! `waggle bench`: one case run as processes once per render path in a single invocation, so
//! the figures are a side-by-side ratio on the same machine in the same minutes rather than an
//! absolute time. Runs alternate (full, damage, full, damage, …) so slow drift in the machine's
//! load falls on both paths alike.

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
    /// Pairs of runs (one per path each).
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

/// Both paths' runs and the damage/full ratios of their means.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchReport {
    pub case: String,
    pub modality: Modality,
    pub machine: MachineState,
    pub runs: Vec<BenchRun>,
    /// Mean over the runs of each path.
    pub wall_over_sim: BTreeMap<RenderPath, f64>,
    pub camera_cpu_per_sim_s: BTreeMap<RenderPath, f64>,
    /// damage ÷ full.
    pub wall_over_sim_ratio: f64,
    pub camera_cpu_ratio: f64,
    /// Every run published the same sensor bytes.
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
    let case = Case::load(&opts.case)?;
    let modality = run_modality(&case, opts.modality)?;
    std::fs::create_dir_all(&opts.out)
        .with_context(|| format!("creating {}", opts.out.display()))?;
    let load_before = load_average();
    let mut runs = Vec::new();
    for k in 0..opts.repeat {
        for render in [RenderPath::Full, RenderPath::Damage] {
            let dir = opts.out.join(format!("{}-{k}", render.as_str()));
            if !opts.quiet {
                eprintln!(
                    "bench: run {} of {} — {} {} --render {render}",
                    runs.len() + 1,
                    2 * opts.repeat,
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
                    sensor: node_args::SensorArgs::default(),
                },
            )?;
            if done.summary.interrupted {
                bail!("interrupted");
            }
            runs.push(BenchRun::of(&done.summary, render, dir));
        }
    }
    let report = compare(&case.name, modality, runs, load_before);
    let path = opts.out.join(BENCH_FILE);
    std::fs::write(&path, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(report)
}

fn compare(
    case: &str,
    modality: Modality,
    runs: Vec<BenchRun>,
    load_before: [f32; 3],
) -> BenchReport {
    let mean = |path: RenderPath, f: fn(&BenchRun) -> f64| {
        let v: Vec<f64> = runs.iter().filter(|r| r.render == path).map(f).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let per_path = |f: fn(&BenchRun) -> f64| -> BTreeMap<RenderPath, f64> {
        RenderPath::ALL
            .into_iter()
            .map(|p| (p, mean(p, f)))
            .collect()
    };
    let wall_over_sim = per_path(|r| r.wall_over_sim);
    let camera_cpu_per_sim_s = per_path(|r| r.camera_cpu_per_sim_s);
    let ratio = |m: &BTreeMap<RenderPath, f64>| m[&RenderPath::Damage] / m[&RenderPath::Full];
    let digests_equal = runs
        .windows(2)
        .all(|w| w[0].sensor_digests == w[1].sensor_digests);
    BenchReport {
        case: case.to_string(),
        modality,
        machine: MachineState {
            cores: std::thread::available_parallelism().map_or(0, usize::from),
            load_before,
            load_after: load_average(),
        },
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
    println!(
        "damage ÷ full: wall/sim {:.3} ({:.3} vs {:.3}) · camera CPU {:.3} ({:.3} vs {:.3} CPU-s per sim-s)",
        r.wall_over_sim_ratio,
        r.wall_over_sim[&RenderPath::Damage],
        r.wall_over_sim[&RenderPath::Full],
        r.camera_cpu_ratio,
        r.camera_cpu_per_sim_s[&RenderPath::Damage],
        r.camera_cpu_per_sim_s[&RenderPath::Full],
    );
    println!(
        "sensor digests {}",
        if r.digests_equal {
            "equal in every run"
        } else {
            "DIFFER between runs"
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
    fn ratios_are_damage_over_full_of_the_means_and_digests_must_all_agree() {
        let runs = vec![
            run(RenderPath::Full, 0.6, 1.0, "d"),
            run(RenderPath::Damage, 0.3, 0.4, "d"),
            run(RenderPath::Full, 0.8, 1.2, "d"),
            run(RenderPath::Damage, 0.3, 0.44, "d"),
        ];
        let r = compare("c", Modality::Events, runs.clone(), [0.0; 3]);
        assert!((r.wall_over_sim_ratio - 0.3 / 0.7).abs() < 1e-12);
        assert!((r.camera_cpu_ratio - 0.42 / 1.1).abs() < 1e-12);
        assert!(r.digests_equal);
        let mut differ = runs;
        differ[3] = run(RenderPath::Damage, 0.3, 0.44, "e");
        assert!(!compare("c", Modality::Events, differ, [0.0; 3]).digests_equal);
    }
}
