//! `run-format`: the files a Waggle run reads and writes, typed.
//!
//! - [`case`]: case files — which mission to fly, which faults to inject, what the outcome
//!   must be (the built-in cases of `deploy/cases/` and TOML files of the same shape).
//! - [`run_dir`]: run directories — the mission and run summaries (`summary.json`), the
//!   observers' records (`observers.json`), the session record (`session.json`), the sweep
//!   manifest (`sweep.json`), the audit report and the run lock. One set of serde structs is
//!   shared by the writer (the launcher) and every reader; the JSON layout is the on-disk format.
//! - [`study_file`]: link study files — their fields, parse and the checks that need neither
//!   simulator nor file system ([`study`] holds the built-in ones' texts).
//! - [`trial_record`]: the lab's per-trial record files (`<point>/trials/NNNNNN.json`), their
//!   checksum and the checks a resumed or merged run makes of them.
//! - [`render_cache`]: the lab's render cache entries (`<key>.renders`) as bytes, encoded and
//!   decoded with every check, lengths checked before anything is allocated.
//!
//! Errors are typed ([`case::CaseError`], [`run_dir::RunDirError`], [`run_dir::lock::LockError`],
//! [`study_file::StudyFileError`], [`trial_record::TrialRecordError`],
//! [`render_cache::RenderCacheError`]) and name the file or field at fault.

#![forbid(unsafe_code)]

pub mod case;
pub mod link_out;
pub mod render_cache;
pub mod run_dir;
pub mod study;
pub mod study_file;
pub mod trial_record;
