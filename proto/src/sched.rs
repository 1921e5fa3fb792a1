//! What the scheduler publishes: observer flight setpoints (`sched/cmd`), the offers the
//! performer must send (`sched/broadcast`) and session controls (`sched/session`).
//!
//! Session controls carry no payloads, labels or poses: observers subscribe to them.

use serde::{Deserialize, Serialize};

use crate::clock::{check_finite, stamp_in_tick};
use crate::codec::Validate;
use crate::keys::ObserverId;
use crate::payload::Offer;

/// Flight setpoint of one observer, chosen by the safety router.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverSetpoint {
    pub observer: ObserverId,
    pub pos_m: [f64; 3],
    /// Feed-forward velocity.
    pub vel_mps: [f64; 3],
    pub yaw_rad: f64,
}

/// Setpoints for every observer after tick `tick` (`sched/cmd`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SchedCommand {
    pub tick: u64,
    pub setpoints: Vec<ObserverSetpoint>,
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
            check_finite(&format!("setpoint position of {}", s.observer), &s.pos_m)?;
            check_finite(&format!("setpoint velocity of {}", s.observer), &s.vel_mps)?;
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
    /// Offers to send, each as one complete frame, in this order; empty = send nothing.
    pub offers: Vec<Offer>,
    /// Whether to fly the acquisition motion and quiet period before the first offer.
    pub acquisition: bool,
}

/// Largest number of frames one broadcast may request.
pub const MAX_BROADCAST_OFFERS: usize = 16;

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
