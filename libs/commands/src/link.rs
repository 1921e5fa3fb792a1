//! `waggle link`: one broadcast flown in one process and decoded by each observer.

use crate::common::{FrameCheckArg, parse_bits6, parse_viewpoint};
use clap::Args;
use proto::scene::Placement;
use proto::{Receiver, Rectification};

#[derive(Debug, Args)]
pub struct LinkArgs {
    /// Number of observers (1..=8).
    #[arg(long, default_value_t = 3)]
    pub observers: usize,
    /// Observer sensor modality.
    #[arg(long, value_enum, default_value_t = Receiver::Ideal)]
    pub modality: Receiver,
    /// Six-bit payload to broadcast, e.g. 011010; repeat for back-to-back offers. Without any,
    /// the performer only hovers (a control: nothing may be decoded).
    #[arg(long = "payload", value_parser = parse_bits6)]
    pub payloads: Vec<u8>,
    /// Events modality: skip the acquisition sweep before the first offer (a control).
    #[arg(long)]
    pub no_acquisition: bool,
    /// Seconds to hover when no payload is given.
    #[arg(long, default_value_t = 30.0)]
    pub hover_s: f64,
    /// Black out this observer's camera from start-up (e.g. O2); repeatable.
    #[arg(long)]
    pub black: Vec<String>,
    /// Place an observer at AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M from the performer's hover
    /// point (azimuth from the gesture plane's normal, towards +x), aimed at it; repeat for up
    /// to 8 observers. Replaces the built-in formation of --observers.
    #[arg(long = "viewpoint", value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, allow_hyphen_values = true)]
    pub viewpoints: Vec<Placement>,
    /// Viewpoint rectification of the receivers' trajectories before template matching.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    pub rectify: Rectification,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    /// The event sensors' model: a preset and `events.*` terms (events modality only; other
    /// groups are modelled by `waggle trials`).
    #[command(flatten)]
    pub perturb: crate::common::PerturbArgs,
    /// Seed of the event sensors' noise draws (with --sensor-preset/--perturb): observer i
    /// draws from stream i of it, as in `waggle mission --seed`.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Events modality: write each observer's events to DIR/<observer>.raw (Prophesee EVT
    /// 3.0, readable by Metavision tools and `waggle decode --events`).
    #[arg(long, value_name = "DIR")]
    pub events_raw: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub check: FrameCheckArg,
    /// Print machine-readable JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}
