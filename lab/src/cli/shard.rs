//! The shard, cluster and merge arguments shared by `waggle study` and `waggle trials`
//! ([`crate::harness::runs::shard`], [`crate::harness::runs::cluster`], [`crate::harness::study::merge`]).

use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::harness::flight::cache::RenderCache;
use crate::harness::runs::cluster::ClusterJob;
use crate::harness::study::StudyFile;
use crate::harness::study::merge::{MergeOptions, Merged, merge as merge_dirs};
use commands::shard::{ClusterArgs, MergeArgs, RenderCacheArg, ShardArgs};

/// The cache `arg` names, opened (created if absent), if one was given.
pub fn open_cache(arg: &RenderCacheArg) -> Result<Option<RenderCache>> {
    arg.render_cache
        .as_deref()
        .map(RenderCache::open)
        .transpose()
}

/// A study that job files can run: its name and its definition as written to `DIR/study.toml`.
pub trait JobStudy {
    fn job_name(&self) -> &str;
    fn job_toml(&self) -> Result<String>;
}

impl JobStudy for StudyFile {
    fn job_name(&self) -> &str {
        &self.name
    }
    fn job_toml(&self) -> Result<String> {
        toml::to_string(self).context("writing the study as TOML")
    }
}

impl JobStudy for crate::harness::study::baselines::BaselineStudy {
    fn job_name(&self) -> &str {
        &self.name
    }
    fn job_toml(&self) -> Result<String> {
        toml::to_string(self).context("writing the study as TOML")
    }
}

/// Writes the job files `cluster` asks for of `study` into `out` (and submits them with
/// `--submit`).
pub fn write_jobs(
    cluster: &ClusterArgs,
    study: &dyn JobStudy,
    out: &Path,
    shards: &ShardArgs,
    render: &super::RenderArg,
    cache: &RenderCacheArg,
) -> Result<()> {
    let n = shards
        .shard_count
        .context("--slurm and --kubernetes need --shard-count N")?;
    if n == 0 {
        bail!("--shard-count must be at least 1");
    }
    let mut extra = Vec::new();
    if let Some(v) = clap::ValueEnum::to_possible_value(&render.path)
        && render.path != proto::RenderPath::default()
    {
        extra.extend(["--render".to_owned(), v.get_name().to_owned()]);
    }
    if let Some(dir) = &cache.render_cache {
        extra.extend([
            "--render-cache".to_owned(),
            dir.to_string_lossy().into_owned(),
        ]);
    }
    let waggle = match &cluster.waggle {
        Some(w) => std::path::absolute(w).context("the --waggle path")?,
        None => crate::waggle_binary()?,
    };
    let job = ClusterJob {
        name: study.job_name().to_owned(),
        study_toml: study.job_toml()?,
        shards: n,
        partition: cluster.partition.clone(),
        time: cluster.time.clone(),
        mem: cluster.mem.clone(),
        cpus_per_task: cluster.cpus_per_task.max(1),
        waggle,
        extra,
    };
    if let Some(image) = &cluster.kubernetes {
        let path = job.write_kubernetes(out, image, &cluster.claim)?;
        println!(
            "kubectl apply -f {}; once complete: kubectl apply -f {}",
            path.display(),
            path.with_file_name("merge-job.yaml").display()
        );
    }
    if cluster.slurm {
        let submit = job.write_slurm(out)?;
        if cluster.submit {
            let status = crate::host_command("bash")
                .arg(&submit)
                .status()
                .with_context(|| format!("running {}", submit.display()))?;
            if !status.success() {
                bail!("{} failed ({status})", submit.display());
            }
        } else {
            println!("submit with: bash {}", submit.display());
        }
    }
    Ok(())
}

pub fn merge(args: &MergeArgs) -> Result<()> {
    let options = MergeOptions {
        partial: args.partial,
        mixed_hosts: args.allow_mixed_hosts,
    };
    match merge_dirs(&args.dirs, &args.out, options)? {
        Merged::Study(results) => {
            let trials: u64 = results.iter().map(|r| r.trials).sum();
            println!(
                "merged {} directories: {} points, {trials} trials -> {}",
                args.dirs.len(),
                results.len(),
                args.out.join("report.md").display()
            );
        }
        Merged::Baselines(results) => println!(
            "merged {} directories: {} case × arm points -> {}",
            args.dirs.len(),
            results.len(),
            args.out.join("report.md").display()
        ),
        Merged::Missions(t) => println!(
            "merged {} directories: {}/{} missions met the expected outcome -> {}",
            args.dirs.len(),
            t.tally.successes,
            t.tally.trials,
            args.out.join("trials.json").display()
        ),
        Merged::Trials(t) => println!(
            "merged {} directories: {}/{} trials succeeded -> {}",
            args.dirs.len(),
            t.tally.successes,
            t.tally.trials,
            args.out.join("trials.json").display()
        ),
    }
    Ok(())
}
