//! Evaluation of what a run left behind: the shared mission summary ([`summary`]), reading a
//! recording ([`recording`]), the audit from a recording alone ([`audit`]), the replay of the
//! event receivers from a recording ([`replay`]) and the session report ([`report`]).

pub mod audit;
pub mod recording;
pub mod replay;
pub mod report;
pub mod summary;
