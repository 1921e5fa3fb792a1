//! `waggle trials`: one condition, N seeded trials, `DIR/trials.json` with the success rate and
//! its Wilson 95 % interval ([`crate::harness::trials`]).

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use perturb::Perturbation;
use proto::scene::{Formation, MAX_OBSERVERS, Placement};
use proto::{Modality, Rectification};

use super::link::{parse_bits6, parse_viewpoint};
use crate::harness::trials::{TrialsOptions, criterion, run_trials};

#[derive(Debug, Args)]
#[command(after_long_help = perturbation_help())]
pub struct TrialsArgs {
    /// The broadcast: six-bit payloads flown back to back, comma-separated (e.g. 011010,100111).
    #[arg(long, value_delimiter = ',', value_parser = parse_bits6, required = true)]
    link: Vec<u8>,
    /// Number of observers in the built-in formation (1..=8).
    #[arg(long, default_value_t = 3)]
    observers: usize,
    /// Place observers at AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M instead (repeat, up to 8).
    #[arg(long = "viewpoint", value_name = "AZ,EL,DIST", value_parser = parse_viewpoint)]
    viewpoints: Vec<Placement>,
    /// The observers' sensor.
    #[arg(long, value_enum)]
    modality: Modality,
    /// Number of trials.
    #[arg(long, default_value_t = 100)]
    trials: u64,
    /// Seed of the run: trial k draws from a seed derived from it and k.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// A perturbation term KEY=VALUE (repeatable; see the table below). None: the noiseless
    /// sensors of `waggle link`.
    #[arg(long = "perturb", value_name = "KEY=VALUE")]
    perturb: Vec<String>,
    /// Trials at once (threads; default: the machine's cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Viewpoint rectification of the receivers' trajectories.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    rectify: Rectification,
    #[command(flatten)]
    render: super::RenderArg,
    /// Output directory: trials.json (deterministic) and cost.json (wall-clock figures).
    #[arg(long)]
    out: PathBuf,
}

fn perturbation_help() -> String {
    let mut s = String::from("Perturbation terms (--perturb KEY=VALUE; every default is off):\n");
    for p in perturb::spec::PARAMETERS {
        s.push_str(&format!(
            "  {:<28} [{}] default {}: {}\n",
            p.key, p.unit, p.default, p.doc
        ));
    }
    s
}

fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

pub fn run(args: TrialsArgs) -> Result<()> {
    let perturbation = Perturbation::parse(&args.perturb)?;
    let formation = if args.viewpoints.is_empty() {
        Formation::standard(args.observers).map_err(|_| {
            anyhow::anyhow!(
                "--observers {} is outside 1..={MAX_OBSERVERS}",
                args.observers
            )
        })?
    } else {
        Formation::custom(args.viewpoints).context("--viewpoint")?
    };
    if args.out.join("trials.json").exists() {
        bail!(
            "{} already holds trials.json: choose another --out or remove it",
            args.out.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let opts = TrialsOptions {
        payloads: args.link,
        formation,
        modality: args.modality,
        trials: args.trials,
        seed: args.seed,
        perturbation,
        jobs: args.jobs.unwrap_or_else(default_jobs).max(1),
        render: args.render.path,
        rectification: args.rectify,
    };
    opts.check()?;
    eprintln!("trials: {}", criterion(&opts));
    let stop = bus::on_stop_signal();
    let bar = ProgressBar::new(opts.trials);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} trials, {msg} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message("flying and rendering the broadcast");
    let (out, cost) = run_trials(&opts, &stop, |done, successes| {
        bar.set_position(done);
        bar.set_message(format!("{successes} succeeded"));
    })?;
    bar.finish_and_clear();
    let path = args.out.join("trials.json");
    std::fs::write(&path, serde_json::to_string_pretty(&out)? + "\n")
        .with_context(|| format!("writing {}", path.display()))?;
    let cost_path = args.out.join("cost.json");
    std::fs::write(&cost_path, serde_json::to_string_pretty(&cost)? + "\n")
        .with_context(|| format!("writing {}", cost_path.display()))?;
    let rate = out.success_rate.map_or("—".into(), |r| format!("{:.3}", r));
    println!(
        "{} ({}): {}/{} trials succeeded, rate {rate}, 95 % CI [{:.3}, {:.3}]{}",
        out.modality,
        if out.perturb.is_empty() {
            "no perturbation".to_owned()
        } else {
            out.perturb
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(" ")
        },
        out.successes,
        out.trials,
        out.ci95[0],
        out.ci95[1],
        if out.interrupted {
            " — interrupted, finished trials kept"
        } else {
            ""
        }
    );
    println!(
        "cost: {} flight(s) {:.1} s, trials {:.1} s ({:.2} s per trial at {} jobs), render cache {:.1} MB -> {}",
        cost.flights,
        cost.fly_and_render_s,
        cost.trials_s,
        cost.trials_s / out.trials.max(1) as f64,
        opts.jobs,
        cost.render_cache_mb,
        path.display()
    );
    if stop.load(Ordering::SeqCst) {
        bail!(
            "interrupted after {} of {} trials (kept in {})",
            out.trials,
            out.requested,
            path.display()
        );
    }
    Ok(())
}
