//! `waggle report DIR`: rebuild `report.md` and its figures from a run or sweep directory
//! ([`crate::report`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use crate::report::{gather, print_outcomes, verdict, write_report};

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// A run directory (`waggle run --out DIR`) or a sweep directory (`waggle sweep --out DIR`).
    dir: PathBuf,
    /// Skip the sensor-comparison figure (it re-simulates ≈ 30 s of one camera, ≈ 20 s wall).
    #[arg(long)]
    no_sensor_figure: bool,
}

pub fn run(args: ReportArgs) -> Result<()> {
    let (entries, manifest) = gather(&args.dir)?;
    let path = write_report(
        &args.dir,
        &entries,
        manifest.as_ref(),
        !args.no_sensor_figure,
    )?;
    print_outcomes(&entries);
    println!("report: {}", path.display());
    verdict(&entries)
}
