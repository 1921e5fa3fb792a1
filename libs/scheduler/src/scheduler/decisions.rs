//! Judging decisions: which are accepted into the round (and queue a trip) and which are
//! counted as rejections, independently of their arrival order within a tick.

use crate::log::{DecisionReject, EventKind};
use crate::scheduler::Scheduler;
use crate::scheduler::router::Queued;
use crate::scheduler::tick::{DecisionNotice, TickOutput};

impl Scheduler {
    fn reject(
        &mut self,
        d: &DecisionNotice,
        reason: DecisionReject,
        now: u64,
        out: &mut TickOutput,
    ) {
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

    pub(super) fn ingest_decisions(
        &mut self,
        decisions: &[DecisionNotice],
        now: u64,
        out: &mut TickOutput,
    ) {
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

    fn judge(&self, d: &DecisionNotice, now: u64) -> Result<(), DecisionReject> {
        if self.ended.is_some() {
            return Err(DecisionReject::MissionOver);
        }
        if self.index_of(&d.observer).is_none() {
            return Err(DecisionReject::UnknownObserver);
        }
        let Some(round) = &self.round else {
            return Err(DecisionReject::WrongRound);
        };
        if d.round != round.number {
            return Err(DecisionReject::WrongRound);
        }
        if round.broadcast_due_ns.is_none() {
            return Err(DecisionReject::NothingBroadcast);
        }
        if d.decided_ns > now {
            return Err(DecisionReject::FromTheFuture);
        }
        match round.broadcast {
            Some((start_ns, _)) if d.decided_ns >= start_ns => {}
            _ => return Err(DecisionReject::BeforeBroadcast),
        }
        if round.deadline_ns.is_some_and(|dl| now > dl) {
            return Err(DecisionReject::AfterDeadline);
        }
        if round.decisions.contains_key(&d.observer) {
            return Err(DecisionReject::Duplicate);
        }
        Ok(())
    }
}
