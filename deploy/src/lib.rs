//! `deploy`: the Waggle launcher as a library, behind the thin `waggle` binary.
//!
//! - [`launch`]: `waggle run` (the supervisor: node processes over Zenoh, faults, progress,
//!   summary) and `waggle sweep` (every case × modality as its own `waggle run`).
//! - [`harness`]: in-process harnesses — a whole mission in one process, the link bench, the
//!   performer's flight and the PNG → events converter.
//! - [`eval`]: what is read back from a run — the recording audit, the replay of the event
//!   receivers, the shared mission summary and the session report.
//! - [`run_dir`]: the typed run-directory formats (`summary.json`, `observers.json`,
//!   `session.json`, `sweep.json`, the audit report), shared by the writer and every reader.
//! - [`case`]: case files.
//!
//!   Both are the `run-format` library, re-exported here under their old paths.
//! - [`cli`]: one small adapter per `waggle` command (arguments in, library call, output).

#![forbid(unsafe_code)]

pub mod cli;
pub mod compose;
pub mod eval;
pub mod fault;
pub mod harness;
pub mod launch;

pub use run_format::{case, run_dir};
