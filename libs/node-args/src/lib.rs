//! The command-line contract between the composer (`waggle compose`/`up`/`run`) and the node
//! processes: each node's own arguments are one typed struct here, flattened into the node's
//! clap parser and built by the composer, so the two cannot drift apart.
//!
//! - [`ObserverArgs`] (`observer-node`), [`CameraArgs`] with its [`SensorArgs`]
//!   (`sim-node camera`), [`SchedulerArgs`] (`scheduler-node`), [`RecorderArgs`] and the
//!   launcher's [`RecorderOutput`] (`recorder-node`); `sim-node run` and `performer-node` have
//!   no arguments of their own;
//! - [`NodeCommand`]: one node of a session, its binary and its own arguments; [`NodeLine`] adds
//!   the access-control list the composer gives it, as a compose file stores them
//!   ([`NodeLine::to_args`]) and reads them back ([`NodeLine::parse`]).
//!
//! [`init_logging`] is every node's one log set-up.
//!
//! The session-wide options every node takes (`--session`, endpoints, credentials) are
//! `bus::NodeArgs`, added by the launcher.

mod camera;
mod command;
mod logging;
mod observer;
mod performer;
mod recorder;
mod scheduler;

pub use camera::{
    CameraArgs, CameraThrottle, DEFAULT_ROS2_ROUTER, Ros2Source, SensorArgs, preset_perturbation,
};
pub use command::{NodeArgsError, NodeCommand, NodeLine};
pub use logging::init_logging;
pub use observer::{DEFAULT_GRACE_MS, ObserverArgs};
pub use performer::PerformerArgs;
pub use recorder::{RecorderArgs, RecorderOutput};
pub use scheduler::SchedulerArgs;

/// `--flag value` pairs and bare flags, for the `to_args` of each struct.
pub(crate) struct ArgList(Vec<String>);

impl ArgList {
    pub(crate) fn new() -> Self {
        Self(Vec::new())
    }

    pub(crate) fn value(&mut self, flag: &str, value: impl ToString) -> &mut Self {
        self.0.push(flag.to_string());
        self.0.push(value.to_string());
        self
    }

    pub(crate) fn opt(&mut self, flag: &str, value: Option<impl ToString>) -> &mut Self {
        if let Some(v) = value {
            self.value(flag, v);
        }
        self
    }

    pub(crate) fn flag(&mut self, flag: &str, on: bool) -> &mut Self {
        if on {
            self.0.push(flag.to_string());
        }
        self
    }

    pub(crate) fn done(&mut self) -> Vec<String> {
        std::mem::take(&mut self.0)
    }
}
