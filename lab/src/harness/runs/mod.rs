//! What makes a trials or study directory resumable, shardable and mergeable: per-trial
//! records written as each trial ends ([`records`]), the run's own files (`run.json`,
//! `cost.json`: [`files`]), the records gathered over shard directories for a merge
//! ([`merge_records`]), shards of a run's trials ([`shard`]) and cluster job files
//! ([`cluster`]).

pub mod cluster;
pub mod files;
pub mod merge_records;
pub mod records;
pub mod shard;
