//! Faults the launcher injects: the case's `[[faults]]` plus the command line's `--black O2`,
//! `--kill O2@35` and `--throttle O1@0:250:0` (or a compose file's `[faults]`), each parsed by
//! [`FromStr`](std::str::FromStr) (so clap rejects a bad one naming it) and checked against the
//! case's observers. Checking a compose file needs them, so they live beside it; `deploy`
//! injects them.

use proto::scene::observer_name;
use proto::{Fault, FaultKind, KeyError, ObserverId};
use run_format::case::{Case, CaseFaultKind as CaseFault};

pub use commands::fault::{BlackSpec, FaultSpecError, KillSpec, ThrottleSpec};

/// A fault names an observer the case does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("fault names {observer}, but the case has {have}")]
pub struct UnknownObserver {
    pub observer: ObserverId,
    pub have: String,
}

/// Why a case's and a file's faults cannot be injected.
#[derive(Debug, thiserror::Error)]
pub enum FaultError {
    /// A case's fault names no valid observer id.
    #[error(transparent)]
    Observer(#[from] KeyError),
    /// A fault names an observer the case does not have.
    #[error(transparent)]
    Unknown(#[from] UnknownObserver),
}

/// Faults injected beyond the case's own: the command line's `--black`, `--kill` and
/// `--throttle`, and a compose file's `[faults]` table, where each is written as on the command
/// line (`black = ["O2"]`, `kill = ["O2@35"]`, `throttle = ["O1@0:250:0"]`) and parsed by the
/// same [`FromStr`](std::str::FromStr), so a bad one is refused naming it.
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
///
/// # Errors
///
/// When a fault names an observer that is not a valid id or that the case does not have.
pub fn injected_faults(case: &Case, extra: &ExtraFaults) -> Result<Vec<Injected>, FaultError> {
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
