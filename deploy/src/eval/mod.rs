//! Evaluation of what a run left behind: the shared mission summary ([`summary`]), reading a
//! recording ([`recording`]), the audit from a recording alone ([`audit`]) and the replay of the
//! event receivers from a recording ([`replay`]), with the event packets regenerated from the
//! recorded sensor input when the recording kept that instead ([`regenerate`]). The session report (`report.md`, which
//! re-simulates its sensor figure) is the `lab` crate's.

pub mod audit;
pub mod recording;
pub mod regenerate;
pub mod replay;
pub mod summary;
