//! `waggle mission`: a whole case flown in one process.

use crate::common::Policy;
use clap::Args;
use proto::Receiver;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct MissionArgs {
    #[arg(help = run_format::case::case_arg_help())]
    pub case: String,
    /// Observer sensor modality (`ideal` is the ground-truth baseline).
    #[arg(long, value_enum, default_value_t = Receiver::Events)]
    pub modality: Receiver,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    #[command(flatten)]
    pub flights: crate::common::CaseOverrides,
    /// Allocation policy: `waggle` (decode the broadcast) or `fixed` (the no-communication
    /// baseline: observer i always takes offer site i mod sites).
    #[arg(long, value_enum, default_value_t)]
    pub policy: Policy,
    #[command(flatten)]
    pub perturb: crate::common::PerturbArgs,
    #[command(flatten)]
    pub receivers: crate::common::MissionReceiversArg,
    /// Seed of the perturbation's draws.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write DIR/summary.json, DIR/observers.json (every token, frame, decision and track
    /// sample, as `waggle run` writes it) and DIR/metrics.json here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Events modality: write each observer's events, as its camera produced them (before the
    /// sensor link's loss), to DIR/<observer>.raw (Prophesee EVT 3.0, readable by Metavision
    /// tools, `waggle decode --events` and the perception crate's `event_symbols` example).
    #[arg(long, value_name = "DIR")]
    pub events_raw: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}
