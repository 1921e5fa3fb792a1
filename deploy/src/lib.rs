//! `deploy`: the Waggle operations as a library, behind the thin `waggle` binary. It never links
//! MuJoCo: what needs the simulator (missions, trials, studies, link, decode, reports, sweeps)
//! is the `lab` crate, whose `waggle-lab` binary `waggle` hands those commands to
//! ([`cli::lab`]).
//!
//! - [`launch`]: `waggle run` (the supervisor: node processes over Zenoh, faults, progress,
//!   summary), `waggle up`, the router and `waggle bench`.
//! - [`compose`]: a session's compose file, its placement on hosts and its bundles.
//! - [`eval`]: what is read back from a run — the recording audit, the replay of the event
//!   receivers and the shared mission summary.
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
pub mod launch;

pub use compose_file::fault;
pub use run_format::{case, run_dir};
