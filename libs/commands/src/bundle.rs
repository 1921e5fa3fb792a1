//! `waggle bundle`: what one host of a session needs, in a new directory.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct BundleArgs {
    /// The compose file (`waggle compose … --out FILE`), beside its secrets directory.
    pub file: PathBuf,
    /// The host the bundle is for: one the file places nodes or the router on.
    #[arg(long)]
    pub host: String,
    /// A new directory to write: the compose file under its own name, and beside it the
    /// credentials of that host's processes only.
    #[arg(long)]
    pub out: PathBuf,
}
