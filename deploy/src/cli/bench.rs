//! `waggle bench`: a case run once per render path in one invocation, printed side by side
//! ([`crate::launch::bench`]).

use anyhow::{Result, bail};

use crate::launch::bench::{BenchOptions, print_report, run_bench};
use commands::bench::BenchArgs;

pub fn run(args: BenchArgs) -> Result<()> {
    let report = run_bench(&BenchOptions {
        case: args.case,
        modality: args.modality,
        paths: args.paths,
        repeat: args.repeat,
        out: args.out,
        bin_dir: args.bin_dir,
        quiet: args.quiet,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_report(&report);
    }
    if !report.digests_equal {
        bail!("two runs of one renderer published different sensor bytes");
    }
    if let Some(run) = report.runs.iter().find(|r| !r.pass) {
        bail!(
            "the {} run in {} did not meet the case's expected outcome",
            run.render,
            run.dir.display()
        );
    }
    Ok(())
}
