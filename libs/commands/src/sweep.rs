//! `waggle sweep`: every case × modality as `waggle run`, audited and reported.

use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Which sensor modalities to run (each case only in the modalities it applies to).
    #[arg(long, value_enum, default_value_t = SweepModality::Both)]
    pub modality: SweepModality,
    /// Sweep directory: one subdirectory per run, report.md, figures/, sweep.json.
    #[arg(long, default_value = "waggle-sweep")]
    pub out: PathBuf,
    /// Runs in parallel (default: half the cores, at least 1 — one mission already keeps two
    /// cores busy, so 1 on a 2-core machine).
    #[arg(long, value_parser = crate::common::parse_jobs)]
    pub jobs: Option<usize>,
    /// Only these cases (built-in names or case files); repeatable. Default: the paper's seven
    /// functional cases (add e.g. `--case eight-observers`).
    #[arg(long = "case")]
    pub cases: Vec<String>,
    /// Skip the sensor-comparison figure (≈ 20 s wall).
    #[arg(long)]
    pub no_sensor_figure: bool,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
}

/// Which sensor modalities a sweep runs (a command-line selection).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SweepModality {
    Rgb,
    Events,
    Both,
}
