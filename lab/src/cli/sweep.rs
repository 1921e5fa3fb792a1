//! `waggle sweep`: every case × modality as its own `waggle run`, then the report
//! ([`crate::sweep`]).

use anyhow::Result;

use crate::sweep::{SweepOptions, run_sweep};
use commands::sweep::SweepArgs;

pub fn run(args: SweepArgs) -> Result<()> {
    run_sweep(&SweepOptions {
        modality: args.modality,
        out: args.out,
        jobs: args.jobs,
        cases: args.cases,
        render: args.render.path,
        no_sensor_figure: args.no_sensor_figure,
    })
}
