//! `scheduler-node`'s own arguments.

use proto::{FlightMode, FrameCheck, Modality};

use crate::ArgList;

/// The scheduler process of a session.
#[derive(Debug, Clone, PartialEq, clap::Args)]
pub struct SchedulerArgs {
    /// The observers' sensor (the event modality adds the acquisition preamble).
    #[arg(long, value_enum)]
    pub modality: Modality,
    /// Sites advertised each round, in order, comma-separated; empty: no broadcast.
    #[arg(long, default_value = "A,B")]
    pub offers: String,
    /// Number of rounds.
    #[arg(long, default_value_t = 2)]
    pub rounds: u32,
    /// Initial work units of the sites named, `A=24,B=40` (default: `max(1, N−1)` at A and
    /// `N+1` at B).
    #[arg(long)]
    pub work: Option<String>,
    /// Broadcasts a round may fly: its offers again while a live observer is undecided.
    #[arg(long, default_value_t = 1)]
    pub max_broadcasts: u32,
    /// Hard limit on simulated time, seconds.
    #[arg(long)]
    pub time_limit_s: Option<f64>,
    /// Safety router: one trip at a time, or overlapping trips on checked reservations.
    #[arg(long, value_enum, default_value_t = FlightMode::default())]
    pub flights: FlightMode,
    /// The check every frame carries after its payload (its length sets the windows).
    #[arg(long, value_enum, default_value_t = FrameCheck::None)]
    pub frame_check: FrameCheck,
}

impl SchedulerArgs {
    /// The arguments that reproduce these.
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .value("--modality", self.modality.as_str())
            .value("--offers", &self.offers)
            .value("--rounds", self.rounds)
            // Only when the case sets it, so every other command line stays as it was.
            .opt("--work", self.work.as_deref())
            // Only when asked for, so the paper's compose lines stay as they were.
            .opt(
                "--max-broadcasts",
                (self.max_broadcasts != 1).then_some(self.max_broadcasts),
            )
            .opt("--time-limit-s", self.time_limit_s)
            .value("--flights", self.flights)
            .opt(
                "--frame-check",
                (self.frame_check != FrameCheck::None).then_some(self.frame_check),
            )
            .done()
    }
}
