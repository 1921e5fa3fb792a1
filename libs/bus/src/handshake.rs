//! Start-up handshake: no lockstep message is published before its subscribers exist.
//!
//! Zenoh delivers a publication only to subscribers its publisher's session already knows of,
//! and peers of a session find each other asynchronously (endpoints, then gossip). So every
//! process, once all its subscriptions are declared:
//! 1. declares its liveliness token `alive/<role>/<id>` — over each link it follows the
//!    subscription declarations, so a peer that sees the token knows the subscriptions;
//! 2. waits until it sees the `alive` token of **every** process of the session (it then knows
//!    every peer's subscriptions, and every peer is connected to it);
//! 3. declares `ready/<role>/<id>`.
//!
//! The simulator publishes tick 0 only once every `ready` token is present
//! ([`wait_ready`]). Tokens disappear when a process dies, which is how peers learn of it.

use std::time::Duration;

use proto::{Keys, Role, scene::observer_name};

use crate::bus::Bus;
use crate::error::BusError;

/// One process of a session: its role and id (`O1` for cameras and observers, the role name
/// otherwise).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Process {
    pub role: Role,
    pub id: String,
}

impl Process {
    pub fn new(role: Role, id: impl Into<String>) -> Self {
        Self {
            role,
            id: id.into(),
        }
    }

    /// The single process of a role that has one (`sim`, `performer`, `scheduler`, …).
    pub fn singleton(role: Role) -> Self {
        Self::new(role, role.as_str())
    }

    /// Its process name: the role for a singleton (`sim`), role and id otherwise
    /// (`camera-O1`, the launcher of host `b`: `launcher-b`) — the name in `summary.json` and
    /// its user name on the bus.
    pub fn name(&self) -> String {
        match self.role {
            Role::Camera | Role::Observer => format!("{}-{}", self.role.as_str(), self.id),
            _ if self.id == self.role.as_str() => self.id.clone(),
            _ => format!("{}-{}", self.role.as_str(), self.id),
        }
    }

    /// The launcher of one host of a multi-host session that does not supervise it (it only
    /// starts, watches and stops that host's nodes).
    pub fn host_launcher(host: &str) -> Self {
        Self::new(Role::Launcher, host)
    }

    pub fn alive_key(&self, keys: &Keys) -> Result<String, BusError> {
        Ok(keys.alive(self.role, &self.id)?)
    }

    pub fn ready_key(&self, keys: &Keys) -> Result<String, BusError> {
        Ok(keys.ready(self.role, &self.id)?)
    }
}

impl std::fmt::Display for Process {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.role.as_str(), self.id)
    }
}

/// Every process of a mission with `observers` observers: the simulator, one camera and one
/// observer per observer, the performer, the scheduler and, when it takes part, the launcher.
pub fn mission_processes(observers: usize, with_launcher: bool) -> Vec<Process> {
    let mut out = vec![
        Process::singleton(Role::Sim),
        Process::singleton(Role::Performer),
        Process::singleton(Role::Scheduler),
    ];
    for i in 0..observers {
        out.push(Process::new(Role::Camera, observer_name(i)));
        out.push(Process::new(Role::Observer, observer_name(i)));
    }
    if with_launcher {
        out.push(Process::singleton(Role::Launcher));
    }
    out
}

fn missing(keys: &[String], present: &std::collections::BTreeSet<String>) -> Vec<String> {
    keys.iter()
        .filter(|k| !present.contains(*k))
        .cloned()
        .collect()
}

/// Steps 1–3 of the handshake for process `me`. Call after declaring every subscription.
pub fn join(
    bus: &mut Bus,
    me: &Process,
    everyone: &[Process],
    timeout: Duration,
) -> Result<(), BusError> {
    announce(bus, me)?;
    await_everyone(bus, everyone, timeout)?;
    declare_ready(bus, me)
}

/// Step 1: watch every liveliness token and declare `me`'s.
pub fn announce(bus: &mut Bus, me: &Process) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    bus.watch_liveliness(&keys.alive_any())?;
    bus.declare_token(&me.alive_key(&keys)?)
}

/// Step 2: wait until every process's liveliness token is present.
pub fn await_everyone(
    bus: &mut Bus,
    everyone: &[Process],
    timeout: Duration,
) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    let wanted: Vec<String> = everyone
        .iter()
        .map(|p| p.alive_key(&keys))
        .collect::<Result<_, _>>()?;
    bus.wait_for("every process's liveliness token", timeout, |present| {
        missing(&wanted, present).is_empty()
    })
    .map_err(|e| with_missing(e, &wanted, bus))
}

/// Step 3: declare `me` ready.
pub fn declare_ready(bus: &mut Bus, me: &Process) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    bus.declare_token(&me.ready_key(&keys)?)
}

/// Waits until every process of the session has declared `ready`.
pub fn wait_ready(bus: &mut Bus, everyone: &[Process], timeout: Duration) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    bus.watch_liveliness(&keys.ready_any())?;
    let wanted: Vec<String> = everyone
        .iter()
        .map(|p| p.ready_key(&keys))
        .collect::<Result<_, _>>()?;
    bus.wait_for("every process to be ready", timeout, |present| {
        missing(&wanted, present).is_empty()
    })
    .map_err(|e| with_missing(e, &wanted, bus))
}

fn with_missing(e: BusError, wanted: &[String], bus: &Bus) -> BusError {
    match e {
        BusError::Timeout { what, waited_s } => BusError::Timeout {
            what: format!(
                "{what} (missing: {})",
                missing(wanted, bus.alive_keys()).join(", ")
            ),
            waited_s,
        },
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mission_has_one_camera_and_one_observer_per_observer() {
        let p = mission_processes(3, true);
        assert_eq!(p.len(), 3 + 6 + 1);
        assert!(p.contains(&Process::new(Role::Camera, "O3")));
        assert!(p.contains(&Process::new(Role::Observer, "O1")));
        assert!(p.contains(&Process::singleton(Role::Launcher)));
        assert!(!mission_processes(1, false).contains(&Process::singleton(Role::Launcher)));
        let keys = Keys::new("s").unwrap();
        assert_eq!(
            Process::new(Role::Camera, "O2").alive_key(&keys).unwrap(),
            "waggle/s/alive/camera/O2"
        );
        assert_eq!(
            Process::singleton(Role::Sim).ready_key(&keys).unwrap(),
            "waggle/s/ready/sim/sim"
        );
    }
}
