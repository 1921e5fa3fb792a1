//! `observer-node`'s own arguments.

use proto::{FrameCheck, Modality, ObserverId};
use receiver_plugin::PluginSpec;

use crate::ArgList;

/// Default wall-clock grace after `clock{k}` before a packet that has not arrived is missing.
///
/// A last resort only: a dropped packet is announced by its camera, a dead camera by its
/// liveliness token, so in a fault-free or fault-injected run the grace never decides what a tick
/// contains. It only unblocks the lockstep when a live camera goes silent. It is a minute, not
/// seconds, because a loaded machine (a CI runner, a paused VM) can stall a healthy camera for
/// several seconds, and a verdict taken then would change the run.
pub const DEFAULT_GRACE_MS: u64 = 60_000;

/// One observer process.
#[derive(Debug, Clone, PartialEq, Eq, clap::Args)]
pub struct ObserverArgs {
    /// This observer's id (O1, O2, …).
    #[arg(long)]
    pub id: ObserverId,
    /// The sensor it carries.
    #[arg(long, value_enum)]
    pub modality: Modality,
    /// Wall-clock time after `clock{k}` at which a packet that has not arrived (and that its
    /// camera did not say it dropped) is missing, ms: the last resort for a silent camera.
    #[arg(long, default_value_t = DEFAULT_GRACE_MS)]
    pub grace_ms: u64,
    /// A plug-in receiver instead of Waggle's (`python:MODULE:CLASS`), run in a worker process
    /// this observer starts and feeds only its own sensor's input.
    #[arg(long, value_name = "python:MODULE:CLASS")]
    pub receiver: Option<PluginSpec>,
    /// The plug-in's wall-clock limit over the whole session, ms (none when not given).
    #[arg(long, value_name = "MS", requires = "receiver")]
    pub plugin_time_limit_ms: Option<u64>,
    /// The seed the plug-in is told (the session's sensor seed).
    #[arg(long, value_name = "SEED", requires = "receiver")]
    pub plugin_seed: Option<u64>,
    /// The check the session's frames carry (the observer releases only frames that pass it).
    #[arg(long, value_enum, default_value_t = FrameCheck::None)]
    pub frame_check: FrameCheck,
}

impl ObserverArgs {
    /// The arguments that reproduce these.
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .value("--id", &self.id)
            .value("--modality", self.modality.as_str())
            .value("--grace-ms", self.grace_ms)
            .opt("--receiver", self.receiver.as_ref())
            .opt("--plugin-time-limit-ms", self.plugin_time_limit_ms)
            .opt("--plugin-seed", self.plugin_seed)
            .opt(
                "--frame-check",
                (self.frame_check != FrameCheck::None).then_some(self.frame_check),
            )
            .done()
    }
}
