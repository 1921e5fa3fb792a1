//! A plug-in as one observer's whole receiving chain in a mission (`waggle run`/`mission
//! --receiver O2=python:MODULE:CLASS`): the observer's runtime feeds it as it feeds Waggle's
//! own receivers ([`perception::Receiving`]).
//!
//! A mission is not a trial that can be failed and counted: when the plug-in raises, returns
//! malformed output, dies or runs past its time limit, the chain keeps the first error, kills
//! the worker and from then on hears nothing (no tokens, no frames) — the observer goes on
//! deaf, the mission ends as it would with a blind camera, and the error is reported by name.

use std::cell::RefCell;
use std::fmt;
use std::rc::Rc;
use std::str::FromStr;
use std::time::Duration;

use perception::{PerceptionError, Receiving, SensorInput};
use proto::{DecodeStep, EgoRotation, ObserverId, SegmenterConfig};

use crate::error::PluginError;
use crate::receiver::{ObserverInfo, PluginReceiver, Pushed};
use crate::spec::PluginSpec;
use crate::worker::Worker;

/// Which observer a plug-in receives for: `O2=python:MODULE:CLASS`.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct ObserverPlugin {
    pub observer: ObserverId,
    pub plugin: PluginSpec,
}

impl FromStr for ObserverPlugin {
    type Err = PluginError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: String| PluginError::Spec {
            spec: s.to_owned(),
            why,
        };
        let (observer, plugin) = s
            .split_once('=')
            .ok_or_else(|| bad("an observer's receiver is OBSERVER=python:MODULE:CLASS".into()))?;
        Ok(Self {
            observer: ObserverId::new(observer)
                .map_err(|e| bad(format!("OBSERVER {observer:?}: {e}")))?,
            plugin: plugin.parse().map_err(|e| match e {
                PluginError::Spec { why, .. } => bad(why),
                other => other,
            })?,
        })
    }
}

impl fmt::Display for ObserverPlugin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}", self.observer.as_str(), self.plugin)
    }
}

/// One observer's receiving chain on a plug-in worker of its own.
pub struct PluginChain {
    spec: PluginSpec,
    /// `None` once the plug-in failed (its worker is then dropped, which kills it).
    receiver: Option<PluginReceiver>,
    failure: Option<PluginError>,
}

impl fmt::Debug for PluginChain {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PluginChain")
            .field("spec", &self.spec)
            .field("working", &self.receiver.is_some())
            .field("failure", &self.failure)
            .finish()
    }
}

impl PluginChain {
    /// Starts a worker for `spec` on `python` and opens the plug-in for `info`, the whole
    /// mission limited to `limit` of wall-clock time. A plug-in that raises or misbehaves while
    /// it opens gives a chain that has failed (see [`Receiving::failure`]); only a worker that
    /// cannot be started at all is an error.
    pub fn open(
        spec: &PluginSpec,
        python: &str,
        info: &ObserverInfo,
        segmenter: SegmenterConfig,
        limit: Option<Duration>,
    ) -> Result<Self, PluginError> {
        let mut worker = Worker::spawn(spec, python)?;
        worker.start_trial(limit);
        let mut chain = Self {
            spec: spec.clone(),
            receiver: None,
            failure: None,
        };
        match PluginReceiver::open(Rc::new(RefCell::new(worker)), info, segmenter) {
            Ok(r) => chain.receiver = Some(r),
            Err(e) => chain.fail(e),
        }
        Ok(chain)
    }

    pub fn spec(&self) -> &PluginSpec {
        &self.spec
    }

    fn fail(&mut self, e: PluginError) {
        self.receiver = None;
        self.failure.get_or_insert(e);
    }

    /// Runs `call` on the working receiver: a failure is kept and heard as nothing.
    fn with<T: Default>(
        &mut self,
        call: impl FnOnce(&mut PluginReceiver) -> Result<T, PluginError>,
    ) -> T {
        let Some(r) = self.receiver.as_mut() else {
            return T::default();
        };
        match call(r) {
            Ok(v) => v,
            Err(e) => {
                self.fail(e);
                T::default()
            }
        }
    }
}

impl Receiving for PluginChain {
    fn push_tracked(&mut self, input: SensorInput<'_>) -> Result<Pushed, PerceptionError> {
        match input {
            SensorInput::Events(p) => Ok(self.with(|r| r.push_events(p))),
            SensorInput::Rgb(f) => Ok(self.with(|r| r.push_rgb(f))),
            SensorInput::Track(_) => Err(PerceptionError::WrongSensor {
                expected: "sensor (events or rgb)",
                got: input.kind(),
            }),
        }
    }

    fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep, PerceptionError> {
        Ok(self.with(|r| r.missing(stamp_ns)))
    }

    fn reset(&mut self) {
        self.with(PluginReceiver::reset);
    }

    fn set_ego_rotation(&mut self, ego: Option<EgoRotation>) {
        if let Some(r) = self.receiver.as_mut() {
            r.set_ego_rotation(ego);
        }
    }

    fn set_frame_check(&mut self, check: proto::FrameCheck) {
        if let Some(r) = self.receiver.as_mut() {
            r.set_frame_check(check);
        }
    }

    fn failure(&self) -> Option<String> {
        self.failure
            .as_ref()
            .map(|e| format!("{}: {e}", e.outcome()))
    }
}

#[cfg(test)]
mod tests {
    use super::ObserverPlugin;

    #[test]
    fn an_observer_and_its_plugin_parse_and_print_back() {
        let p: ObserverPlugin = "O2=python:lab.rx:Tracker".parse().unwrap();
        assert_eq!(
            (p.observer.as_str(), p.plugin.to_string().as_str()),
            ("O2", "python:lab.rx:Tracker")
        );
        assert_eq!(p.to_string(), "O2=python:lab.rx:Tracker");
        for bad in [
            "python:lab.rx:Tracker",
            "=python:a:B",
            "O2=lab:B",
            "O 2=python:a:B",
        ] {
            let err = bad.parse::<ObserverPlugin>().unwrap_err().to_string();
            assert!(err.contains(bad), "{bad}: {err}");
        }
    }
}
