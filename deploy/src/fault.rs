//! Faults the launcher injects: the case's `[[faults]]` plus the command line's `--black O2`,
//! `--kill O2@35` and `--throttle O1@0:250:0`, each parsed by [`FromStr`] (so clap rejects a
//! bad one naming it) and checked against the case's observers.

use std::str::FromStr;

use proto::scene::observer_name;
use proto::{Fault, FaultKind, KeyError, ObserverId};

use crate::case::{Case, CaseFaultKind as CaseFault};

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

/// A fault names an observer the case does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("fault names {observer}, but the case has {have}")]
pub struct UnknownObserver {
    pub observer: ObserverId,
    pub have: String,
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

/// Faults injected beyond the case's own: the command line's `--black`, `--kill` and
/// `--throttle`, and a compose file's `[faults]` table, where each is written as on the command
/// line (`black = ["O2"]`, `kill = ["O2@35"]`, `throttle = ["O1@0:250:0"]`) and parsed by the
/// same [`FromStr`], so a bad one is refused naming it.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtraFaults {
    /// Black input from start-up, `O2`.
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "as_text")]
    pub black: Vec<BlackSpec>,
    /// SIGKILL of a camera at a sim time, `O2@35`.
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "as_text")]
    pub kill: Vec<KillSpec>,
    /// Throttle of a camera, `O1@0:250:0`.
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "as_text")]
    pub throttle: Vec<ThrottleSpec>,
}

impl ExtraFaults {
    pub fn is_empty(&self) -> bool {
        self.black.is_empty() && self.kill.is_empty() && self.throttle.is_empty()
    }
}

/// A list of fault specifications as their command-line text.
mod as_text {
    use std::fmt::Display;
    use std::str::FromStr;

    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<T: Display, S: Serializer>(items: &[T], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(items.iter().map(ToString::to_string))
    }

    pub fn deserialize<'de, T, D>(d: D) -> Result<Vec<T>, D::Error>
    where
        T: FromStr,
        T::Err: Display,
        D: Deserializer<'de>,
    {
        Vec::<String>::deserialize(d)?
            .iter()
            .map(|text| text.parse().map_err(serde::de::Error::custom))
            .collect()
    }
}

/// A fault the launcher injects.
#[derive(Debug, Clone, PartialEq)]
pub enum Injected {
    /// Published on `fault/Oi` before the clock starts.
    Message(Fault),
    /// SIGKILL of the camera process once the clock reaches `at_ns`.
    KillCamera { observer: ObserverId, at_ns: u64 },
}

impl Injected {
    /// The observer whose camera the fault hits.
    pub fn observer(&self) -> &ObserverId {
        match self {
            Injected::Message(m) => &m.observer,
            Injected::KillCamera { observer, .. } => observer,
        }
    }

    /// The sim time from which `o`'s stream stops, if this is such a fault.
    pub fn dropout_from(&self, o: &ObserverId) -> Option<u64> {
        match self {
            Injected::Message(Fault {
                observer,
                kind: FaultKind::StreamDropout,
                from_ns,
                ..
            }) if observer == o => Some(*from_ns),
            _ => None,
        }
    }

    /// The throttle on `o`'s camera, if this is one (handed to the camera on its command line).
    pub fn throttle_of(&self, o: &ObserverId) -> Option<node_args::CameraThrottle> {
        match self {
            Injected::Message(Fault {
                observer,
                kind:
                    FaultKind::Throttle {
                        drop_per_mille,
                        delay_ms,
                    },
                from_ns,
                until_ns: None,
            }) if observer == o => Some(node_args::CameraThrottle {
                from_ns: *from_ns,
                drop_per_mille: *drop_per_mille,
                delay_ms: *delay_ms,
            }),
            _ => None,
        }
    }

    /// True for black input of `o` from start-up (its camera starts black).
    pub fn black_from_start(&self, o: &ObserverId) -> bool {
        matches!(self, Injected::Message(Fault { observer, kind: FaultKind::BlackInput, from_ns: 0, .. }) if observer == o)
    }
}

fn secs_ns(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

/// The stream stops at exactly `at_ns` of sim time: the camera publishes nothing from its
/// render at `at_ns` on, so what its observer received does not depend on when the SIGKILL
/// that follows lands (wall-clock time never decides what an observer sees).
fn dropout(observer: ObserverId, at_ns: u64) -> Injected {
    Injected::Message(Fault {
        observer,
        kind: FaultKind::StreamDropout,
        from_ns: at_ns,
        until_ns: None,
    })
}

fn black(observer: ObserverId) -> Injected {
    Injected::Message(Fault {
        observer,
        kind: FaultKind::BlackInput,
        from_ns: 0,
        until_ns: None,
    })
}

fn throttle(observer: ObserverId, from_s: f64, drop_per_mille: u16, delay_ms: u32) -> Injected {
    Injected::Message(Fault {
        observer,
        kind: FaultKind::Throttle {
            drop_per_mille,
            delay_ms,
        },
        from_ns: secs_ns(from_s),
        until_ns: None,
    })
}

/// The case's faults then the extra ones, each checked against the case's observers.
pub fn injected_faults(case: &Case, extra: &ExtraFaults) -> anyhow::Result<Vec<Injected>> {
    let mut out = Vec::new();
    for f in &case.faults {
        let observer = ObserverId::new(f.observer.as_str())?;
        match f.kind {
            CaseFault::Black => out.push(black(observer)),
            CaseFault::Dropout => {
                out.push(dropout(observer.clone(), secs_ns(f.at_s)));
                out.push(Injected::KillCamera {
                    observer,
                    at_ns: secs_ns(f.at_s),
                });
            }
            CaseFault::Throttle => {
                out.push(throttle(observer, f.at_s, f.drop_per_mille, f.delay_ms));
            }
        }
    }
    out.extend(extra.black.iter().map(|b| black(b.observer.clone())));
    for k in &extra.kill {
        out.push(dropout(k.observer.clone(), secs_ns(k.at_s)));
        out.push(Injected::KillCamera {
            observer: k.observer.clone(),
            at_ns: secs_ns(k.at_s),
        });
    }
    out.extend(
        extra
            .throttle
            .iter()
            .map(|t| throttle(t.observer.clone(), t.from_s, t.drop_per_mille, t.delay_ms)),
    );
    let names: Vec<String> = (0..case.observers).map(observer_name).collect();
    for f in &out {
        let o = f.observer();
        if !names.iter().any(|n| n == o.as_str()) {
            return Err(UnknownObserver {
                observer: o.clone(),
                have: names.join(", "),
            }
            .into());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs_parse_and_bad_ones_name_the_input() {
        let k: KillSpec = "O2@35".parse().unwrap();
        assert_eq!((k.observer.as_str(), k.at_s), ("O2", 35.0));
        let t: ThrottleSpec = "O1@0:250:7".parse().unwrap();
        assert_eq!(
            (t.observer.as_str(), t.from_s, t.drop_per_mille, t.delay_ms),
            ("O1", 0.0, 250, 7)
        );
        let b: BlackSpec = "O3".parse().unwrap();
        assert_eq!(b.observer.as_str(), "O3");
        for (bad, needle) in [
            ("O2", "OBSERVER@SECONDS"),
            ("O2@-1", "\"-1\" must be a non-negative number"),
            ("O2@x", "\"x\""),
        ] {
            let e = bad.parse::<KillSpec>().unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(needle), "{e}");
        }
        for (bad, needle) in [
            ("O1@0:250", "OBSERVER@FROM_S"),
            ("O1@0:1001:0", "\"1001\""),
            ("O1@0:10:x", "delay \"x\""),
            ("O1@nan:10:0", "start \"nan\""),
        ] {
            let e = bad.parse::<ThrottleSpec>().unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(needle), "{e}");
        }
    }

    #[test]
    fn a_fault_on_an_observer_the_case_lacks_is_rejected() {
        let case = Case::load("only-a").unwrap();
        let extra = ExtraFaults {
            kill: vec!["O5@1".parse().unwrap()],
            ..ExtraFaults::default()
        };
        let e = injected_faults(&case, &extra).unwrap_err().to_string();
        assert!(
            e.contains("fault names O5, but the case has O1, O2, O3"),
            "{e}"
        );
    }
}
