//! `waggle audit DIR|FILE.mcap [--json]`: the paper's tables from a recording alone
//! ([`run_eval::audit`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use run_eval::audit::{audit_recording, print_audit};
use run_eval::summary::print_json;

#[derive(Debug, Args)]
pub struct AuditArgs {
    /// A run directory (holding session.mcap) or an MCAP file.
    path: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: AuditArgs) -> Result<()> {
    let report = audit_recording(&args.path)?;
    if args.json {
        print_json(&report)?;
    } else {
        print_audit(&report);
    }
    if !report.pass {
        bail!("audit failed: {}", report.reasons.join("; "));
    }
    Ok(())
}
