//! Evaluation that needs the launcher's libraries: the replay of the event receivers from a
//! recording ([`replay`]), with the event packets regenerated from the recorded sensor input
//! when the recording kept that instead ([`regenerate`]). The summary, the recording scan and
//! the audit are the `run-eval` library's, shared with the lab; the session report
//! (`report.md`, which re-simulates its sensor figure) is the `lab` crate's.

pub mod regenerate;
pub mod replay;
