//! A process by its name (`sim`, `camera-O2`, `launcher-b`), as compose files, `summary.json`
//! and the bus's user names spell it: parsed back into a [`Process`] so a node's role is typed
//! wherever it is read.

use std::str::FromStr;

use proto::{ObserverId, Role};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::handshake::Process;

/// A name that is no process's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{name:?} is not a process name (sim, performer, scheduler, recorder, launcher, \
     camera-Oi, observer-Oi, launcher-HOST)"
)]
pub struct ProcessNameError {
    pub name: String,
}

impl FromStr for Process {
    type Err = ProcessNameError;

    fn from_str(name: &str) -> Result<Self, ProcessNameError> {
        let bad = || ProcessNameError {
            name: name.to_string(),
        };
        let process = match name.split_once('-') {
            None => match Role::parse(name) {
                Some(Role::Camera | Role::Observer) | None => return Err(bad()),
                Some(role) => Process::singleton(role),
            },
            Some((role, id)) => match Role::parse(role) {
                Some(role @ (Role::Camera | Role::Observer)) => {
                    let o = ObserverId::new(id).map_err(|_| bad())?;
                    Process::new(role, o.as_str())
                }
                Some(Role::Launcher) if proto::keys::validate_chunk("host", id).is_ok() => {
                    Process::host_launcher(id)
                }
                _ => return Err(bad()),
            },
        };
        // One spelling per process: `launcher-launcher` is not the supervisor's name.
        if process.name() != name {
            return Err(bad());
        }
        Ok(process)
    }
}

impl Serialize for Process {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for Process {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission_processes;

    #[test]
    fn every_process_name_parses_back_and_others_are_refused() {
        let mut all = mission_processes(8, true);
        all.push(Process::singleton(Role::Recorder));
        all.push(Process::host_launcher("b"));
        for p in all {
            assert_eq!(p.name().parse::<Process>().unwrap(), p, "{}", p.name());
        }
        for bad in [
            "",
            "camera",
            "observer",
            "camera-O1/x",
            "observer-",
            "sim-2",
            "launcher-launcher",
            "launcher-a/b",
            "robot",
            "Sim",
        ] {
            let err = bad.parse::<Process>().unwrap_err();
            assert!(err.to_string().contains(&format!("{bad:?}")), "{err}");
        }
    }
}
