//! The safety router: the queue of accepted assignments, the path each trip would fly if it
//! left now, and which trips may depart (one at a time, or concurrently when their
//! reservations keep clear of every trip in the air).

use std::collections::BTreeSet;

use proto::{FlightMode, ObserverId, Site};

use crate::error::SchedulerError;
use crate::log::{EventKind, waypoints_um};
use crate::navigation::{obstacles, plan_path};
use crate::reservation::{Reservation, admit};
use crate::scheduler::Scheduler;
use crate::scheduler::tick::TickOutput;
use crate::scheduler::trips::{Phase, Trip, nav_error};
use crate::trajectory::Leg;

#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Queued {
    pub(super) decided_ns: u64,
    pub(super) observer: ObserverId,
    pub(super) site: Site,
    pub(super) round: u32,
}

impl Scheduler {
    /// The safety router. Sequential: one mover at a time, queue order (decision time,
    /// observer name). Concurrent: every queued trip, in queue order, departs as soon as its
    /// reservation keeps the clearance from every trip in the air (a blocked trip does not hold
    /// back those behind it).
    pub(super) fn route(&mut self, now: u64, out: &mut TickOutput) -> Result<(), SchedulerError> {
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
