//! Scheduler: task state, rounds, reception windows, the safety router, navigation, the virtual
//! service and mission end — as a pure, deterministic state machine advanced once per 40 ms
//! tick. No I/O: a runner (in-process or a Zenoh node) feeds it each tick's clock, ground-truth
//! observer positions, the decisions received and the live observers, and publishes what it
//! returns.
//!
//! # Driving it
//!
//! ```text
//! let mut s = Scheduler::new(SchedulerConfig::new(3, Modality::Events))?;
//! for k in 0.. {
//!     // after every live observer's status{k} (docs/DESIGN.md §3, step 4):
//!     let out = s.step(&SchedulerInput { clock: ClockTick::at(k), positions_m, decisions, alive })?;
//!     // publish, in this order: out.session (RoundReset before WindowOpen …),
//!     // out.broadcast_message() (the performer starts it at t_k), out.command() (sched/cmd{k});
//!     // record out.events. Stop after the tick with out.mission_end.is_some().
//! }
//! ```
//!
//! # Rounds
//!
//! Round 1 starts on the first tick. A round start resets every observer (`RoundReset`: offer
//! caches and parsers cleared) and opens the reception window (`WindowOpen`); the broadcast
//! starts [`Timing::broadcast_lead_ns`] later (5 s: round 1 broadcasts at 5.0 s) and advertises
//! the task state's offer for each of [`SchedulerConfig::offer_sites`] (A then B), so a depleted
//! site goes out as the withdrawal `q = 0, c = 0` (round 2 of the nominal case: `010000`,
//! `100111`). The events modality adds the acquisition preamble. How long the broadcast lasts
//! comes from the performer's own deterministic schedule ([`proto::broadcast`]).
//!
//! The window closes when every live observer has decided in the round, or else
//! [`Timing::window_margin_ns`] after the broadcast ends. Observers never move while it is
//! open. The round's decision deadline is [`Timing::decision_grace_ns`] (20 s) after it closed.
//!
//! # Decisions
//!
//! A decision is accepted when it comes from a roster observer, names the current round, was
//! made after the round's broadcast started and not after the tick's sim time, arrives no later
//! than the deadline, and is that observer's first in the round. `assignment: None` means the
//! observer decided that nothing is assigned to it. Anything else is a counted rejection
//! ([`DecisionReject`]), never an error. An observer that never decides (black input, dead
//! camera) simply stays home. Within a tick decisions are processed in sorted order, so
//! transport arrival order cannot change the outcome.
//!
//! # Safety router, navigation and service
//!
//! Accepted assignments queue ordered by (decision time, observer name). Once the window is
//! closed, the first in the queue flies a whole trip — home → site → 5 s service → home — and
//! only then the next one departs: one observer moves at a time and nobody is ever parked at a
//! site while another flies (the paper's 45.80 s for three round-2 trips is three serial trips).
//! Paths are planned at departure at the nominal altitude around the performer, the other
//! observers (at their ground-truth positions) and the other site, with ≥ 0.4 m clearance
//! between body centres (0.5 m from the performer), fastest path first; see [`navigation`]. Each path segment is a
//! rest-to-rest minimum-jerk blend with whole-tick duration, so every transition (arrival,
//! service end, return) falls on a tick. The return flies the outbound path backwards.
//!
//! **Concurrent mode** ([`SchedulerConfig::flights`] = [`FlightMode::Concurrent`](proto::FlightMode::Concurrent)): every queued
//! trip, in queue order, departs as soon as its whole reserved trajectory (out, service hover,
//! back, then home) keeps the 0.4 m clearance from every trip already in the air at every
//! instant ([`reservation`]: sampled every 20 ms with a bound on what two drones at ≤ 1 m/s can
//! do between samples); a blocked trip does not hold back later ones. Paths then avoid only the
//! observers on the ground. A trip that finds no work hovers out its reserved service time, so
//! a reservation checked once stays true. Rounds still settle only when every trip is home.
//!
//! On arrival the site's counter is checked: with work left, the 5 s service runs and then
//! decrements it ([`TaskState::serve`]); a site found depleted is logged as `NoWork` (no unit
//! counted) and the observer returns at once (sequential mode).
//!
//! # Round settling and mission end
//!
//! A round is *settled* once its window is closed, no trip is queued or flying, and either
//! every live observer has decided or the deadline has passed. Then, in this order:
//! - (b) nobody decided in the round → the mission ends ([`EndReason::NoDecision`](proto::EndReason::NoDecision); only-A:
//!   one offer, nobody can decide, so the mission ends at window close + 20 s, nobody departs);
//! - (a) it was the last round → the mission ends ([`EndReason::RoundsComplete`](proto::EndReason::RoundsComplete); every trip is
//!   back home by construction);
//! - (a′) no work is left anywhere → the mission ends ([`EndReason::AllWorkDone`](proto::EndReason::AllWorkDone));
//! - otherwise the next round starts on the same tick with offers from the task state as it is
//!   now (O2-black: O2 never decides, so round 1 settles after O1's and O3's trips and the
//!   deadline, and round 2 sends A `011001`).
//!
//! (c) A round that broadcasts nothing ([`SchedulerConfig::without_broadcast`]) ends the mission
//! [`Timing::idle_end_ns`] (15 s) after it started ([`EndReason::NoBroadcast`](proto::EndReason::NoBroadcast)); decisions in
//! such a round are rejected. Optionally, [`SchedulerConfig::time_limit_ns`] ends the mission
//! ([`EndReason::TimeLimit`](proto::EndReason::TimeLimit)); anything in flight then hovers where it is.
//!
//! Session controls on mission end: `WindowClose` (if still open), then `MissionEnd`.

pub mod config;
pub mod error;
pub mod log;
pub mod navigation;
pub mod reservation;
pub mod scheduler;
pub mod trajectory;

pub use config::{FlightLimits, SchedulerConfig, Timing};
pub use error::{ConfigError, NavError, SchedulerError};
pub use log::{DecisionReject, EventKind, LogEvent, PoseReject};
pub use proto::Kinematics;
pub use scheduler::{
    BroadcastPlan, DecisionNotice, Scheduler, SchedulerInput, Stats, TickOutput, observer_positions,
};
pub use trajectory::Leg;

#[doc(no_inline)]
pub use proto::TaskState;
