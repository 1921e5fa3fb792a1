//! `waggle study`: a study file's conditions × levels × modalities as seeded trials, then
//! `DIR/report.md` ([`crate::harness::study`]).

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::harness::study::{BUILT_IN, StudyFile, run_study};

#[derive(Debug, Args)]
pub struct StudyArgs {
    /// A study file (TOML) or a built-in study: event-noise, rgb-noise, viewing-angle, distance.
    study: String,
    /// Output directory: one subdirectory per point (trials.json, cost.json), study.json,
    /// success.svg and report.md.
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
    let mut study = StudyFile::load(&args.study)?;
    if args.print {
        match BUILT_IN.iter().find(|(n, _)| *n == args.study) {
            Some((_, text)) => print!("{text}"),
            None => print!("{}", std::fs::read_to_string(&args.study)?),
        }
        return Ok(());
    }
    if let Some(t) = args.trials {
        study.trials = t;
    }
    if args.out.join("report.md").exists() {
        bail!(
            "{} already holds a study report: choose another --out",
            args.out.display()
        );
    }
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get))
        .max(1);
    let stop = bus::on_stop_signal();
    let points = study.modalities.len() * study.vary.levels.len();
    let bar = ProgressBar::new(points as u64 * study.trials);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} trials, {msg} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let started = std::time::Instant::now();
    let results = run_study(
        &study,
        &args.out,
        args.render.path,
        jobs,
        &stop,
        |k, n, done, per_point| {
            bar.set_position(k as u64 * per_point + done);
            bar.set_message(format!("point {}/{n}", k + 1));
        },
    )?;
    bar.finish_and_clear();
    for r in &results {
        println!(
            "{:<7} {} = {:<8} {:>4}/{:<4} P = {:<6} CI [{:.3}, {:.3}]",
            r.modality,
            study.vary.key,
            r.level,
            r.successes,
            r.trials,
            r.success_rate.map_or("—".into(), |p| format!("{p:.3}")),
            r.ci95[0],
            r.ci95[1]
        );
    }
    println!(
        "study {}: {} points in {:.0} s wall ({} jobs) -> {}",
        study.name,
        results.len(),
        started.elapsed().as_secs_f64(),
        jobs,
        args.out.join("report.md").display()
    );
    if stop.load(Ordering::SeqCst) {
        bail!(
            "interrupted: {} of {points} points finished (report written)",
            results.len()
        );
    }
    Ok(())
}
