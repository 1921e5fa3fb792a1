//! Trips in the air: each one's phases (outbound, service or hold, return) and the arrivals,
//! services and returns home they produce as the ticks pass.

use proto::{FlightMode, ObserverId, Site};

use crate::error::{NavError, SchedulerError};
use crate::log::EventKind;
use crate::reservation::Reservation;
use crate::scheduler::Scheduler;
use crate::scheduler::tick::TickOutput;
use crate::trajectory::Leg;

#[derive(Debug, Clone, PartialEq)]
pub(super) enum Phase {
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
pub(super) struct Trip {
    pub(super) index: usize,
    pub(super) site: Site,
    pub(super) round: u32,
    pub(super) outbound: Leg,
    pub(super) phase: Phase,
    /// The whole trip as committed at departure (what the concurrent router checks).
    pub(super) reservation: Reservation,
}

impl Scheduler {
    /// Moves every trip in the air through the phase changes due by `now`, in departure order.
    pub(super) fn advance_trips(
        &mut self,
        now: u64,
        out: &mut TickOutput,
    ) -> Result<(), SchedulerError> {
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
}

pub(super) fn nav_error(observer: &ObserverId, site: Site, source: NavError) -> SchedulerError {
    SchedulerError::Navigation {
        observer: observer.clone(),
        site,
        source,
    }
}
