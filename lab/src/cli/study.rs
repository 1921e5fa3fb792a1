//! `waggle study`: a study file's conditions × levels × modalities as seeded trials, then
//! `DIR/report.md` ([`crate::harness::study`]); one shard of it (`--shard K/N`), job files for
//! a cluster (`--slurm`, `--kubernetes`) and the merge of shards (`waggle study merge`).

use std::path::Path;
use std::sync::atomic::Ordering;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressStyle};

use crate::harness::runs::shard::Shard;
use crate::harness::study::baselines::BaselineStudy;
use crate::harness::study::baselines_run;
use crate::harness::study::merge::{MergeOptions, Merged, merge};
use crate::harness::study::run::{PartRun, run_study_part};
use crate::harness::study::{Study, StudyFile, study_text};
use commands::study::{StudyArgs, StudyCommand};
use run_format::run_dir::lock::RunLock;

pub fn run(args: StudyArgs) -> Result<()> {
    if let Some(StudyCommand::Merge(merge)) = args.command {
        return super::shard::merge(&merge);
    }
    if let (Some(name), true) = (&args.study, args.print) {
        Study::load(name)?;
        print!("{}", study_text(name)?.0);
        return Ok(());
    }
    let (Some(name), Some(out)) = (args.study.clone(), args.out.clone()) else {
        bail!("give a study and --out DIR (or `waggle study merge DIR… --out DIR`)");
    };
    let mut study = Study::load(&name)?;
    if let Some(t) = args.trials {
        match &mut study {
            Study::Link(s) => s.trials = t,
            Study::Baselines(s) => s.trials = t,
        }
    }
    if args.cluster.wanted() {
        let job: &dyn super::shard::JobStudy = match &study {
            Study::Link(s) => s.as_ref(),
            Study::Baselines(s) => s,
        };
        return super::shard::write_jobs(
            &args.cluster,
            job,
            &out,
            &args.shard,
            &args.render,
            &args.render_cache,
        );
    }
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get))
        .max(1);
    let shard = args.shard.shard()?;
    let _lock = RunLock::acquire(&out)?;
    match study {
        Study::Link(study) => run_link_study(&study, &args, &out, shard, jobs),
        Study::Baselines(study) => {
            run_baseline_study(&study, &out, (args.render.path, jobs, shard))
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

/// Runs a baselines study (or one shard of it) under a progress bar, resumably. A whole run then
/// writes its results (partial ones when Ctrl-C interrupted it, exit 1); a shard leaves them to
/// the merge.
fn run_baseline_study(
    study: &BaselineStudy,
    out: &Path,
    (render, jobs, shard): (proto::RenderPath, usize, Option<Shard>),
) -> Result<()> {
    let stop = bus::on_stop_signal();
    let bar = bar_for(0);
    let started = std::time::Instant::now();
    let counts =
        baselines_run::run_part(study, out, (render, jobs, shard), &stop, |done, part| {
            bar.set_length(part);
            bar.set_position(done);
        })?;
    bar.finish_and_clear();
    let what = shard.map_or_else(|| "study".to_owned(), |s| format!("shard {s} of the study"));
    println!(
        "{what} {}: {} missions in this part: {} flown now, {} already recorded{}; {:.0} s wall \
         ({jobs} jobs)",
        study.name,
        counts.part,
        counts.ran,
        counts.recorded,
        if counts.damaged > 0 {
            format!(
                ", {} damaged records set aside and flown again",
                counts.damaged
            )
        } else {
            String::new()
        },
        started.elapsed().as_secs_f64(),
    );
    let interrupted = stop.load(Ordering::SeqCst);
    if let Some(shard) = shard {
        println!(
            "shard {shard} -> {} (merge every shard with `waggle study merge DIR… --out DIR`)",
            out.display()
        );
        if interrupted {
            bail!("interrupted: rerun the same command to resume the shard");
        }
        return Ok(());
    }
    let options = MergeOptions {
        partial: interrupted,
        mixed_hosts: false,
    };
    if let Merged::Baselines(results) = merge(&[out.to_path_buf()], out, options)? {
        print!(
            "{}",
            crate::harness::study::baselines::report(study, &results)
        );
    }
    println!("-> {}", out.join("report.md").display());
    if interrupted {
        bail!(
            "interrupted: {} of {} missions recorded (report written from them; rerun the same \
             command to resume)",
            counts.recorded + counts.ran,
            counts.part
        );
    }
    Ok(())
}

/// Runs a link study (or one shard of it) under a progress bar. A whole run then writes its
/// results (partial ones when Ctrl-C interrupted it, exit 1); a shard leaves them to the merge.
fn run_link_study(
    study: &StudyFile,
    args: &StudyArgs,
    out: &Path,
    shard: Option<Shard>,
    jobs: usize,
) -> Result<()> {
    let stop = bus::on_stop_signal();
    let cache = super::shard::open_cache(&args.render_cache)?;
    let bar = bar_for(0);
    let started = std::time::Instant::now();
    let counts = run_study_part(
        study,
        out,
        PartRun {
            render: args.render.path,
            jobs,
            shard,
            cache: cache.as_ref(),
        },
        &stop,
        |done, part| {
            bar.set_length(part);
            bar.set_position(done);
        },
    )?;
    bar.finish_and_clear();
    let what = shard.map_or_else(|| "study".to_owned(), |s| format!("shard {s} of the study"));
    println!(
        "{what} {}: {} trials in this part: {} ran now, {} already recorded{}; {} shared flight(s){}; \
         {:.0} s wall ({jobs} jobs)",
        study.name,
        counts.part,
        counts.ran,
        counts.recorded,
        if counts.damaged > 0 {
            format!(", {} damaged records set aside and rerun", counts.damaged)
        } else {
            String::new()
        },
        counts.shared_flights,
        if cache.is_some() {
            format!(
                " ({} from the render cache)",
                counts.shared_flights_from_cache
            )
        } else {
            String::new()
        },
        started.elapsed().as_secs_f64(),
    );
    let interrupted = stop.load(Ordering::SeqCst);
    if shard.is_none() {
        let options = MergeOptions {
            partial: interrupted,
            mixed_hosts: false,
        };
        if let Merged::Study(results) = merge(&[out.to_path_buf()], out, options)? {
            for r in &results {
                let (p, ci) = r.rate_cells();
                let at = if r.factors.is_empty() {
                    format!("{} = {:<8}", r.key, r.level)
                } else {
                    let f: Vec<String> =
                        r.factors.iter().map(|(k, v)| format!("{k}={v}")).collect();
                    f.join(" ")
                };
                println!(
                    "{:<7} {at} {:>4}/{:<4} P = {p:<6} CI {ci}",
                    r.modality, r.successes, r.trials
                );
            }
        }
        println!("-> {}", out.join("report.md").display());
    } else if !interrupted {
        println!(
            "-> {} (merge every shard with `waggle study merge DIR… --out DIR`)",
            out.display()
        );
    }
    if interrupted {
        bail!(
            "interrupted: rerun the same command to run the {} missing trials",
            counts.part - counts.recorded - counts.ran
        );
    }
    Ok(())
}
