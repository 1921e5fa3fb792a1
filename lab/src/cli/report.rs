//! `waggle report DIR`: rebuild `report.md` and its figures from a run or sweep directory
//! ([`crate::report`]).

use anyhow::Result;

use crate::report::{gather, print_outcomes, verdict, write_report};
use commands::report::ReportArgs;

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
