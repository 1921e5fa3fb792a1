//! `waggle replay DIR/session.mcap [--json]`: the event receivers re-run from a recording
//! ([`crate::eval::replay`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use crate::eval::replay::{print_replay, replay_recording};
use run_eval::summary::print_json;

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recording (`DIR/session.mcap`, or the run directory).
    path: PathBuf,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: ReplayArgs) -> Result<()> {
    let report = replay_recording(&args.path)?;
    if args.json {
        print_json(&report)?;
    } else {
        print_replay(&report);
    }
    if !report.all_matched {
        bail!("replay does not reproduce the live decodes");
    }
    Ok(())
}
