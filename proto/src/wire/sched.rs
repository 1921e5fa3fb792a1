//! What the scheduler publishes: observer flight setpoints (`sched/cmd`), the offers the
//! performer must send (`sched/broadcast`) and session controls (`sched/session`).
//!
//! Session controls carry no payloads, labels or poses: observers subscribe to them.
//!
//! In the distributed runtime the scheduler publishes one [`SessionTick`] on `sched/session` and
//! one [`BroadcastTick`] on `sched/broadcast` **every** tick, even when empty: an observer (or the
//! performer) then knows it has everything the scheduler said in tick k, whatever the arrival
//! order of messages from different publishers. The final [`MissionReport`] goes on
//! `sched/report`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::clock::{check_finite, stamp_in_tick};
use crate::codec::Validate;
use crate::end_reason::EndReason;
use crate::keys::ObserverId;
use crate::payload::{Offer, Site};
use crate::world::Kinematics;

/// Flight setpoint of one observer, chosen by the safety router. `kin` carries the feed-forward
/// velocity and acceleration (the simulator extrapolates the setpoint over the next tick); on the
/// wire its fields follow `observer` in order, as the flat layout did (bincode nests no framing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverSetpoint {
    pub observer: ObserverId,
    pub kin: Kinematics,
    pub yaw_rad: f64,
}

impl ObserverSetpoint {
    /// `observer`'s setpoint: `kin` flown at heading `yaw_rad`.
    pub fn new(observer: ObserverId, kin: Kinematics, yaw_rad: f64) -> Self {
        Self {
            observer,
            kin,
            yaw_rad,
        }
    }

    /// Position, velocity and acceleration of the setpoint.
    pub fn kinematics(&self) -> Kinematics {
        self.kin
    }
}

/// Setpoints for every observer after tick `tick` (`sched/cmd`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SchedCommand {
    pub tick: u64,
    pub setpoints: Vec<ObserverSetpoint>,
    /// The mission ended in this tick: the simulator stops instead of stepping on.
    pub mission_end: bool,
}

impl Validate for SchedCommand {
    fn validate(&self) -> Result<(), String> {
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.setpoints {
            if !seen.insert(&s.observer) {
                return Err(format!(
                    "two setpoints for {} in tick {}",
                    s.observer, self.tick
                ));
            }
            check_finite(
                &format!("setpoint position of {}", s.observer),
                &s.kin.pos_m,
            )?;
            check_finite(
                &format!("setpoint velocity of {}", s.observer),
                &s.kin.vel_mps,
            )?;
            check_finite(
                &format!("setpoint acceleration of {}", s.observer),
                &s.kin.acc_mps2,
            )?;
            check_finite(&format!("setpoint yaw of {}", s.observer), &[s.yaw_rad])?;
        }
        Ok(())
    }
}

/// The offers the performer should send in a round, in order (`sched/broadcast`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Broadcast {
    pub tick: u64,
    pub round: u32,
    /// Sim time at which the performer starts flying it (inside tick `tick`).
    pub start_ns: u64,
    /// Offers to send, each as one complete frame, in this order; empty = send nothing.
    pub offers: Vec<Offer>,
    /// Whether to fly the acquisition motion and quiet period before the first offer.
    pub acquisition: bool,
}

/// Largest number of frames one broadcast may request.
pub const MAX_BROADCAST_OFFERS: usize = 16;

/// The most broadcasts one round may fly (a case's `max_broadcasts`): enough to ride out a few
/// losses, few enough that a deaf observer cannot hold a mission for long.
pub const MAX_ROUND_BROADCASTS: u32 = 8;

impl Validate for Broadcast {
    fn validate(&self) -> Result<(), String> {
        if self.offers.len() > MAX_BROADCAST_OFFERS {
            return Err(format!(
                "broadcast of {} offers exceeds {MAX_BROADCAST_OFFERS}",
                self.offers.len()
            ));
        }
        for o in &self.offers {
            o.check().map_err(|e| format!("broadcast offer: {e}"))?;
        }
        if !stamp_in_tick(self.start_ns, self.tick) {
            return Err(format!(
                "broadcast starting at {} ns is outside tick {}",
                self.start_ns, self.tick
            ));
        }
        Ok(())
    }
}

/// What the scheduler tells the performer in one tick (`sched/broadcast`, every tick).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BroadcastTick {
    pub tick: u64,
    /// A broadcast starting in this tick, if any.
    pub broadcast: Option<Broadcast>,
}

impl Validate for BroadcastTick {
    fn validate(&self) -> Result<(), String> {
        if let Some(b) = &self.broadcast {
            b.validate()?;
            if b.tick != self.tick {
                return Err(format!(
                    "broadcast of tick {} inside the message of tick {}",
                    b.tick, self.tick
                ));
            }
        }
        Ok(())
    }
}

/// A session-level event every process may observe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SessionEvent {
    /// A new round begins: observers clear their offer caches and frame parsers.
    RoundReset { round: u32 },
    /// Observers may receive (they stay still) from now on.
    WindowOpen { round: u32 },
    /// Reception for the round is over.
    WindowClose { round: u32 },
    /// The mission is over; processes may exit.
    MissionEnd,
}

/// A session control (`sched/session`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SessionControl {
    pub tick: u64,
    pub stamp_ns: u64,
    pub event: SessionEvent,
}

impl Validate for SessionControl {
    fn validate(&self) -> Result<(), String> {
        if !stamp_in_tick(self.stamp_ns, self.tick) {
            return Err(format!(
                "session control at {} ns is outside tick {}",
                self.stamp_ns, self.tick
            ));
        }
        Ok(())
    }
}

/// Every session control of one tick, in the order they apply (`sched/session`, every tick).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SessionTick {
    pub tick: u64,
    pub controls: Vec<SessionControl>,
}

impl Validate for SessionTick {
    fn validate(&self) -> Result<(), String> {
        for c in &self.controls {
            c.validate()?;
            if c.tick != self.tick {
                return Err(format!(
                    "session control of tick {} inside the message of tick {}",
                    c.tick, self.tick
                ));
            }
        }
        Ok(())
    }
}

/// One departure of an observer on a trip (for the provenance audit).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Departure {
    pub observer: ObserverId,
    pub round: u32,
    pub site: Site,
    pub t_ns: u64,
}

/// The scheduler's account of the mission, published once on its last tick (`sched/report`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MissionReport {
    pub tick: u64,
    pub end_ns: u64,
    /// Why the mission ended.
    pub end_reason: EndReason,
    pub work_units: u32,
    /// Completed services per observer, in order: (round, site).
    pub services: BTreeMap<ObserverId, Vec<(u32, Site)>>,
    pub departures: Vec<Departure>,
    /// Decisions the scheduler rejected.
    pub rejected_decisions: u64,
}

impl Validate for MissionReport {
    fn validate(&self) -> Result<(), String> {
        if crate::clock::tick_end_ns(self.tick) != Some(self.end_ns) {
            return Err(format!(
                "mission report of tick {} ends at {} ns",
                self.tick, self.end_ns
            ));
        }
        let served: usize = self.services.values().map(Vec::len).sum();
        if served != self.work_units as usize {
            return Err(format!(
                "{} work units but {served} services listed",
                self.work_units
            ));
        }
        Ok(())
    }
}
