//! What crosses the scheduler's boundary each tick: the runner's input (clock, ground-truth
//! positions, decisions, live observers) and the output it publishes (setpoints, session
//! controls, the broadcast, the log).

use std::collections::{BTreeMap, BTreeSet};

use proto::sched::{Broadcast, ObserverSetpoint, SchedCommand, SessionControl};
use proto::{ClockTick, Decision, ObserverId, SimState, Site};

use crate::log::LogEvent;
use crate::scheduler::broadcast::BroadcastPlan;
use proto::EndReason;

/// The part of an observer's decision the scheduler acts on.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct DecisionNotice {
    pub observer: ObserverId,
    pub round: u32,
    /// `None`: the observer decided that nothing is assigned to it.
    pub assignment: Option<Site>,
    pub decided_ns: u64,
}

impl From<&Decision> for DecisionNotice {
    fn from(d: &Decision) -> Self {
        Self {
            observer: d.observer.clone(),
            round: d.round,
            assignment: d.assignment,
            decided_ns: d.decided_ns,
        }
    }
}

/// The observers' positions from a ground-truth `sim/state` sample (the performer and any name
/// that is not a valid observer id are skipped; the scheduler ignores unknown observers itself).
pub fn observer_positions(state: &SimState) -> BTreeMap<ObserverId, [f64; 3]> {
    state
        .drones
        .iter()
        .filter(|d| d.name != "performer")
        .filter_map(|d| {
            ObserverId::new(d.name.as_str())
                .ok()
                .map(|id| (id, d.pos_m))
        })
        .collect()
}

/// Everything the scheduler learns in one tick.
#[derive(Debug, Clone, Copy)]
pub struct SchedulerInput<'a> {
    pub clock: ClockTick,
    /// Ground-truth observer positions at `t_k` (missing entries: the last known, else home).
    pub positions_m: &'a BTreeMap<ObserverId, [f64; 3]>,
    /// Decisions received during this tick, in any order.
    pub decisions: &'a [DecisionNotice],
    /// Observers whose processes are alive (liveliness token present).
    pub alive: &'a BTreeSet<ObserverId>,
}

/// What the scheduler publishes after one tick.
#[derive(Debug, Clone, PartialEq)]
pub struct TickOutput {
    pub tick: u64,
    pub now_ns: u64,
    /// A broadcast starting now.
    pub broadcast: Option<BroadcastPlan>,
    /// One setpoint per observer, roster order, for sim time `now_ns` (the simulator
    /// extrapolates it over the next tick with the feed-forward terms).
    pub setpoints: Vec<ObserverSetpoint>,
    /// Session controls, stamped `now_ns`, in the order they must be applied.
    pub session: Vec<SessionControl>,
    /// Everything logged during this tick.
    pub events: Vec<LogEvent>,
    /// Set on the tick the mission ended.
    pub mission_end: Option<EndReason>,
}

impl TickOutput {
    /// `sched/cmd` for this tick.
    pub fn command(&self) -> SchedCommand {
        SchedCommand {
            tick: self.tick,
            setpoints: self.setpoints.clone(),
            mission_end: self.mission_end.is_some(),
        }
    }

    /// `sched/broadcast` for this tick, if a broadcast starts.
    pub fn broadcast_message(&self) -> Option<Broadcast> {
        self.broadcast.as_ref().map(|b| b.to_proto(self.tick))
    }
}
