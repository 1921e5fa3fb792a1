//! The scheduler state machine, advanced once per 40 ms tick (rules in the crate docs). This
//! module owns the state, the order of work within a tick (`step`), the observers' positions
//! and setpoints, and the mission end. Each child module adds the `Scheduler` methods for one
//! responsibility, so they share the state without exposing it: `rounds` (round life cycle and
//! its broadcast), `decisions` (accepting or rejecting decisions), `router` (the queue and
//! departures), `trips` (trips in the air); `tick` and `broadcast` hold the public types.

mod broadcast;
mod decisions;
mod rounds;
mod router;
mod tick;
mod trips;

use std::collections::{BTreeMap, BTreeSet};

use proto::clock::tick_end_ns;
use proto::scene::{observer_home_m, observer_home_yaw_rad};
use proto::sched::{ObserverSetpoint, SessionControl, SessionEvent};
use proto::{Kinematics, ObserverId, Site, TaskState};

use crate::config::SchedulerConfig;
use crate::error::{ConfigError, SchedulerError};
use crate::log::{DecisionReject, EventKind, LogEvent, PoseReject};
use proto::EndReason;

pub use broadcast::BroadcastPlan;
use rounds::Round;
use router::Queued;
pub use tick::{DecisionNotice, SchedulerInput, TickOutput, observer_positions};
use trips::{Phase, Trip};

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
    pub rejected_decisions: BTreeMap<DecisionReject, u64>,
    pub rejected_poses: BTreeMap<PoseReject, u64>,
}

impl Stats {
    pub fn rejections(&self) -> u64 {
        self.rejected_decisions.values().sum()
    }
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
        proto::broadcast(0, &[0], true, &config.gesture, config.frame_check)
            .map_err(ConfigError::from)?;
        let n = config.observers;
        let task = TaskState::with_units(n, &config.work)
            .map_err(|_| ConfigError::ObserverCount { observers: n })?;
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
    pub fn step(&mut self, input: &SchedulerInput<'_>) -> Result<TickOutput, SchedulerError> {
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
}
