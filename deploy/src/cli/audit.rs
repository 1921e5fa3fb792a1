//! `waggle audit DIR|FILE.mcap [--json]`: the paper's tables from a recording alone
//! ([`run_eval::audit`]).

use anyhow::{Result, bail};

use commands::audit::AuditArgs;
use run_eval::audit::{audit_recording, print_audit};
use run_eval::summary::print_json;

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
