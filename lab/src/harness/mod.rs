//! In-process harnesses: the simulator flown in this process, by purpose.
//!
//! - [`flight`]: what every harness flies — the performer's broadcast as physics references,
//!   the air it flies in, a flight rendered once and kept (on disk, shared by a host's
//!   processes), the cameras' raw output files.
//! - [`mission`]: a whole case in one process, its metrics, its observers, and seeded trials of
//!   whole missions.
//! - [`link`]: one broadcast decoded by each observer, and decode success against viewpoint.
//! - [`trials`]: seeded perturbed trials of one condition on a flight rendered once, on a
//!   thread pool.
//! - [`study`]: study files (link studies and baselines), their runs, merges, reports and
//!   figures.
//! - [`runs`]: what makes a trials or study directory resumable, shardable and mergeable:
//!   per-trial records, run files, shards and cluster job files.
//! - [`decode`]: recordings in — real or recorded camera files decoded by a receiver, and PNG
//!   frames converted to events.

pub mod decode;
pub mod flight;
pub mod link;
pub mod mission;
pub mod runs;
pub mod study;
pub mod trials;
