//! The shard, cluster and merge arguments shared by `waggle study` and `waggle trials`
//! ([`crate::harness::shard`], [`crate::harness::cluster`], [`crate::harness::study_merge`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::harness::cluster::ClusterJob;
use crate::harness::render_cache::RenderCache;
use crate::harness::shard::Shard;
use crate::harness::study::StudyFile;
use crate::harness::study_merge::{MergeOptions, Merged, merge as merge_dirs};

/// `--shard K/N` or `--shard-from-env`.
#[derive(Debug, Clone, Args)]
pub struct ShardArgs {
    /// Run only shard K of N (1 ≤ K ≤ N): the K-th of N disjoint, balanced blocks of the trials
    /// (each shard flies the shared flights it needs). Merge the N directories with
    /// `waggle study merge`.
    #[arg(long, value_name = "K/N", conflicts_with = "shard_from_env")]
    shard: Option<Shard>,
    /// Take the shard from a Slurm job array (SLURM_ARRAY_TASK_ID counted from
    /// SLURM_ARRAY_TASK_MIN, N = SLURM_ARRAY_TASK_COUNT) or a Kubernetes Indexed Job
    /// (JOB_COMPLETION_INDEX, with N from --shard-count).
    #[arg(long)]
    shard_from_env: bool,
    /// The number of shards: for --shard-from-env under Kubernetes, and for --slurm and
    /// --kubernetes (array tasks, completions).
    #[arg(long, value_name = "N")]
    shard_count: Option<u64>,
}

impl ShardArgs {
    /// The shard to run, if any.
    pub fn shard(&self) -> Result<Option<Shard>> {
        if self.shard_from_env {
            return Shard::from_env(self.shard_count).map(Some);
        }
        Ok(self.shard)
    }

    /// Whether a shard was asked for.
    pub fn given(&self) -> bool {
        self.shard.is_some() || self.shard_from_env
    }
}

/// `--render-cache DIR`: flights kept on disk and shared by the processes of one host.
#[derive(Debug, Clone, Args)]
pub struct RenderCacheArg {
    /// Keep rendered flights in DIR, shared by every run on this host (e.g. a study's shards
    /// on one node): a flight another run has rendered, or is rendering, is read instead of
    /// flown again. Entries are addressed by the flight, this binary and the host kind, checked
    /// on reading (a damaged one is flown again) and never evicted: a node-local scratch
    /// directory suits it. Results are identical with or without it.
    #[arg(long, value_name = "DIR")]
    pub render_cache: Option<PathBuf>,
}

impl RenderCacheArg {
    /// The cache, opened (created if absent), if one was given.
    pub fn open(&self) -> Result<Option<RenderCache>> {
        self.render_cache
            .as_deref()
            .map(RenderCache::open)
            .transpose()
    }
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

impl JobStudy for crate::harness::baselines::BaselineStudy {
    fn job_name(&self) -> &str {
        &self.name
    }
    fn job_toml(&self) -> Result<String> {
        toml::to_string(self).context("writing the study as TOML")
    }
}

/// `--slurm` / `--kubernetes IMAGE` and the resources of their tasks.
#[derive(Debug, Clone, Args)]
pub struct ClusterArgs {
    /// Instead of running: write DIR/slurm/array.sbatch (the shards as a job array),
    /// DIR/slurm/merge.sbatch (the merge, a job depending on the array) and DIR/slurm/submit.sh
    /// (submits both); needs --shard-count N.
    #[arg(long, requires = "shard_count")]
    slurm: bool,
    /// Instead of running: write a Kubernetes Indexed Job running this image (with `waggle` on
    /// its PATH) and its merge Job, DIR/kubernetes/*.yaml; needs --shard-count N. DIR must be
    /// the path where every pod mounts --claim.
    #[arg(long, value_name = "IMAGE", requires = "shard_count")]
    kubernetes: Option<String>,
    /// The ReadWriteMany PersistentVolumeClaim the Kubernetes pods mount at DIR.
    #[arg(long, default_value = "waggle-studies")]
    claim: String,
    /// Slurm partition of every task (default: the cluster's default).
    #[arg(long)]
    partition: Option<String>,
    /// Time limit per task (Slurm syntax).
    #[arg(long, default_value = "04:00:00")]
    time: String,
    /// Memory per task (Slurm syntax: 8G).
    #[arg(long, default_value = "8G")]
    mem: String,
    /// CPUs per task (also each shard's --jobs; at least 1).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..))]
    cpus_per_task: u32,
    /// With --slurm: submit at once (runs DIR/slurm/submit.sh).
    #[arg(long, requires = "slurm")]
    submit: bool,
    /// The waggle the tasks run, a path every node sees (default: this one; a relocatable
    /// bundle's `bin/waggle` when run from one, see deploy/relocatable.sh).
    #[arg(long, value_name = "PATH")]
    waggle: Option<PathBuf>,
}

impl ClusterArgs {
    /// Whether job files were asked for.
    pub fn wanted(&self) -> bool {
        self.slurm || self.kubernetes.is_some()
    }

    /// Writes the job files of `study` into `out` (and submits them with `--submit`).
    pub fn write(
        &self,
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
        let waggle = match &self.waggle {
            Some(w) => std::path::absolute(w).context("the --waggle path")?,
            None => crate::waggle_binary()?,
        };
        let job = ClusterJob {
            name: study.job_name().to_owned(),
            study_toml: study.job_toml()?,
            shards: n,
            partition: self.partition.clone(),
            time: self.time.clone(),
            mem: self.mem.clone(),
            cpus_per_task: self.cpus_per_task.max(1),
            waggle,
            extra,
        };
        if let Some(image) = &self.kubernetes {
            let path = job.write_kubernetes(out, image, &self.claim)?;
            println!(
                "kubectl apply -f {}; once complete: kubectl apply -f {}",
                path.display(),
                path.with_file_name("merge-job.yaml").display()
            );
        }
        if self.slurm {
            let submit = job.write_slurm(out)?;
            if self.submit {
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
}

/// `waggle study merge DIR… --out DIR`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The shards' output directories (of one `waggle study` or `waggle trials` run).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Where the merged results go.
    #[arg(long)]
    out: PathBuf,
    /// Write results from whatever trials are recorded (otherwise every trial must be).
    #[arg(long)]
    partial: bool,
    /// Merge records made on different CPU models or renderers (the result may then differ
    /// from a run on one machine kind).
    #[arg(long)]
    allow_mixed_hosts: bool,
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
