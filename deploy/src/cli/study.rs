//! `waggle study`: a study file's conditions × levels × modalities as seeded trials, then
//! `DIR/report.md` ([`crate::harness::study`]).

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::harness::baselines::{BaselineStudy, run_baselines};
use crate::harness::study::{Study, StudyFile, run_study, study_text};
use crate::run_dir::lock::RunLock;

#[derive(Debug, Args)]
pub struct StudyArgs {
    /// A study file (TOML) or a built-in study: event-noise, rgb-noise, light, viewing-angle,
    /// distance, baselines (`--print` shows one to copy and edit).
    study: String,
    /// Output directory: one subdirectory per point (trials.json, cost.json), study.json,
    /// success-<condition>.svg and report.md.
    #[arg(long)]
    out: PathBuf,
    /// Trials at once (threads; default: the machine's cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Override the study's trials per point (e.g. a quick look before the real run).
    #[arg(long)]
    trials: Option<u64>,
    /// Print the study file (a built-in one's TOML, to copy and edit) and exit.
    #[arg(long)]
    print: bool,
    #[command(flatten)]
    render: super::RenderArg,
}

pub fn run(args: StudyArgs) -> Result<()> {
    let study = Study::load(&args.study)?;
    if args.print {
        print!("{}", study_text(&args.study)?.0);
        return Ok(());
    }
    if args.out.join("report.md").exists() {
        bail!(
            "{} already holds a study report: choose another --out",
            args.out.display()
        );
    }
    let _lock = RunLock::acquire(&args.out)?;
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get))
        .max(1);
    match study {
        Study::Link(mut study) => {
            if let Some(t) = args.trials {
                study.trials = t;
            }
            run_link_study(&study, &args, jobs)
        }
        Study::Baselines(mut study) => {
            if let Some(t) = args.trials {
                study.trials = t;
            }
            run_baseline_study(&study, &args, jobs)
        }
    }
}

fn bar_for(trials: u64) -> ProgressBar {
    let bar = ProgressBar::new(trials);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} trials, {msg} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// What a study is about to run, for its progress bar and closing line.
#[derive(Clone, Copy)]
struct Plan<'a> {
    name: &'a str,
    /// What one point is called (`points`, `case × arm`).
    unit: &'a str,
    points: usize,
    trials: u64,
}

/// Runs a study under a progress bar over `points` × `trials` trials (`run` gets the stop flag
/// and the progress callback), prints what `print` makes of the results and the closing line;
/// exit 1 when Ctrl-C interrupted it (the report is written either way).
fn with_progress<R>(
    plan: &Plan<'_>,
    args: &StudyArgs,
    jobs: usize,
    run: impl FnOnce(&Arc<AtomicBool>, &(dyn Fn(usize, usize, u64, u64) + Sync)) -> Result<Vec<R>>,
    print: impl FnOnce(&[R]),
) -> Result<()> {
    let Plan {
        name,
        unit,
        points,
        trials,
    } = *plan;
    let stop = bus::on_stop_signal();
    let bar = bar_for(points as u64 * trials);
    let started = std::time::Instant::now();
    let progress = |k: usize, n: usize, done: u64, per: u64| {
        bar.set_position(k as u64 * per + done);
        bar.set_message(format!("{unit} {}/{n}", k + 1));
    };
    let results = run(&stop, &progress)?;
    bar.finish_and_clear();
    print(&results);
    println!(
        "study {name}: {} {unit} in {:.0} s wall ({jobs} jobs) -> {}",
        results.len(),
        started.elapsed().as_secs_f64(),
        args.out.join("report.md").display()
    );
    if stop.load(Ordering::SeqCst) {
        bail!(
            "interrupted: {} of {points} {unit} finished (report written)",
            results.len()
        );
    }
    Ok(())
}

fn run_baseline_study(study: &BaselineStudy, args: &StudyArgs, jobs: usize) -> Result<()> {
    let points = study.cases.len() * study.arms.len();
    let plan = Plan {
        name: &study.name,
        unit: "case × arm",
        points,
        trials: study.trials,
    };
    with_progress(
        &plan,
        args,
        jobs,
        |stop, progress| run_baselines(study, &args.out, args.render.path, jobs, stop, progress),
        |results| print!("{}", crate::harness::baselines::report(study, results)),
    )
}

fn run_link_study(study: &StudyFile, args: &StudyArgs, jobs: usize) -> Result<()> {
    let points = study.modalities.len() * study.vary.iter().map(|v| v.levels.len()).sum::<usize>();
    let plan = Plan {
        name: &study.name,
        unit: "points",
        points,
        trials: study.trials,
    };
    with_progress(
        &plan,
        args,
        jobs,
        |stop, progress| run_study(study, &args.out, args.render.path, jobs, stop, progress),
        |results| {
            for r in results {
                let (p, ci) = r.rate_cells();
                println!(
                    "{:<7} {} = {:<8} {:>4}/{:<4} P = {p:<6} CI {ci}",
                    r.modality, r.key, r.level, r.successes, r.trials
                );
            }
        },
    )
}
