//! `waggle bench`: one case per camera render path, side by side.

use clap::Args;
use proto::{Modality, RenderPath};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Built-in case name or case file to run.
    #[arg(default_value = "nominal-3")]
    pub case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    pub modality: Option<Modality>,
    /// The render paths to compare, the first the baseline the others are divided by.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [RenderPath::Damage, RenderPath::Raster])]
    pub paths: Vec<RenderPath>,
    /// Runs per render path (they alternate: damage, raster, damage, …).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Directory for each run's directory and bench.json.
    #[arg(long, default_value = "waggle-bench")]
    pub out: PathBuf,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    pub bin_dir: Option<PathBuf>,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Print bench.json instead of the table.
    #[arg(long)]
    pub json: bool,
}
