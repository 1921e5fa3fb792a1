//! Shards of a run's trials (`--shard K/N`, `--shard-from-env`), the render cache, cluster job files and the merge of shards, shared by `waggle trials` and `waggle study`.
//!
//! A run's trials are numbered in one global order; shard K takes the K-th of N contiguous, balanced blocks of it.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::ops::Range;
use std::path::PathBuf;
use std::str::FromStr;

/// `--shard K/N` or `--shard-from-env`.
#[derive(Debug, Clone, Args)]
pub struct ShardArgs {
    /// Run only shard K of N (1 ≤ K ≤ N): the K-th of N disjoint, balanced blocks of the trials
    /// (each shard flies the shared flights it needs). Merge the N directories with
    /// `waggle study merge`.
    #[arg(long, value_name = "K/N", conflicts_with = "shard_from_env")]
    pub shard: Option<Shard>,
    /// Take the shard from a Slurm job array (SLURM_ARRAY_TASK_ID counted from
    /// SLURM_ARRAY_TASK_MIN, N = SLURM_ARRAY_TASK_COUNT) or a Kubernetes Indexed Job
    /// (JOB_COMPLETION_INDEX, with N from --shard-count).
    #[arg(long)]
    pub shard_from_env: bool,
    /// The number of shards: for --shard-from-env under Kubernetes, and for --slurm and
    /// --kubernetes (array tasks, completions).
    #[arg(long, value_name = "N")]
    pub shard_count: Option<u64>,
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

/// `--slurm` / `--kubernetes IMAGE` and the resources of their tasks.
#[derive(Debug, Clone, Args)]
pub struct ClusterArgs {
    /// Instead of running: write DIR/slurm/array.sbatch (the shards as a job array),
    /// DIR/slurm/merge.sbatch (the merge, a job depending on the array) and DIR/slurm/submit.sh
    /// (submits both); needs --shard-count N.
    #[arg(long, requires = "shard_count")]
    pub slurm: bool,
    /// Instead of running: write a Kubernetes Indexed Job running this image (with `waggle` on
    /// its PATH) and its merge Job, DIR/kubernetes/*.yaml; needs --shard-count N. DIR must be
    /// the path where every pod mounts --claim.
    #[arg(long, value_name = "IMAGE", requires = "shard_count")]
    pub kubernetes: Option<String>,
    /// The ReadWriteMany PersistentVolumeClaim the Kubernetes pods mount at DIR.
    #[arg(long, default_value = "waggle-studies")]
    pub claim: String,
    /// Slurm partition of every task (default: the cluster's default).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit per task (Slurm syntax).
    #[arg(long, default_value = "04:00:00")]
    pub time: String,
    /// Memory per task (Slurm syntax: 8G).
    #[arg(long, default_value = "8G")]
    pub mem: String,
    /// CPUs per task (also each shard's --jobs; at least 1).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..))]
    pub cpus_per_task: u32,
    /// With --slurm: submit at once (runs DIR/slurm/submit.sh).
    #[arg(long, requires = "slurm")]
    pub submit: bool,
    /// The waggle the tasks run, a path every node sees (default: this one; a relocatable
    /// bundle's `bin/waggle` when run from one, see deploy/relocatable.sh).
    #[arg(long, value_name = "PATH")]
    pub waggle: Option<PathBuf>,
}

/// `waggle study merge DIR… --out DIR`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The shards' output directories (of one `waggle study` or `waggle trials` run).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Where the merged results go.
    #[arg(long)]
    pub out: PathBuf,
    /// Write results from whatever trials are recorded (otherwise every trial must be).
    #[arg(long)]
    pub partial: bool,
    /// Merge records made on different CPU models or renderers (the result may then differ
    /// from a run on one machine kind).
    #[arg(long)]
    pub allow_mixed_hosts: bool,
}

/// Shard `k` (1-based) of `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub k: u64,
    pub n: u64,
}

impl Shard {
    /// Checks 1 ≤ k ≤ n.
    pub fn new(k: u64, n: u64) -> Result<Self> {
        if n == 0 || k == 0 || k > n {
            bail!("shard {k}/{n}: K must be between 1 and N (and N at least 1)");
        }
        Ok(Self { k, n })
    }

    /// This shard's block of the global trial order `0..total`.
    pub fn range(self, total: u64) -> Range<u64> {
        let at = |k: u64| (u128::from(k) * u128::from(total) / u128::from(self.n)) as u64;
        at(self.k - 1)..at(self.k)
    }

    /// The shard of a Slurm array task (`SLURM_ARRAY_TASK_ID` counted from
    /// `SLURM_ARRAY_TASK_MIN`, N = `SLURM_ARRAY_TASK_COUNT`) or of a Kubernetes Indexed Job
    /// (`JOB_COMPLETION_INDEX` from 0, N = `count`, which such a job does not export).
    pub fn from_env(count: Option<u64>) -> Result<Self> {
        Self::from_vars(|name| std::env::var(name).ok(), count)
    }

    fn from_vars(var: impl Fn(&str) -> Option<String>, count: Option<u64>) -> Result<Self> {
        let num = |name: &str| -> Result<Option<u64>> {
            var(name)
                .map(|v| {
                    v.trim()
                        .parse::<u64>()
                        .with_context(|| format!("{name}={v:?} is not a whole number"))
                })
                .transpose()
        };
        if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
            let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let n = match (num("SLURM_ARRAY_TASK_COUNT")?, count) {
                (Some(n), Some(c)) if n != c => bail!(
                    "SLURM_ARRAY_TASK_COUNT={n} but --shard-count {c}: submit the array as 0-{}",
                    c - 1
                ),
                (Some(n), _) | (None, Some(n)) => n,
                (None, None) => bail!("SLURM_ARRAY_TASK_ID is set but not SLURM_ARRAY_TASK_COUNT"),
            };
            let k = id.checked_sub(min).with_context(|| {
                format!("SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}")
            })?;
            return Self::new(k + 1, n).context("from the Slurm array variables");
        }
        if let Some(index) = num("JOB_COMPLETION_INDEX")? {
            let n = count.context(
                "JOB_COMPLETION_INDEX is set (Kubernetes Indexed Job): give the job's completions \
                 as --shard-count N",
            )?;
            return Self::new(index + 1, n).context("from JOB_COMPLETION_INDEX");
        }
        bail!(
            "--shard-from-env: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor \
             JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set"
        )
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

impl FromStr for Shard {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        let (k, n) = s
            .split_once('/')
            .with_context(|| format!("shard {s:?}: write it as K/N, e.g. 2/8"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<u64>()
                .with_context(|| format!("shard {s:?}: {v:?} is not a whole number"))
        };
        Self::new(parse(k)?, parse(n)?)
    }
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

impl ClusterArgs {
    /// Whether job files were asked for.
    pub fn wanted(&self) -> bool {
        self.slurm || self.kubernetes.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_are_disjoint_balanced_and_cover_everything() {
        for total in [0u64, 1, 7, 100, 1001] {
            for n in 1..=9 {
                let ranges: Vec<_> = (1..=n)
                    .map(|k| Shard::new(k, n).unwrap().range(total))
                    .collect();
                assert_eq!(ranges[0].start, 0);
                assert_eq!(ranges.last().unwrap().end, total);
                for w in ranges.windows(2) {
                    assert_eq!(w[0].end, w[1].start);
                }
                let sizes: Vec<u64> = ranges.iter().map(|r| r.end - r.start).collect();
                assert!(sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1);
            }
        }
    }

    #[test]
    fn parsing_and_the_environment() {
        assert_eq!("2/8".parse::<Shard>().unwrap(), Shard { k: 2, n: 8 });
        for bad in ["0/4", "5/4", "2", "a/4", "1/0"] {
            let e = format!("{:#}", bad.parse::<Shard>().unwrap_err());
            assert!(e.contains(bad) || e.contains("between"), "{bad}: {e}");
        }
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| (*v).to_owned())
            }
        };
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_MIN", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(Shard::from_vars(slurm, None).unwrap(), Shard { k: 3, n: 4 });
        let k8s = env(&[("JOB_COMPLETION_INDEX", "0")]);
        assert_eq!(
            Shard::from_vars(k8s, Some(3)).unwrap(),
            Shard { k: 1, n: 3 }
        );
        let e = Shard::from_vars(env(&[("JOB_COMPLETION_INDEX", "0")]), None).unwrap_err();
        assert!(format!("{e:#}").contains("--shard-count"), "{e:#}");
        let e = Shard::from_vars(env(&[]), None).unwrap_err();
        assert!(format!("{e:#}").contains("SLURM_ARRAY_TASK_ID"), "{e:#}");
        let over = env(&[("JOB_COMPLETION_INDEX", "3")]);
        assert!(Shard::from_vars(over, Some(3)).is_err());
    }
}
