//! `waggle up`: the nodes a compose file places on this host.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct UpArgs {
    /// The compose file (`waggle compose … --out FILE`).
    pub file: PathBuf,
    /// Start only the nodes placed on this host (default: every node, on this machine). The
    /// simulator's host supervises the session and writes the summary; the router's host runs
    /// the router.
    #[arg(long)]
    pub host: Option<String>,
    #[command(flatten)]
    pub launch: super::run::LaunchArgs,
}
