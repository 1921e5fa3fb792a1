//! `waggle replay`: the event receivers re-run from a recording.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recording (`DIR/session.mcap`, or the run directory).
    pub path: PathBuf,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
}
