//! `observer-node`'s own arguments.

use proto::{Modality, ObserverId};

use crate::ArgList;

/// Default wall-clock grace after `clock{k}` before a packet that has not arrived is missing.
pub const DEFAULT_GRACE_MS: u64 = 10_000;

/// One observer process.
#[derive(Debug, Clone, PartialEq, Eq, clap::Args)]
pub struct ObserverArgs {
    /// This observer's id (O1, O2, …).
    #[arg(long)]
    pub id: ObserverId,
    /// The sensor it carries.
    #[arg(long, value_enum)]
    pub modality: Modality,
    /// Wall-clock time after `clock{k}` at which a packet that has not arrived is missing, ms.
    #[arg(long, default_value_t = DEFAULT_GRACE_MS)]
    pub grace_ms: u64,
}

impl ObserverArgs {
    /// The arguments that reproduce these.
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .value("--id", &self.id)
            .value("--modality", self.modality.as_str())
            .value("--grace-ms", self.grace_ms)
            .done()
    }
}
