//! Shards: the K-th of N disjoint, balanced parts of a run's trials (`--shard K/N`, or
//! `--shard-from-env` under a Slurm job array or a Kubernetes Indexed Job).
//!
//! A run's trials are numbered in one global order (point by point, trial index within a point);
//! shard K takes a contiguous block of that order, and the N blocks differ in size by at most
//! one trial. Contiguous blocks keep the points (and so the flights) a shard needs few: a shard
//! flies only the shared flights of the levels its block touches. A trial's seed depends only on
//! the run's seed and its index, never on which shard runs it.

use std::ops::Range;
use std::str::FromStr;

use anyhow::{Context, Result, bail};

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

/// The trials of `points` × `per_point` that `shard` (all when none) runs, per point, and how
/// many they are.
pub fn part_of(
    points: usize,
    per_point: u64,
    shard: Option<Shard>,
) -> (Vec<(usize, Vec<u64>)>, u64) {
    let total = points as u64 * per_point;
    let range = shard.map_or(0..total, |s| s.range(total));
    let parts = split(points, per_point, range);
    let n = parts.iter().map(|(_, v)| v.len() as u64).sum();
    (parts, n)
}

/// The trials `0..per_point` of each of `points` points that fall in `range` of the global order
/// (point-major): for each point with any, its index and its trial indices.
pub fn split(points: usize, per_point: u64, range: Range<u64>) -> Vec<(usize, Vec<u64>)> {
    (0..points)
        .filter_map(|p| {
            let first = p as u64 * per_point;
            let lo = range.start.max(first);
            let hi = range.end.min(first + per_point);
            (lo < hi).then(|| (p, (lo - first..hi - first).collect()))
        })
        .collect()
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
    fn split_follows_the_point_major_order() {
        // 3 points of 4 trials; shard 2/3 holds global trials 4..8: point 1 whole.
        assert_eq!(split(3, 4, 4..8), vec![(1, vec![0, 1, 2, 3])]);
        assert_eq!(split(3, 4, 2..7), vec![(0, vec![2, 3]), (1, vec![0, 1, 2])]);
        assert!(split(3, 4, 5..5).is_empty());
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
