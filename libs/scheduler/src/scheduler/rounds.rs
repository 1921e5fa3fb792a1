//! The round life cycle: a round's start (offers from the task state, reset, window open), its
//! broadcast, window close, decision deadline and settling into the next round or the mission
//! end.

use std::collections::{BTreeMap, BTreeSet};

use proto::sched::SessionEvent;
use proto::{ObserverId, Offer};

use crate::error::SchedulerError;
use crate::log::EventKind;
use crate::scheduler::Scheduler;
use crate::scheduler::broadcast::BroadcastPlan;
use crate::scheduler::tick::{DecisionNotice, TickOutput};
use proto::EndReason;

#[derive(Debug, Clone, PartialEq)]
pub(super) struct Round {
    pub(super) number: u32,
    pub(super) start_ns: u64,
    pub(super) offers: Vec<Offer>,
    /// `None`: this round broadcasts nothing.
    pub(super) broadcast_due_ns: Option<u64>,
    pub(super) broadcast: Option<(u64, u64)>,
    /// Broadcasts flown this round (more than one only under `max_broadcasts`).
    pub(super) broadcasts_flown: u32,
    pub(super) window_open: bool,
    pub(super) deadline_ns: Option<u64>,
    pub(super) deadline_logged: bool,
    pub(super) decisions: BTreeMap<ObserverId, DecisionNotice>,
}

impl Scheduler {
    pub(super) fn start_round(&mut self, number: u32, now: u64, out: &mut TickOutput) {
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
            broadcasts_flown: 0,
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

    pub(super) fn advance_rounds(
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
        // Window close: broadcast end + margin, or as soon as every live observer decided. A
        // round allowed more broadcasts flies its offers again instead while one is undecided.
        let all_decided = self.all_alive_decided(alive);
        if let Some(r) = self.round.clone()
            && r.window_open
            && !all_decided
            && r.broadcasts_flown < self.config.max_broadcasts
            && r.broadcast
                .is_some_and(|(_, end_ns)| now >= end_ns.saturating_add(timing.window_margin_ns))
        {
            self.send_broadcast(&r, now, out)?;
        }
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
        let plan = BroadcastPlan::plan(round.number, &round.offers, now, &self.config)?;
        if let Some(r) = self.round.as_mut() {
            r.broadcast = Some((now, plan.end_ns));
            r.broadcasts_flown += 1;
        }
        self.emit(
            out,
            now,
            EventKind::BroadcastStarted {
                round: round.number,
                offers: round.offers.clone(),
                acquisition: plan.acquisition,
                end_ns: plan.end_ns,
            },
        );
        self.broadcasts.push(plan.clone());
        out.broadcast = Some(plan);
        Ok(())
    }
}
