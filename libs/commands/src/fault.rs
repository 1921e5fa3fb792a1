//! The faults a user injects beyond a case's own (`--black O2`, `--kill O2@35`, `--throttle O1@0:250:0`, and a compose file's `[faults]`), each parsed by [`FromStr`] so clap refuses a bad one naming it.

use anyhow::Result;
use proto::KeyError;
use proto::ObserverId;
use std::str::FromStr;

/// A fault specification on the command line that does not parse.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaultSpecError {
    /// Not of the shape the option wants.
    #[error("{input:?} is not {want}")]
    Shape { input: String, want: &'static str },
    /// The observer part is not an observer id.
    #[error("{input:?}: bad observer: {source}")]
    Observer {
        input: String,
        #[source]
        source: KeyError,
    },
    /// One number is out of range or not a number.
    #[error("{input:?}: {what} {value:?} must be {must}")]
    Value {
        input: String,
        what: &'static str,
        value: String,
        must: &'static str,
    },
}

fn observer(input: &str, o: &str) -> Result<ObserverId, FaultSpecError> {
    ObserverId::new(o).map_err(|source| FaultSpecError::Observer {
        input: input.to_string(),
        source,
    })
}

/// A non-negative, finite number of seconds.
fn seconds(input: &str, what: &'static str, value: &str) -> Result<f64, FaultSpecError> {
    match value.parse::<f64>() {
        Ok(s) if s.is_finite() && s >= 0.0 => Ok(s),
        _ => Err(FaultSpecError::Value {
            input: input.to_string(),
            what,
            value: value.to_string(),
            must: "a non-negative number of seconds",
        }),
    }
}

/// `--black O2`: black input of this observer from start-up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlackSpec {
    pub observer: ObserverId,
}

impl FromStr for BlackSpec {
    type Err = FaultSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(Self {
            observer: observer(s, s)?,
        })
    }
}

/// `--kill O2@35`: SIGKILL this observer's camera at a sim time, seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct KillSpec {
    pub observer: ObserverId,
    pub at_s: f64,
}

impl FromStr for KillSpec {
    type Err = FaultSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (o, at) = s.split_once('@').ok_or_else(|| FaultSpecError::Shape {
            input: s.to_string(),
            want: "OBSERVER@SECONDS (e.g. O2@35)",
        })?;
        Ok(Self {
            observer: observer(s, o)?,
            at_s: seconds(s, "time", at)?,
        })
    }
}

/// `--throttle O1@0:250:0`: from a sim time on, drop a share of the camera's packets (per
/// mille) and delay the rest (wall-clock ms).
#[derive(Debug, Clone, PartialEq)]
pub struct ThrottleSpec {
    pub observer: ObserverId,
    pub from_s: f64,
    pub drop_per_mille: u16,
    pub delay_ms: u32,
}

impl FromStr for ThrottleSpec {
    type Err = FaultSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let shape = || FaultSpecError::Shape {
            input: s.to_string(),
            want: "OBSERVER@FROM_S:DROP_PER_MILLE:DELAY_MS (e.g. O1@0:250:0)",
        };
        let (o, rest) = s.split_once('@').ok_or_else(shape)?;
        let parts: Vec<&str> = rest.split(':').collect();
        let [from, drop, delay] = parts[..] else {
            return Err(shape());
        };
        let value = |what, value: &str, must| FaultSpecError::Value {
            input: s.to_string(),
            what,
            value: value.to_string(),
            must,
        };
        let drop_per_mille = drop
            .parse::<u16>()
            .ok()
            .filter(|d| *d <= 1000)
            .ok_or_else(|| value("drop", drop, "a whole number of per mille, 0–1000"))?;
        let delay_ms = delay
            .parse::<u32>()
            .map_err(|_| value("delay", delay, "a whole number of milliseconds"))?;
        Ok(Self {
            observer: observer(s, o)?,
            from_s: seconds(s, "start", from)?,
            drop_per_mille,
            delay_ms,
        })
    }
}

impl std::fmt::Display for BlackSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.observer)
    }
}

impl std::fmt::Display for KillSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}@{}", self.observer, self.at_s)
    }
}

impl std::fmt::Display for ThrottleSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}@{}:{}:{}",
            self.observer, self.from_s, self.drop_per_mille, self.delay_ms
        )
    }
}
