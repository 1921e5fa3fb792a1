//! `waggle report`: report.md rebuilt from a run or sweep directory.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// A run directory (`waggle run --out DIR`) or a sweep directory (`waggle sweep --out DIR`).
    pub dir: PathBuf,
    /// Skip the sensor-comparison figure (it re-simulates ≈ 30 s of one camera, ≈ 20 s wall).
    #[arg(long)]
    pub no_sensor_figure: bool,
}
