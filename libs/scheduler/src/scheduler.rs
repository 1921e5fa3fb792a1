//! The scheduler state machine, advanced once per 40 ms tick (rules in the crate docs).

use std::collections::{BTreeMap, BTreeSet};

use proto::ScheduledOffer;
use proto::clock::tick_end_ns;
use proto::scene::{observer_home_m, observer_home_yaw_rad};
use proto::sched::{Broadcast, ObserverSetpoint, SchedCommand, SessionControl, SessionEvent};
use proto::{ClockTick, Decision, ObserverId, Offer, SimState, Site, TaskState};

use crate::config::SchedulerConfig;
use crate::error::{ConfigError, SchedulerError};
use crate::log::{EndReason, EventKind, LogEvent, PoseReject, RejectReason, waypoints_um};
use crate::navigation::{obstacles, plan_path};
use crate::reservation::{Reservation, admit};
use crate::trajectory::Leg;
use proto::{FlightMode, Kinematics};

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
pub struct TickInput<'a> {
    pub clock: ClockTick,
    /// Ground-truth observer positions at `t_k` (missing entries: the last known, else home).
    pub positions_m: &'a BTreeMap<ObserverId, [f64; 3]>,
    /// Decisions received during this tick, in any order.
    pub decisions: &'a [DecisionNotice],
    /// Observers whose processes are alive (liveliness token present).
    pub alive: &'a BTreeSet<ObserverId>,
}

/// A broadcast the performer must fly, starting at `start_ns` (= the sim time of the tick that
/// emitted it).
#[derive(Debug, Clone, PartialEq)]
pub struct BroadcastPlan {
    pub round: u32,
    /// In transmission order (A then B in the paper).
    pub offers: Vec<Offer>,
    /// Events modality: the acquisition sweep and its quiet precede the first offer.
    pub acquisition: bool,
    pub start_ns: u64,
    /// When the performer's schedule ends (end of the last final NULL hold).
    pub end_ns: u64,
    /// Per offer: payload, start and final-NULL start, exactly as the performer will fly them.
    pub scheduled: Vec<ScheduledOffer>,
}

impl BroadcastPlan {
    /// The wire form for `sched/broadcast` (`start_ns` is the sim time of `tick`).
    pub fn to_proto(&self, tick: u64) -> Broadcast {
        Broadcast {
            tick,
            round: self.round,
            start_ns: self.start_ns,
            offers: self.offers.clone(),
            acquisition: self.acquisition,
        }
    }
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

/// Counters for the summary.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    /// Completed services (virtual work units).
    pub work_units: u32,
    /// Completed services per observer, in order, with their round.
    pub services: BTreeMap<ObserverId, Vec<(u32, Site)>>,
    pub departures: u32,
    /// Arrivals at a depleted site.
    pub no_work_arrivals: u32,
    pub rejected_decisions: BTreeMap<RejectReason, u64>,
    pub rejected_poses: BTreeMap<PoseReject, u64>,
}

impl Stats {
    pub fn rejections(&self) -> u64 {
        self.rejected_decisions.values().sum()
    }
}

#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
struct Queued {
    decided_ns: u64,
    observer: ObserverId,
    site: Site,
    round: u32,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    Outbound,
    Service {
        until_ns: u64,
    },
    /// Concurrent mode: no work at the site, but the trip hovers out its reserved service time
    /// so that every reservation checked against it stays true.
    Hold {
        until_ns: u64,
    },
    Return(Leg),
}

#[derive(Debug, Clone, PartialEq)]
struct Trip {
    index: usize,
    site: Site,
    round: u32,
    outbound: Leg,
    phase: Phase,
    /// The whole trip as committed at departure (what the concurrent router checks).
    reservation: Reservation,
}

#[derive(Debug, Clone, PartialEq)]
struct Round {
    number: u32,
    start_ns: u64,
    offers: Vec<Offer>,
    /// `None`: this round broadcasts nothing.
    broadcast_due_ns: Option<u64>,
    broadcast: Option<(u64, u64)>,
    window_open: bool,
    deadline_ns: Option<u64>,
    deadline_logged: bool,
    decisions: BTreeMap<ObserverId, DecisionNotice>,
}

/// The scheduler. See the crate docs for the rules and the per-tick protocol.
#[derive(Debug, Clone)]
pub struct Scheduler {
    config: SchedulerConfig,
    ids: Vec<ObserverId>,
    homes_m: Vec<[f64; 3]>,
    yaws_rad: Vec<f64>,
    positions_m: Vec<[f64; 3]>,
    task: TaskState,
    last_tick: Option<u64>,
    round: Option<Round>,
    queue: BTreeSet<Queued>,
    /// Trips in the air, in departure order (at most one in sequential mode).
    active: Vec<Trip>,
    ended: Option<(EndReason, u64)>,
    frozen: Option<Vec<ObserverSetpoint>>,
    stats: Stats,
    log: Vec<LogEvent>,
    broadcasts: Vec<BroadcastPlan>,
}

impl Scheduler {
    pub fn new(config: SchedulerConfig) -> Result<Self, SchedulerError> {
        config.validate()?;
        proto::broadcast(0, &[0], true, &config.gesture).map_err(ConfigError::from)?;
        let n = config.observers;
        let task =
            TaskState::initial(n).map_err(|_| ConfigError::ObserverCount { observers: n })?;
        let homes_m: Vec<[f64; 3]> = (0..n).map(|i| observer_home_m(i, n)).collect();
        Ok(Self {
            ids: (0..n).map(ObserverId::from_index).collect(),
            yaws_rad: homes_m.iter().map(|h| observer_home_yaw_rad(*h)).collect(),
            positions_m: homes_m.clone(),
            homes_m,
            task,
            config,
            last_tick: None,
            round: None,
            queue: BTreeSet::new(),
            active: Vec::new(),
            ended: None,
            frozen: None,
            stats: Stats::default(),
            log: Vec::new(),
            broadcasts: Vec::new(),
        })
    }

    pub fn config(&self) -> &SchedulerConfig {
        &self.config
    }

    /// Roster order: `O1 … On`.
    pub fn observers(&self) -> &[ObserverId] {
        &self.ids
    }

    pub fn homes_m(&self) -> &[[f64; 3]] {
        &self.homes_m
    }

    pub fn task(&self) -> &TaskState {
        &self.task
    }

    /// The current round (1-based; 0 before the first tick).
    pub fn round(&self) -> u32 {
        self.round.as_ref().map_or(0, |r| r.number)
    }

    /// Reason and sim time of the mission end, once ended.
    pub fn ended(&self) -> Option<(EndReason, u64)> {
        self.ended
    }

    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// The whole log so far.
    pub fn log(&self) -> &[LogEvent] {
        &self.log
    }

    /// Every broadcast sent so far.
    pub fn broadcasts(&self) -> &[BroadcastPlan] {
        &self.broadcasts
    }

    /// Advances to tick `input.clock.tick`. Ticks must increase (gaps are allowed: pending
    /// transitions are then stamped with their planned times).
    pub fn step(&mut self, input: &TickInput<'_>) -> Result<TickOutput, SchedulerError> {
        let tick = input.clock.tick;
        let now = tick_end_ns(tick).ok_or(SchedulerError::TimeOverflow)?;
        if now != input.clock.sim_time_ns {
            return Err(SchedulerError::BadClock {
                tick,
                sim_time_ns: input.clock.sim_time_ns,
            });
        }
        if let Some(previous) = self.last_tick
            && tick <= previous
        {
            return Err(SchedulerError::TickOutOfOrder { previous, tick });
        }
        self.last_tick = Some(tick);
        let mut out = TickOutput {
            tick,
            now_ns: now,
            broadcast: None,
            setpoints: Vec::new(),
            session: Vec::new(),
            events: Vec::new(),
            mission_end: None,
        };
        self.ingest_positions(input.positions_m);
        if self.ended.is_none() {
            if self.round.is_none() {
                self.start_round(1, now, &mut out);
            }
            self.advance_trips(now, &mut out)?;
            self.ingest_decisions(input.decisions, now, &mut out);
            self.advance_rounds(now, input.alive, &mut out)?;
            if let Some(limit) = self.config.time_limit_ns
                && now >= limit
                && self.ended.is_none()
            {
                self.end(EndReason::TimeLimit, now, &mut out);
            }
        } else {
            self.ingest_decisions(input.decisions, now, &mut out);
        }
        out.setpoints = match &self.frozen {
            Some(f) => f.clone(),
            None => self.setpoints_at(now),
        };
        Ok(out)
    }

    /// Every observer's setpoint at `t_ns` under the current plan. After `step(k)` this is
    /// exact for any `t_ns` in `[t_k, t_{k+1}]` (all plan transitions fall on tick times), so a
    /// caller may sample it per physics step instead of extrapolating.
    pub fn setpoints_at(&self, t_ns: u64) -> Vec<ObserverSetpoint> {
        if let Some(f) = &self.frozen {
            return f.clone();
        }
        (0..self.ids.len())
            .map(|i| {
                let k = match self.active.iter().find(|trip| trip.index == i) {
                    Some(trip) => match &trip.phase {
                        Phase::Outbound => trip.outbound.state_at(t_ns),
                        Phase::Service { .. } | Phase::Hold { .. } => {
                            Kinematics::rest(trip.site.position_m())
                        }
                        Phase::Return(leg) => leg.state_at(t_ns),
                    },
                    None => Kinematics::rest(self.homes_m[i]),
                };
                ObserverSetpoint::new(self.ids[i].clone(), k, self.yaws_rad[i])
            })
            .collect()
    }

    fn index_of(&self, id: &ObserverId) -> Option<usize> {
        self.ids.iter().position(|x| x == id)
    }

    fn emit(&mut self, out: &mut TickOutput, t_ns: u64, kind: EventKind) {
        let e = LogEvent { t_ns, kind };
        self.log.push(e.clone());
        out.events.push(e);
    }

    fn control(out: &mut TickOutput, event: SessionEvent) {
        out.session.push(SessionControl {
            tick: out.tick,
            stamp_ns: out.now_ns,
            event,
        });
    }

    fn ingest_positions(&mut self, positions: &BTreeMap<ObserverId, [f64; 3]>) {
        for (id, p) in positions {
            let reject = match self.index_of(id) {
                None => Some(PoseReject::UnknownObserver),
                Some(_) if p.iter().any(|v| !v.is_finite()) => Some(PoseReject::NonFinite),
                Some(i) => {
                    self.positions_m[i] = *p;
                    None
                }
            };
            if let Some(r) = reject {
                *self.stats.rejected_poses.entry(r).or_default() += 1;
            }
        }
    }

    fn start_round(&mut self, number: u32, now: u64, out: &mut TickOutput) {
        let offers: Vec<Offer> = self
            .config
            .offer_sites
            .iter()
            .map(|s| self.task.offer(*s))
            .collect();
        let broadcast_due_ns =
            (!offers.is_empty()).then(|| now.saturating_add(self.config.timing.broadcast_lead_ns));
        self.round = Some(Round {
            number,
            start_ns: now,
            offers: offers.clone(),
            broadcast_due_ns,
            broadcast: None,
            window_open: true,
            deadline_ns: None,
            deadline_logged: false,
            decisions: BTreeMap::new(),
        });
        self.emit(
            out,
            now,
            EventKind::RoundStarted {
                round: number,
                offers,
            },
        );
        Self::control(out, SessionEvent::RoundReset { round: number });
        Self::control(out, SessionEvent::WindowOpen { round: number });
        self.emit(out, now, EventKind::WindowOpened { round: number });
    }

    fn end(&mut self, reason: EndReason, now: u64, out: &mut TickOutput) {
        if let Some(r) = self.round.as_mut()
            && r.window_open
        {
            r.window_open = false;
            let round = r.number;
            Self::control(out, SessionEvent::WindowClose { round });
            self.emit(out, now, EventKind::WindowClosed { round });
        }
        Self::control(out, SessionEvent::MissionEnd);
        self.emit(out, now, EventKind::MissionEnded { reason });
        out.mission_end = Some(reason);
        // Whatever was in flight hovers where its setpoint is now.
        let hold: Vec<ObserverSetpoint> = self
            .setpoints_at(now)
            .into_iter()
            .map(|mut s| {
                s.kin.vel_mps = [0.0; 3];
                s.kin.acc_mps2 = [0.0; 3];
                s
            })
            .collect();
        self.frozen = Some(hold);
        self.ended = Some((reason, now));
    }

    fn reject(&mut self, d: &DecisionNotice, reason: RejectReason, now: u64, out: &mut TickOutput) {
        *self.stats.rejected_decisions.entry(reason).or_default() += 1;
        self.emit(
            out,
            now,
            EventKind::DecisionRejected {
                observer: d.observer.clone(),
                round: d.round,
                reason,
            },
        );
    }

    fn ingest_decisions(&mut self, decisions: &[DecisionNotice], now: u64, out: &mut TickOutput) {
        // Arrival order within a tick is transport-dependent; sorting makes the outcome not.
        let mut sorted: Vec<&DecisionNotice> = decisions.iter().collect();
        sorted.sort();
        for d in sorted {
            let verdict = self.judge(d, now);
            match verdict {
                Err(reason) => self.reject(d, reason, now, out),
                Ok(()) => {
                    let Some(round) = self.round.as_mut() else {
                        continue;
                    };
                    round.decisions.insert(d.observer.clone(), d.clone());
                    let number = round.number;
                    self.emit(
                        out,
                        now,
                        EventKind::DecisionAccepted {
                            observer: d.observer.clone(),
                            round: d.round,
                            assignment: d.assignment,
                            decided_ns: d.decided_ns,
                        },
                    );
                    if let Some(site) = d.assignment {
                        self.queue.insert(Queued {
                            decided_ns: d.decided_ns,
                            observer: d.observer.clone(),
                            site,
                            round: number,
                        });
                        self.emit(
                            out,
                            now,
                            EventKind::TripQueued {
                                observer: d.observer.clone(),
                                site,
                                round: number,
                            },
                        );
                    }
                }
            }
        }
    }

    fn judge(&self, d: &DecisionNotice, now: u64) -> Result<(), RejectReason> {
        if self.ended.is_some() {
            return Err(RejectReason::MissionOver);
        }
        if self.index_of(&d.observer).is_none() {
            return Err(RejectReason::UnknownObserver);
        }
        let Some(round) = &self.round else {
            return Err(RejectReason::WrongRound);
        };
        if d.round != round.number {
            return Err(RejectReason::WrongRound);
        }
        if round.broadcast_due_ns.is_none() {
            return Err(RejectReason::NothingBroadcast);
        }
        if d.decided_ns > now {
            return Err(RejectReason::FromTheFuture);
        }
        match round.broadcast {
            Some((start_ns, _)) if d.decided_ns >= start_ns => {}
            _ => return Err(RejectReason::BeforeBroadcast),
        }
        if round.deadline_ns.is_some_and(|dl| now > dl) {
            return Err(RejectReason::AfterDeadline);
        }
        if round.decisions.contains_key(&d.observer) {
            return Err(RejectReason::Duplicate);
        }
        Ok(())
    }

    /// Moves every trip in the air through the phase changes due by `now`, in departure order.
    fn advance_trips(&mut self, now: u64, out: &mut TickOutput) -> Result<(), SchedulerError> {
        let mut k = 0;
        while k < self.active.len() {
            if self.advance_trip(k, now, out)? {
                self.active.remove(k);
            } else {
                k += 1;
            }
        }
        Ok(())
    }

    /// Advances trip `k`; true once it is home.
    fn advance_trip(
        &mut self,
        k: usize,
        now: u64,
        out: &mut TickOutput,
    ) -> Result<bool, SchedulerError> {
        loop {
            let trip = &self.active[k];
            let id = self.ids[trip.index].clone();
            let (site, round) = (trip.site, trip.round);
            match &trip.phase {
                Phase::Outbound if trip.outbound.end_ns() <= now => {
                    let t = trip.outbound.end_ns();
                    self.arrive(k, t, out)?;
                }
                Phase::Service { until_ns } if *until_ns <= now => {
                    let t = *until_ns;
                    self.start_return(k, t)?;
                    self.finish_service(id, site, round, t, out);
                }
                Phase::Hold { until_ns } if *until_ns <= now => {
                    let t = *until_ns;
                    self.start_return(k, t)?;
                }
                Phase::Return(leg) if leg.end_ns() <= now => {
                    let t = leg.end_ns();
                    self.emit(out, t, EventKind::ReturnedHome { observer: id });
                    return Ok(true);
                }
                _ => return Ok(false),
            }
        }
    }

    /// Trip `k` reached its site at `t`: service if there is work, else back home (at once in
    /// sequential mode; after its reserved service time in concurrent mode).
    fn arrive(&mut self, k: usize, t: u64, out: &mut TickOutput) -> Result<(), SchedulerError> {
        let service_ns = self.config.timing.service_ns;
        let trip = &self.active[k];
        let (id, site) = (self.ids[trip.index].clone(), trip.site);
        let remaining = self.task.remaining(site);
        let kinds = if remaining == 0 {
            self.stats.no_work_arrivals += 1;
            match self.config.flights {
                FlightMode::Sequential => self.start_return(k, t)?,
                FlightMode::Concurrent => {
                    self.active[k].phase = Phase::Hold {
                        until_ns: t
                            .checked_add(service_ns)
                            .ok_or(SchedulerError::TimeOverflow)?,
                    };
                }
            }
            vec![EventKind::NoWork {
                observer: id.clone(),
                site,
            }]
        } else {
            self.active[k].phase = Phase::Service {
                until_ns: t
                    .checked_add(service_ns)
                    .ok_or(SchedulerError::TimeOverflow)?,
            };
            vec![EventKind::ServiceStarted {
                observer: id.clone(),
                site,
                remaining,
            }]
        };
        self.emit(out, t, EventKind::ArrivalAtSite { observer: id, site });
        for kind in kinds {
            self.emit(out, t, kind);
        }
        Ok(())
    }

    /// Trip `k` leaves its site at `t` along its outbound path reversed.
    fn start_return(&mut self, k: usize, t: u64) -> Result<(), SchedulerError> {
        let flight = self.config.flight;
        let trip = &mut self.active[k];
        let id = self.ids[trip.index].clone();
        let site = trip.site;
        trip.phase = Phase::Return(
            trip.outbound
                .reversed(t, &flight)
                .map_err(|e| nav_error(&id, site, e))?,
        );
        Ok(())
    }

    /// The end of a service at `t`: one work unit, unless the site ran dry meanwhile.
    fn finish_service(
        &mut self,
        id: ObserverId,
        site: Site,
        round: u32,
        t: u64,
        out: &mut TickOutput,
    ) {
        match self.task.serve(site) {
            Ok(remaining) => {
                self.stats.work_units += 1;
                self.stats
                    .services
                    .entry(id.clone())
                    .or_default()
                    .push((round, site));
                self.emit(
                    out,
                    t,
                    EventKind::ServiceEnded {
                        observer: id,
                        site,
                        remaining,
                    },
                );
            }
            // Two trips never hover at one site together, so this takes a site emptied by
            // another observer's service that ended first.
            Err(_) => {
                self.stats.no_work_arrivals += 1;
                self.emit(out, t, EventKind::NoWork { observer: id, site });
            }
        }
    }

    fn all_alive_decided(&self, alive: &BTreeSet<ObserverId>) -> bool {
        let Some(round) = &self.round else {
            return false;
        };
        let mut any = false;
        for id in self.ids.iter().filter(|id| alive.contains(*id)) {
            any = true;
            if !round.decisions.contains_key(id) {
                return false;
            }
        }
        any
    }

    fn advance_rounds(
        &mut self,
        now: u64,
        alive: &BTreeSet<ObserverId>,
        out: &mut TickOutput,
    ) -> Result<(), SchedulerError> {
        // A round may settle and the next one start within the same tick; each pass either
        // returns or starts a new round, and rounds are bounded.
        while self.ended.is_none() {
            if !self.advance_round_once(now, alive, out)? {
                break;
            }
        }
        Ok(())
    }

    /// Returns true when a new round started (the caller then runs it for this tick too).
    fn advance_round_once(
        &mut self,
        now: u64,
        alive: &BTreeSet<ObserverId>,
        out: &mut TickOutput,
    ) -> Result<bool, SchedulerError> {
        let timing = self.config.timing;
        let Some(round) = self.round.clone() else {
            return Ok(false);
        };
        // Broadcast.
        let Some(due_ns) = round.broadcast_due_ns else {
            // Rule (c): nothing is broadcast, so nothing can be decided.
            if now >= round.start_ns.saturating_add(timing.idle_end_ns) {
                self.end(EndReason::NoBroadcast, now, out);
            }
            return Ok(false);
        };
        if round.broadcast.is_none() {
            if now < due_ns {
                return Ok(false);
            }
            self.send_broadcast(&round, now, out)?;
        }
        // Window close: broadcast end + margin, or as soon as every live observer decided.
        let all_decided = self.all_alive_decided(alive);
        if let Some(r) = self.round.as_mut()
            && r.window_open
        {
            let (_, end_ns) = r.broadcast.unwrap_or((now, now));
            if all_decided || now >= end_ns.saturating_add(timing.window_margin_ns) {
                r.window_open = false;
                r.deadline_ns = Some(now.saturating_add(timing.decision_grace_ns));
                let number = r.number;
                Self::control(out, SessionEvent::WindowClose { round: number });
                self.emit(out, now, EventKind::WindowClosed { round: number });
            }
        }
        let Some(round) = self.round.clone() else {
            return Ok(false);
        };
        let Some(deadline_ns) = round.deadline_ns else {
            return Ok(false);
        };
        if now >= deadline_ns && !round.deadline_logged {
            if let Some(r) = self.round.as_mut() {
                r.deadline_logged = true;
            }
            self.emit(
                out,
                now,
                EventKind::DeadlinePassed {
                    round: round.number,
                },
            );
        }
        self.route(now, out)?;
        // Settling.
        let settled =
            self.active.is_empty() && self.queue.is_empty() && (now >= deadline_ns || all_decided);
        if !settled {
            return Ok(false);
        }
        if round.decisions.is_empty() {
            self.end(EndReason::NoDecision, now, out);
        } else if round.number >= self.config.rounds {
            self.end(EndReason::RoundsComplete, now, out);
        } else if self.task.total_remaining() == 0 {
            self.end(EndReason::AllWorkDone, now, out);
        } else {
            self.start_round(round.number + 1, now, out);
            return Ok(true);
        }
        Ok(false)
    }

    fn send_broadcast(
        &mut self,
        round: &Round,
        now: u64,
        out: &mut TickOutput,
    ) -> Result<(), SchedulerError> {
        let payloads: Vec<u8> = round.offers.iter().map(Offer::to_payload).collect();
        let acquisition = self.config.modality.acquisition();
        let schedule = proto::broadcast(now, &payloads, acquisition, &self.config.gesture)?;
        let plan = BroadcastPlan {
            round: round.number,
            offers: round.offers.clone(),
            acquisition,
            start_ns: now,
            end_ns: schedule.end_ns(),
            scheduled: schedule.offers().to_vec(),
        };
        if let Some(r) = self.round.as_mut() {
            r.broadcast = Some((now, plan.end_ns));
        }
        self.emit(
            out,
            now,
            EventKind::BroadcastStarted {
                round: round.number,
                offers: round.offers.clone(),
                acquisition,
                end_ns: plan.end_ns,
            },
        );
        self.broadcasts.push(plan.clone());
        out.broadcast = Some(plan);
        Ok(())
    }

    /// The safety router. Sequential: one mover at a time, queue order (decision time,
    /// observer name). Concurrent: every queued trip, in queue order, departs as soon as its
    /// reservation keeps the clearance from every trip in the air (a blocked trip does not hold
    /// back those behind it).
    fn route(&mut self, now: u64, out: &mut TickOutput) -> Result<(), SchedulerError> {
        match self.config.flights {
            FlightMode::Sequential => {
                if self.active.is_empty()
                    && let Some(next) = self.queue.pop_first()
                    && let Some(trip) = self.plan_trip(&next, now)?
                {
                    self.depart(next, trip, now, out);
                }
            }
            FlightMode::Concurrent => {
                let flight = self.config.flight;
                for q in self.queue.clone() {
                    let Some(trip) = self.plan_trip(&q, now)? else {
                        self.queue.remove(&q);
                        continue;
                    };
                    let flying: Vec<&Reservation> =
                        self.active.iter().map(|a| &a.reservation).collect();
                    if admit(&flying, &trip.reservation, now, &flight) {
                        self.queue.remove(&q);
                        self.depart(q, trip, now, out);
                    }
                }
            }
        }
        Ok(())
    }

    /// The trip `q` would fly if it left now: a path around every observer on the ground (trips
    /// in the air are the router's business) and the sites it is not going to. `None` for an
    /// observer outside the roster (never queued: decisions are judged first).
    fn plan_trip(&self, q: &Queued, now: u64) -> Result<Option<Trip>, SchedulerError> {
        let Some(index) = self.index_of(&q.observer) else {
            return Ok(None);
        };
        let flight = self.config.flight;
        let flying: BTreeSet<usize> = self.active.iter().map(|t| t.index).collect();
        let others = (0..self.ids.len())
            .filter(|&j| j != index && !flying.contains(&j))
            .map(|j| (self.ids[j].to_string(), self.positions_m[j]));
        let free_sites = Site::ALL
            .into_iter()
            .filter(|&s| s != q.site)
            .map(|s| (format!("site {s}"), s.position_m()));
        let obs = obstacles(others, free_sites, &flight);
        let nav = |e| nav_error(&q.observer, q.site, e);
        let path =
            plan_path(self.homes_m[index], q.site.position_m(), &obs, &flight).map_err(nav)?;
        let outbound = Leg::plan(now, &path, &flight).map_err(nav)?;
        let hover_until_ns = outbound
            .end_ns()
            .checked_add(self.config.timing.service_ns)
            .ok_or(SchedulerError::TimeOverflow)?;
        let inbound = outbound.reversed(hover_until_ns, &flight).map_err(nav)?;
        Ok(Some(Trip {
            index,
            site: q.site,
            round: q.round,
            reservation: Reservation::trip(outbound.clone(), hover_until_ns, inbound),
            outbound,
            phase: Phase::Outbound,
        }))
    }

    fn depart(&mut self, q: Queued, trip: Trip, now: u64, out: &mut TickOutput) {
        let waypoints = waypoints_um(trip.outbound.waypoints());
        self.active.push(trip);
        self.stats.departures += 1;
        self.emit(
            out,
            now,
            EventKind::Departure {
                observer: q.observer,
                site: q.site,
                round: q.round,
                decided_ns: q.decided_ns,
                waypoints,
            },
        );
    }
}

fn nav_error(observer: &ObserverId, site: Site, source: crate::error::NavError) -> SchedulerError {
    SchedulerError::Navigation {
        observer: observer.clone(),
        site,
        source,
    }
}
