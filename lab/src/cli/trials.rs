//! `waggle trials`: one condition, N seeded trials, `DIR/trials.json` with the success rate and
//! its Wilson 95 % interval ([`crate::harness::trials`]).

use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use perturb::Perturbation;
use proto::scene::{Formation, MAX_OBSERVERS, Placement};
use proto::{Modality, Receiver};

use crate::harness::mission::trials::{
    MissionTrial, MissionTrialsOptions, MissionsDefinition, mission_criterion,
    run_mission_trials_on,
};
use crate::harness::runs::files::{PointCostSum, RunCost, RunKind, RunManifest, cpu_s};
use crate::harness::runs::records::{recorded, write_record};
use crate::harness::study::merge::{MergeOptions, Merged, merge};
use crate::harness::study::run::{FlightSource, header, run_point};
use crate::harness::trials::pool::Tally;
use crate::harness::trials::{PluginOptions, TrialsOptions, criterion, definition};
use commands::trials::TrialsArgs;
use run_format::case::Case;
use run_format::run_dir::lock::RunLock;

fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// The preset and terms, with the real-noise source when one is named.
fn perturbation(args: &TrialsArgs) -> Result<Perturbation> {
    perturbation_with(
        &args.perturb,
        args.real_noise.as_deref(),
        args.real_noise_static,
    )
}

/// The preset and terms of `perturb`, with the real-noise source `real_noise` (its static
/// stretch `window`) when one is named: what `waggle trials` and `waggle inputs` run under.
pub(super) fn perturbation_with(
    perturb: &commands::common::PerturbArgs,
    real_noise: Option<&str>,
    window: Option<(f64, f64)>,
) -> Result<Perturbation> {
    let mut perturbation = perturb.perturbation()?;
    if let Some(spec) = real_noise {
        let source =
            crate::harness::decode::real_noise::load(spec, window).context("--real-noise")?;
        perturbation = perturbation.with_real_noise(source);
    }
    perturbation.check_real_noise()?;
    Ok(perturbation)
}

/// The camera of link trials (real noise only for events).
fn link_modality(args: &TrialsArgs) -> Result<Modality> {
    if args.overrides.mode.is_some() || args.overrides.max_broadcasts.is_some() {
        bail!("--flights and --max-broadcasts change a whole case: they need --case");
    }
    let Some(modality) = args.modality.sensor() else {
        bail!("--link trials need a sensor: --modality rgb or events (ideal is for --case)");
    };
    if args.real_noise.is_some() && modality != Modality::Events {
        bail!("--real-noise is an event camera's background: it needs --modality events");
    }
    Ok(modality)
}

pub fn run(args: TrialsArgs) -> Result<()> {
    let perturbation = perturbation(&args)?;
    if args.case.is_some() {
        return run_case(args, perturbation);
    }
    let opts = link_options(&args, perturbation)?;
    opts.check()?;
    let shard = args.shard.shard()?;
    let cache = super::shard::open_cache(&args.render_cache)?;
    let _lock = RunLock::acquire(&args.out)?;
    RunManifest {
        kind: RunKind::Trials,
        definition: definition(&opts),
        requested: opts.trials,
        shard: shard.map(|s| s.to_string()),
    }
    .claim(&args.out)?;
    eprintln!("trials: {}", criterion(&opts));
    let range = shard.map_or(0..opts.trials, |s| s.range(opts.trials));
    let (found, damaged) = recorded::<crate::harness::trials::out::TrialRecord>(
        &args.out,
        ".",
        opts.trials,
        opts.render,
    )?;
    let missing: Vec<u64> = range
        .clone()
        .filter(|i| !found.records.contains_key(i))
        .collect();
    let already = range.end - range.start - missing.len() as u64;
    let stop = bus::on_stop_signal();
    let bar = progress_bar(
        range.end - range.start,
        "flying and rendering the broadcast",
    );
    bar.set_position(already);
    let (started, cpu_before) = (std::time::Instant::now(), cpu_s());
    let cost = if missing.is_empty() && header(&args.out).is_some() {
        PointCostSum::default()
    } else {
        run_point(
            &opts,
            &args.out,
            ".",
            FlightSource {
                shared: None,
                cache: cache.as_ref(),
            },
            &missing,
            &stop,
            |done, successes| {
                bar.set_position(already + done);
                bar.set_message(format!("{successes} of this run's trials succeeded"));
            },
        )?
    };
    bar.finish_and_clear();
    RunCost {
        runs: 1,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: cpu_s() - cpu_before,
        trials_run: cost.trials_run,
        points: [(".".to_owned(), cost)].into(),
        ..RunCost::default()
    }
    .add_to(&args.out)?;
    println!(
        "this run: {} trials ran, {already} already recorded{}; {} flight(s){} {:.1} s, trials \
         {:.1} s ({:.2} s per trial at {} jobs), renders held {:.1} MB",
        cost.trials_run,
        if damaged > 0 {
            format!(", {damaged} damaged records set aside and rerun")
        } else {
            String::new()
        },
        cost.flights,
        if cost.flights_from_cache > 0 {
            format!(" ({} from the render cache)", cost.flights_from_cache)
        } else {
            String::new()
        },
        cost.fly_and_render_s,
        cost.trials_s,
        cost.trials_s / cost.trials_run.max(1) as f64,
        opts.jobs,
        cost.render_cache_mb,
    );
    if let Some(shard) = shard {
        println!(
            "shard {shard} -> {} (merge every shard with `waggle study merge DIR… --out DIR`)",
            args.out.display()
        );
        return finished_shard(&stop);
    }
    write_results(&args.out, &stop)
}

/// The observers of a link: `--observers` in the built-in formation, or `--viewpoint`s.
pub(super) fn formation(observers: usize, viewpoints: &[Placement]) -> Result<Formation> {
    if viewpoints.is_empty() {
        Formation::standard(observers)
            .map_err(|_| anyhow::anyhow!("--observers {observers} is outside 1..={MAX_OBSERVERS}"))
    } else {
        Formation::custom(viewpoints.to_vec()).context("--viewpoint")
    }
}

/// The options of a link's trials (`--link`) from the command line.
fn link_options(args: &TrialsArgs, perturbation: Perturbation) -> Result<TrialsOptions> {
    let modality = link_modality(args)?;
    let formation = formation(args.observers, &args.viewpoints)?;
    Ok(TrialsOptions {
        payloads: args.link.clone(),
        formation,
        modality,
        trials: args.trials,
        seed: args.seed,
        perturbation,
        jobs: args.jobs.unwrap_or_else(default_jobs).max(1),
        render: args.render.path,
        rectification: args.rectify,
        acquisition: args.acquisition,
        plugin: args.receiver.clone().map(|spec| PluginOptions {
            spec,
            trial_limit: Some(std::time::Duration::from_secs_f64(args.plugin_time_limit_s)),
        }),
        frame_check: args.overrides.frame_check.unwrap_or_default(),
    })
}

/// Writes `trials.json` from the records in `dir` (partial ones when `stop` interrupted the
/// run) and prints the outcome.
fn write_results(dir: &std::path::Path, stop: &AtomicBool) -> Result<()> {
    let options = MergeOptions {
        partial: stop.load(Ordering::SeqCst),
        mixed_hosts: false,
    };
    let Merged::Trials(out) = merge(&[dir.to_path_buf()], dir, options)? else {
        bail!("{} is not a trials directory", dir.display());
    };
    let path = dir.join("trials.json");
    println!(
        "{} ({}): {} -> {}",
        out.header.modality,
        {
            let mut terms: Vec<String> = out
                .header
                .perturb
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            if let Some(real) = &out.header.real_noise {
                terms.push(format!("real noise {}", real.file));
            }
            if terms.is_empty() {
                "no perturbation".to_owned()
            } else {
                terms.join(" ")
            }
        },
        outcome_line(&out.tally, "trials succeeded"),
        path.display()
    );
    finished(stop, &out.tally, &path)
}

/// Ok, or the interruption of a shard (exit 1; rerun it to resume).
fn finished_shard(stop: &AtomicBool) -> Result<()> {
    if stop.load(Ordering::SeqCst) {
        bail!("interrupted: rerun the same command to run the shard's missing trials");
    }
    Ok(())
}

/// Creates and locks `out` for a new run, refusing one that already holds results or that
/// another waggle process is writing.
fn progress_bar(trials: u64, first: &str) -> ProgressBar {
    let bar = ProgressBar::new(trials);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} trials, {msg} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(first.to_owned());
    bar
}

/// `--case`: whole missions.
fn run_case(args: TrialsArgs, perturbation: Perturbation) -> Result<()> {
    let name = args.case.as_deref().unwrap_or_default();
    let case_text = run_format::case::case_source(name)?;
    let case = args.overrides.apply(Case::from_text(&case_text, name)?);
    if !case.modalities.contains(&args.modality) && args.modality != Receiver::Ideal {
        bail!(
            "case {} does not apply to the {} modality (it lists {:?})",
            case.name,
            args.modality,
            case.modalities
        );
    }
    let opts = MissionTrialsOptions {
        case,
        modality: args.modality,
        policy: args.policy,
        trials: args.trials,
        seed: args.seed,
        perturbation,
        jobs: args.jobs.unwrap_or_else(default_jobs).max(1),
        render: args.render.path,
    };
    if opts.trials == 0 {
        bail!("--trials must be at least 1");
    }
    let shard = args.shard.shard()?;
    let _lock = RunLock::acquire(&args.out)?;
    RunManifest {
        kind: RunKind::Missions,
        definition: MissionsDefinition::of(&opts, name, &case_text)?.to_text()?,
        requested: opts.trials,
        shard: shard.map(|s| s.to_string()),
    }
    .claim(&args.out)?;
    eprintln!("trials: {}", mission_criterion(&opts));
    let range = shard.map_or(0..opts.trials, |s| s.range(opts.trials));
    let (found, _) = recorded::<MissionTrial>(&args.out, ".", opts.trials, opts.render)?;
    let missing: Vec<u64> = range
        .clone()
        .filter(|i| !found.records.contains_key(i))
        .collect();
    let already = range.end - range.start - missing.len() as u64;
    let stop = bus::on_stop_signal();
    let bar = progress_bar(range.end - range.start, "flying the first missions");
    bar.set_position(already);
    let (started, cpu_before) = (std::time::Instant::now(), cpu_s());
    let flown = run_mission_trials_on(
        &opts,
        &missing,
        &stop,
        |t| write_record(&args.out, ".", opts.render, t),
        |done, successes| {
            bar.set_position(already + done);
            bar.set_message(format!("{successes} of this run's missions passed"));
        },
    )?;
    bar.finish_and_clear();
    RunCost {
        runs: 1,
        wall_s: started.elapsed().as_secs_f64(),
        cpu_s: cpu_s() - cpu_before,
        trials_run: flown.len() as u64,
        ..RunCost::default()
    }
    .add_to(&args.out)?;
    println!(
        "this run: {} missions flown, {already} already recorded; {:.1} s wall ({} jobs)",
        flown.len(),
        started.elapsed().as_secs_f64(),
        opts.jobs
    );
    if let Some(shard) = shard {
        println!(
            "shard {shard} -> {} (merge every shard with `waggle study merge DIR… --out DIR`)",
            args.out.display()
        );
        return finished_shard(&stop);
    }
    let interrupted = stop.load(Ordering::SeqCst);
    let options = MergeOptions {
        partial: interrupted,
        mixed_hosts: false,
    };
    let path = args.out.join("trials.json");
    if let Merged::Missions(out) = merge(std::slice::from_ref(&args.out), &args.out, options)? {
        println!(
            "{} {} ({}): {} -> {}",
            out.case,
            out.modality,
            out.policy,
            outcome_line(&out.tally, "missions met the expected outcome"),
            path.display()
        );
        for (o, r) in &out.receptions {
            println!(
                "  {o}: {} offers flown, {} received, {} lost, {} false release(s)",
                r.flown, r.received, r.lost, r.false_releases
            );
        }
        if out.false_releases.releases > 0 {
            println!(
                "  {} false release(s) — payloads the performer did not fly — in {} mission(s)",
                out.false_releases.releases, out.false_releases.missions
            );
        }
        return finished(&stop, &out.tally, &path);
    }
    Ok(())
}

/// `12/100 <what>, rate 0.120, 95 % CI [0.070, 0.198]` (and a word when interrupted).
fn outcome_line(t: &Tally, what: &str) -> String {
    format!(
        "{}/{} {what}, rate {}, 95 % CI [{:.3}, {:.3}]{}",
        t.successes,
        t.trials,
        t.success_rate.map_or("—".into(), |r| format!("{r:.3}")),
        t.ci95[0],
        t.ci95[1],
        if t.interrupted {
            " — interrupted, finished trials kept"
        } else {
            ""
        }
    )
}

/// Ok, or the interruption (exit 1) once the finished trials are written to `path`.
fn finished(stop: &AtomicBool, tally: &Tally, path: &std::path::Path) -> Result<()> {
    if stop.load(Ordering::SeqCst) {
        bail!(
            "interrupted after {} of {} trials (kept in {})",
            tally.trials,
            tally.requested,
            path.display()
        );
    }
    Ok(())
}
