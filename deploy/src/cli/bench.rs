//! `waggle bench`: a case run once per render path in one invocation, printed side by side
//! ([`crate::launch::bench`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use proto::{Modality, RenderPath};

use crate::launch::bench::{BenchOptions, print_report, run_bench};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Built-in case name or case file to run.
    #[arg(default_value = "nominal-3")]
    case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    modality: Option<Modality>,
    /// The render paths to compare, the first the baseline the others are divided by.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [RenderPath::Damage, RenderPath::Raster])]
    paths: Vec<RenderPath>,
    /// Runs per render path (they alternate: damage, raster, damage, …).
    #[arg(long, default_value_t = 1)]
    repeat: usize,
    /// Directory for each run's directory and bench.json.
    #[arg(long, default_value = "waggle-bench")]
    out: PathBuf,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    bin_dir: Option<PathBuf>,
    /// No progress bars.
    #[arg(long)]
    quiet: bool,
    /// Print bench.json instead of the table.
    #[arg(long)]
    json: bool,
}

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
