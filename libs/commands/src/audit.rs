//! `waggle audit`: the paper's tables, provenance audit and expected outcome from a recording.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct AuditArgs {
    /// A run directory (holding session.mcap) or an MCAP file.
    pub path: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}
