//! `waggle sweep`: every case × modality as its own `waggle run`, then the report
//! ([`crate::sweep`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use crate::sweep::{SweepModality, SweepOptions, run_sweep};

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Which sensor modalities to run (each case only in the modalities it applies to).
    #[arg(long, value_enum, default_value_t = SweepModality::Both)]
    modality: SweepModality,
    /// Sweep directory: one subdirectory per run, report.md, figures/, sweep.json.
    #[arg(long, default_value = "waggle-sweep")]
    out: PathBuf,
    /// Runs in parallel (default: half the cores, at least 1 — one mission already keeps two
    /// cores busy, so 1 on a 2-core machine).
    #[arg(long, value_parser = super::parse_jobs)]
    jobs: Option<usize>,
    /// Only these cases (built-in names or case files); repeatable. Default: the paper's seven
    /// functional cases (add e.g. `--case eight-observers`).
    #[arg(long = "case")]
    cases: Vec<String>,
    /// Skip the sensor-comparison figure (≈ 20 s wall).
    #[arg(long)]
    no_sensor_figure: bool,
    #[command(flatten)]
    render: super::RenderArg,
}

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
