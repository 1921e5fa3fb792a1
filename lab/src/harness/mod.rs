//! In-process harnesses: a whole mission in one process ([`mission`]), the link bench
//! ([`link`]), the performer's flight as physics references ([`performer_flight`]) and the
//! offline PNG → events converter ([`convert`]), decode success against viewpoint
//! ([`viewpoints`]), seeded perturbed trials on a flight rendered once ([`trials`],
//! [`trial_observer`], [`rendered_flight`], kept on disk by [`render_cache`]) and studies of them ([`study`]); per-trial records that make runs
//! resumable ([`records`], [`run_files`]), shards and their merge ([`shard`], [`study_run`],
//! [`study_merge`]) and cluster job files ([`cluster`]).

pub mod air;
pub mod baselines;
pub mod baselines_run;
pub mod cluster;
pub mod convert;
pub mod decode;
pub mod figure;
pub mod link;
pub mod merge_records;
pub mod mission;
pub mod mission_metrics;
pub mod mission_observer;
pub mod mission_options;
pub mod mission_trials;
pub mod performer_flight;
pub mod pool;
pub mod raw;
pub mod records;
pub mod render_cache;
pub mod rendered_flight;
pub mod run_files;
pub mod shard;
pub mod study;
pub mod study_merge;
pub mod study_report;
pub mod study_run;
pub mod trial_observer;
pub mod trials;
pub mod trials_out;
pub mod vary;
pub mod viewpoints;
