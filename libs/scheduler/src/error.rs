//! Typed errors. Bad *inputs* from observers (unknown names, wrong rounds, …) are not errors:
//! they are counted rejections, see [`crate::log::DecisionReject`].

use proto::{ObserverId, Site};

/// A case configuration the scheduler cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error("observer count {observers} is outside 1..={max}", max = proto::scene::MAX_OBSERVERS)]
    ObserverCount { observers: usize },
    #[error("a mission needs at least one round")]
    NoRounds,
    #[error(
        "max_broadcasts = {max_broadcasts}: a round flies 1 to {max} broadcasts",
        max = proto::sched::MAX_ROUND_BROADCASTS
    )]
    MaxBroadcasts { max_broadcasts: u32 },
    #[error("{offers} offers per round exceed the broadcast limit")]
    TooManyOffers { offers: usize },
    #[error("flight limits must be finite and positive, with at least 3 ring points")]
    FlightLimits,
    #[error("the virtual service must last longer than zero")]
    ZeroService,
    #[error("gesture configuration rejected: {0}")]
    Gesture(#[from] proto::ScheduleError),
}

/// Why no path could be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NavError {
    #[error("non-finite waypoint {0:?}")]
    NonFinite([f64; 3]),
    #[error("no path from {from_m:?} to {to_m:?} keeps the clearance")]
    NoPath { from_m: [f64; 3], to_m: [f64; 3] },
    #[error("segment timing overflows sim time")]
    TimeOverflow,
}

/// Why a tick could not be processed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SchedulerError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("clock tick {tick} carries sim time {sim_time_ns} ns, not tick · 40 ms")]
    BadClock { tick: u64, sim_time_ns: u64 },
    #[error("tick {tick} does not follow tick {previous}")]
    TickOutOfOrder { previous: u64, tick: u64 },
    #[error("sim time overflows u64")]
    TimeOverflow,
    #[error("broadcast could not be scheduled: {0}")]
    Broadcast(#[from] proto::ScheduleError),
    #[error("no safe path for {observer} to {site}: {source}")]
    Navigation {
        observer: ObserverId,
        site: Site,
        source: NavError,
    },
}
