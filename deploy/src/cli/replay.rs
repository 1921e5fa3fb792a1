//! `waggle replay DIR/session.mcap [--json]`: the event receivers re-run from a recording
//! ([`crate::eval::replay`]).

use anyhow::{Result, bail};

use crate::eval::replay::{print_replay, replay_recording};
use commands::replay::ReplayArgs;
use run_eval::summary::print_json;

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
