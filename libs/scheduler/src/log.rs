//! The scheduler's record: every round, window, broadcast, decision, flight and service with
//! its sim time, in the order it happened.

use proto::{ObserverId, Offer, Site};

use proto::EndReason;

/// Why a decision was not accepted. Each is counted, none is an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DecisionReject {
    /// The name is not in the roster.
    UnknownObserver,
    /// The decision names another round than the current one.
    WrongRound,
    /// The observer already decided in this round (the first decision counts).
    Duplicate,
    /// `decided_ns` lies after the tick's sim time.
    FromTheFuture,
    /// `decided_ns` lies before the round's broadcast started (or nothing was sent yet).
    BeforeBroadcast,
    /// It arrived after the round's decision deadline.
    AfterDeadline,
    /// The round broadcast nothing, so nothing can have been decided.
    NothingBroadcast,
    /// The mission has ended.
    MissionOver,
}

/// Why a pose input was ignored (counted only, not logged: a bad feed would flood the log).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PoseReject {
    UnknownObserver,
    NonFinite,
}

/// What happened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EventKind {
    RoundStarted {
        round: u32,
        /// Offers the round will send (empty: no broadcast).
        offers: Vec<Offer>,
    },
    WindowOpened {
        round: u32,
    },
    BroadcastStarted {
        round: u32,
        offers: Vec<Offer>,
        acquisition: bool,
        end_ns: u64,
    },
    WindowClosed {
        round: u32,
    },
    DeadlinePassed {
        round: u32,
    },
    DecisionAccepted {
        observer: ObserverId,
        round: u32,
        assignment: Option<Site>,
        decided_ns: u64,
    },
    DecisionRejected {
        observer: ObserverId,
        round: u32,
        reason: DecisionReject,
    },
    /// The safety router queued an assigned observer.
    TripQueued {
        observer: ObserverId,
        site: Site,
        round: u32,
    },
    Departure {
        observer: ObserverId,
        site: Site,
        round: u32,
        decided_ns: u64,
        /// The planned path (home first, site last).
        waypoints: Vec<[i64; 3]>,
    },
    ArrivalAtSite {
        observer: ObserverId,
        site: Site,
    },
    ServiceStarted {
        observer: ObserverId,
        site: Site,
        /// Units at the site before this service.
        remaining: u32,
    },
    ServiceEnded {
        observer: ObserverId,
        site: Site,
        /// Units left after this service.
        remaining: u32,
    },
    /// The site was depleted on arrival: no service, straight back home.
    NoWork {
        observer: ObserverId,
        site: Site,
    },
    ReturnedHome {
        observer: ObserverId,
    },
    MissionEnded {
        reason: EndReason,
    },
}

/// One logged event.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogEvent {
    pub t_ns: u64,
    pub kind: EventKind,
}

/// Waypoints in the log are micrometres (integers), so the log is `Eq` and prints exactly.
pub fn waypoints_um(path: &[[f64; 3]]) -> Vec<[i64; 3]> {
    path.iter()
        .map(|p| p.map(|v| (v * 1e6).round() as i64))
        .collect()
}
