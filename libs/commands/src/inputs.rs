//! `waggle inputs`: one trial's sensor inputs, as its receivers get them, with the ground truth.

use crate::common::{parse_bits6, parse_viewpoint};
use clap::Args;
use proto::scene::Placement;
use proto::{Modality, Rectification};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct InputsArgs {
    /// The broadcast: six-bit payloads flown back to back, comma-separated (e.g. 011010,100111).
    #[arg(long, value_delimiter = ',', value_parser = parse_bits6, required = true)]
    pub link: Vec<u8>,
    /// Number of observers in the built-in formation (1..=8).
    #[arg(long, default_value_t = 3)]
    pub observers: usize,
    /// Place observers at AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M instead (repeat, up to 8).
    #[arg(long = "viewpoint", value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, allow_hyphen_values = true)]
    pub viewpoints: Vec<Placement>,
    /// The observers' sensor.
    #[arg(long, value_enum)]
    pub modality: Modality,
    /// Seed of the run, as `waggle trials --seed`.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Which trial of the run (its seed derives from --seed and this index, as in `waggle
    /// trials`: trial k here is trial k there).
    #[arg(long, default_value_t = 0)]
    pub trial: u64,
    #[command(flatten)]
    pub perturb: crate::common::PerturbArgs,
    /// A real camera's background laid over the event sensor's noise (as `waggle trials`).
    #[arg(long = "real-noise", value_name = "FILE")]
    pub real_noise: Option<String>,
    /// The stretch of --real-noise where nothing moved, START_S:END_S from its first event.
    #[arg(long = "real-noise-static", value_name = "START_S:END_S",
          value_parser = crate::sensor_fit::parse_window, requires = "real_noise")]
    pub real_noise_static: Option<(f64, f64)>,
    /// Fly the acquisition sweep before the first offer: `true` or `false` (default: only for
    /// event cameras).
    #[arg(long, value_name = "BOOL")]
    pub acquisition: Option<bool>,
    /// Viewpoint rectification Waggle's receivers would use (handed to the consumer).
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    pub rectify: Rectification,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    /// Where the stream goes: a file, or `-` for standard output. The format is the plug-in
    /// pipe's (length-prefixed frames: a JSON header, then raw event records or pixels); the
    /// Python package reads it (`waggle.read_inputs`).
    #[arg(long, default_value = "-")]
    pub out: PathBuf,
}
