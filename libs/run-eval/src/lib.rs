//! `run-eval`: what a run left behind, read back, shared by the launcher (`deploy`) and the lab
//! so that neither climbs into the other. It links neither MuJoCo nor Zenoh.
//!
//! - [`summary`]: the mission summary's annotations, its checks against a case's expected
//!   outcome and provenance rules, and the text both binaries print of it.
//! - [`recording`]: a session recording's raw messages scanned back, with the recorder's
//!   account of the packets it did not keep.
//! - [`audit`]: the paper's tables, provenance audit and expected outcome from a recording alone.
//! - [`sensor`]: what a run directory records of an event sensor model.
//! - [`child`]: how a child process's end is labelled, and signalling one.

#![forbid(unsafe_code)]

pub mod audit;
pub mod child;
pub mod recording;
pub mod sensor;
pub mod summary;
