//! Shards: the K-th of N disjoint, balanced parts of a run's trials (`--shard K/N`, or
//! `--shard-from-env` under a Slurm job array or a Kubernetes Indexed Job).
//!
//! A run's trials are numbered in one global order (point by point, trial index within a point);
//! shard K takes a contiguous block of that order, and the N blocks differ in size by at most
//! one trial. Contiguous blocks keep the points (and so the flights) a shard needs few: a shard
//! flies only the shared flights of the levels its block touches. A trial's seed depends only on
//! the run's seed and its index, never on which shard runs it.

use std::ops::Range;

pub use commands::shard::Shard;

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
    fn split_follows_the_point_major_order() {
        // 3 points of 4 trials; shard 2/3 holds global trials 4..8: point 1 whole.
        assert_eq!(split(3, 4, 4..8), vec![(1, vec![0, 1, 2, 3])]);
        assert_eq!(split(3, 4, 2..7), vec![(0, vec![2, 3]), (1, vec![0, 1, 2])]);
        assert!(split(3, 4, 5..5).is_empty());
    }
}
