//! Case files: which mission to fly, which faults to inject, and what the outcome must be.
//!
//! Built-in cases are the TOML files in `deploy/cases/`, compiled into the binary; a path to a
//! TOML file of the same shape works too. Unknown keys are rejected.

use std::collections::BTreeMap;
use std::path::Path;

use proto::Modality;
use serde::Deserialize;

/// Why a case could not be loaded, or does not apply.
#[derive(Debug, thiserror::Error)]
pub enum CaseError {
    /// Neither a built-in name nor an existing file.
    #[error("{name_or_path:?} is neither a built-in case ({built_in}) nor a file")]
    NotFound {
        name_or_path: String,
        /// The built-in names, comma-separated.
        built_in: String,
    },
    /// The case file could not be read ([`Case::load`]).
    #[error("reading {path}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The case file could not be read ([`case_source`]).
    #[error("reading case file {path}")]
    ReadCaseFile {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The text is not a case's TOML (syntax, unknown key, wrong type).
    #[error("parsing {origin}")]
    Parse {
        origin: String,
        #[source]
        source: toml::de::Error,
    },
    /// A field holds a value the case cannot have.
    #[error("checking {origin}")]
    Check {
        origin: String,
        #[source]
        source: CaseCheckError,
    },
    /// The case does not list the modality asked for.
    #[error("case {case} does not apply to the {} modality (it lists {listed:?})", modality.as_str())]
    ModalityNotListed {
        case: String,
        modality: Modality,
        listed: Vec<Receiver>,
    },
}

/// The field of a case that fails its check, and why.
#[derive(Debug, thiserror::Error)]
pub enum CaseCheckError {
    #[error("name is empty")]
    EmptyName,
    #[error("rounds = 0: a mission has at least one round")]
    NoRounds,
    #[error(
        "max_broadcasts = {0}: a round flies 1 to {max} broadcasts",
        max = proto::sched::MAX_ROUND_BROADCASTS
    )]
    MaxBroadcasts(u32),
    #[error("rounds = {0} exceeds {MAX_ROUNDS}")]
    TooManyRounds(u32),
    /// A time field (`field`) outside `0..=MAX_TIME_S` or not finite.
    #[error("{field} = {value_s} must be a finite number of seconds in 0..={MAX_TIME_S}")]
    Time { field: String, value_s: f64 },
    #[error("time_limit_s = 0 would end the mission before it starts")]
    ZeroTimeLimit,
    #[error("observers = {0} is outside 1..={max}", max = proto::scene::MAX_OBSERVERS)]
    ObserverCount(usize),
    /// A fault names an observer the case does not have.
    #[error("fault names observer {observer:?}, but the case has {}", names.join(", "))]
    UnknownFaultObserver {
        observer: String,
        names: Vec<String>,
    },
    #[error("faults[{observer}].delay_ms = {delay_ms} exceeds {MAX_DELAY_MS} ms")]
    DelayTooLong { observer: String, delay_ms: u32 },
    #[error("fault drop_per_mille = {0} exceeds 1000")]
    DropPerMille(u16),
    #[error("drop_per_mille and delay_ms apply to throttle faults only")]
    ThrottleTermsOnOtherFault,
    #[error("faults: two {kind:?} faults on {observer} (one per observer and kind)")]
    DuplicateFault {
        kind: CaseFaultKind,
        observer: String,
    },
    /// An `offer_sites` entry is not a site.
    #[error("offer_sites: {0}")]
    OfferSite(proto::PayloadError),
    /// A `work` entry names no site, or more units than [`MAX_WORK_UNITS`].
    #[error("work.{site} = {units}: {why}")]
    Work {
        site: String,
        units: u32,
        why: String,
    },
    #[error("modalities = {0:?}: list rgb and/or events, each once (ideal applies to every case)")]
    Modalities(Vec<Receiver>),
    #[error("expected.messages has {entries} entries for {observers} observers")]
    ExpectedMessages { entries: usize, observers: usize },
    #[error("expected.services names unknown observer {0:?}")]
    UnknownServiceObserver(String),
    /// An `expected.services.<observer>` entry is not a site.
    #[error("expected.services.{observer}: {error}")]
    ServiceSite {
        observer: String,
        error: proto::PayloadError,
    },
}

/// Built-in cases (name, TOML text), in the paper's table order.
pub const BUILT_IN: &[(&str, &str)] = &[
    // The paper's functional cases (`PAPER_CASES`), then the larger groups.
    (
        "one-observer",
        include_str!("../../../deploy/cases/one-observer.toml"),
    ),
    (
        "two-observers",
        include_str!("../../../deploy/cases/two-observers.toml"),
    ),
    (
        "nominal-3",
        include_str!("../../../deploy/cases/nominal-3.toml"),
    ),
    (
        "black-o2",
        include_str!("../../../deploy/cases/black-o2.toml"),
    ),
    (
        "no-broadcast",
        include_str!("../../../deploy/cases/no-broadcast.toml"),
    ),
    ("only-a", include_str!("../../../deploy/cases/only-a.toml")),
    (
        "dropout-o2",
        include_str!("../../../deploy/cases/dropout-o2.toml"),
    ),
    (
        "four-observers",
        include_str!("../../../deploy/cases/four-observers.toml"),
    ),
    (
        "six-observers",
        include_str!("../../../deploy/cases/six-observers.toml"),
    ),
    (
        "eight-observers",
        include_str!("../../../deploy/cases/eight-observers.toml"),
    ),
    // Long runs: many rounds over an hour of sim time.
    (
        "long-hour",
        include_str!("../../../deploy/cases/long-hour.toml"),
    ),
];

/// The help of a command's case argument: every built-in case by name, so no help text keeps
/// its own list.
pub fn case_arg_help() -> String {
    let names: Vec<&str> = BUILT_IN.iter().map(|(name, _)| *name).collect();
    format!(
        "Built-in case name ({}) or a path to a case TOML file",
        names.join(", ")
    )
}

/// The built-in cases the paper ran (its functional-case table), in its order: what
/// `waggle sweep` runs by default.
pub const PAPER_CASES: &[&str] = &[
    "one-observer",
    "two-observers",
    "nominal-3",
    "black-o2",
    "no-broadcast",
    "only-a",
    "dropout-o2",
];

use proto::{FlightMode, Receiver};

/// The TOML text of a case given by name or path (what [`Case::load`] parses).
pub fn case_source(name_or_path: &str) -> Result<String, CaseError> {
    match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, text)) => Ok((*text).to_string()),
        None => std::fs::read_to_string(name_or_path).map_err(|source| CaseError::ReadCaseFile {
            path: name_or_path.to_string(),
            source,
        }),
    }
}

/// What a case's fault does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CaseFaultKind {
    /// Black frames from start-up, before event conversion.
    Black,
    /// The sensor stream stops at `at_s` (`waggle run`: the camera process is killed).
    Dropout,
    /// From `at_s` on, the camera drops `drop_per_mille` ‰ of its packets and delays the rest
    /// by `delay_ms` of wall-clock time (`waggle run` only).
    Throttle,
}

/// One `[[faults]]` entry of a case.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// The observer whose camera is hit (`O2`).
    pub observer: String,
    /// What happens to it: `black`, `kill` or `throttle`.
    pub kind: CaseFaultKind,
    /// When, in sim seconds (default 0).
    #[serde(default)]
    pub at_s: f64,
    /// Throttle only: packets dropped per thousand.
    #[serde(default)]
    pub drop_per_mille: u16,
    /// Throttle only: wall-clock delay of each packet, ms.
    #[serde(default)]
    pub delay_ms: u32,
}

/// The `[expected]` outcome of a case.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expected {
    /// Complete messages (released frames with a valid offer) per observer, O1 first.
    pub messages: Vec<usize>,
    /// Work units completed by the whole group.
    pub work_units: u32,
    /// Sites of each observer's completed services, in order.
    pub services: BTreeMap<String, Vec<String>>,
}

fn default_sites() -> Vec<String> {
    vec!["A".into(), "B".into()]
}

fn default_rounds() -> u32 {
    2
}

fn default_max_broadcasts() -> u32 {
    1
}

fn default_modalities() -> Vec<Receiver> {
    vec![Receiver::Rgb, Receiver::Events]
}

/// The longest sim time a case may name (a time limit or a fault instant), s: far beyond any
/// mission, and small enough that its nanoseconds fit a `u64` exactly.
pub const MAX_TIME_S: f64 = 1.0e6;
/// The most rounds a case may ask for.
pub const MAX_ROUNDS: u32 = 1000;
/// The longest throttle delay a case may ask for, ms.
pub const MAX_DELAY_MS: u32 = 60_000;
/// The most work units a case may give one site.
pub const MAX_WORK_UNITS: u32 = 10_000;

/// A time field must be a finite number of seconds in `0..=MAX_TIME_S`.
fn check_time_s(field: &str, value_s: f64) -> Result<(), CaseCheckError> {
    if !(value_s.is_finite() && (0.0..=MAX_TIME_S).contains(&value_s)) {
        return Err(CaseCheckError::Time {
            field: field.to_string(),
            value_s,
        });
    }
    Ok(())
}

/// A case file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// The case's name, as reports and recordings give it.
    pub name: String,
    /// Observer drones, O1 … On (1 to 8).
    pub observers: usize,
    /// Sites the performer advertises each round, in order (empty: no broadcast).
    #[serde(default = "default_sites")]
    pub offer_sites: Vec<String>,
    /// Broadcast rounds of `offer_sites` (default 2).
    #[serde(default = "default_rounds")]
    pub rounds: u32,
    /// Initial work units per site, `{ A = 24, B = 40 }`, instead of the default `max(1, N−1)`
    /// at A and `N+1` at B; a site not named keeps its default.
    #[serde(default)]
    pub work: BTreeMap<String, u32>,
    /// Broadcasts a round may fly (default 1, the paper's one-shot): while a live observer has
    /// not decided when a broadcast's window would close, the round's offers are flown again.
    #[serde(default = "default_max_broadcasts")]
    pub max_broadcasts: u32,
    /// The check every frame carries after its six payload bits (`none`, the paper's frame;
    /// `parity`; `crc3`): a frame whose check disagrees is never released.
    #[serde(default)]
    pub frame_check: proto::FrameCheck,
    /// Sensor modalities this case applies to (`rgb`, `events`; default both — every built-in
    /// case states it). The ideal receiver can fly every case.
    #[serde(default = "default_modalities")]
    pub modalities: Vec<Receiver>,
    /// Faults the case injects (`[[faults]]`).
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Hard limit on simulated time.
    #[serde(default)]
    pub time_limit_s: Option<f64>,
    /// Safety router: `sequential` (default, one trip at a time, the paper) or `concurrent`
    /// (trips overlap on checked space-time reservations).
    #[serde(default)]
    pub flights: FlightMode,
    /// The outcome the audit checks (`[expected]`).
    pub expected: Expected,
}

impl Case {
    /// A built-in case by name, or a TOML file by path.
    pub fn load(name_or_path: &str) -> Result<Self, CaseError> {
        let (origin, text) = match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
            Some((n, t)) => (format!("built-in case {n}"), (*t).to_string()),
            None => {
                let path = Path::new(name_or_path);
                if !path.exists() {
                    let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
                    return Err(CaseError::NotFound {
                        name_or_path: name_or_path.to_string(),
                        built_in: names.join(", "),
                    });
                }
                let text = std::fs::read_to_string(path).map_err(|source| CaseError::Read {
                    path: path.display().to_string(),
                    source,
                })?;
                (path.display().to_string(), text)
            }
        };
        Self::from_text(&text, &origin)
    }

    /// A case from its TOML text; `origin` names it in errors.
    pub fn from_text(text: &str, origin: &str) -> Result<Self, CaseError> {
        let case: Case = toml::from_str(text).map_err(|source| CaseError::Parse {
            origin: origin.to_string(),
            source,
        })?;
        case.check().map_err(|source| CaseError::Check {
            origin: origin.to_string(),
            source,
        })?;
        Ok(case)
    }

    /// Checks every field, naming the bad one, so a case is refused before any process
    /// starts (a child failing at start-up is not a validation).
    fn check(&self) -> Result<(), CaseCheckError> {
        use CaseCheckError as E;
        if self.name.trim().is_empty() {
            return Err(E::EmptyName);
        }
        if self.rounds == 0 {
            return Err(E::NoRounds);
        }
        if self.rounds > MAX_ROUNDS {
            return Err(E::TooManyRounds(self.rounds));
        }
        if !(1..=proto::sched::MAX_ROUND_BROADCASTS).contains(&self.max_broadcasts) {
            return Err(E::MaxBroadcasts(self.max_broadcasts));
        }
        if let Some(limit) = self.time_limit_s {
            check_time_s("time_limit_s", limit)?;
            if limit == 0.0 {
                return Err(E::ZeroTimeLimit);
            }
        }
        if !(1..=proto::scene::MAX_OBSERVERS).contains(&self.observers) {
            return Err(E::ObserverCount(self.observers));
        }
        let names: Vec<String> = (0..self.observers)
            .map(proto::scene::observer_name)
            .collect();
        for f in &self.faults {
            if !names.contains(&f.observer) {
                return Err(E::UnknownFaultObserver {
                    observer: f.observer.clone(),
                    names,
                });
            }
            check_time_s(&format!("faults[{}].at_s", f.observer), f.at_s)?;
            if f.delay_ms > MAX_DELAY_MS {
                return Err(E::DelayTooLong {
                    observer: f.observer.clone(),
                    delay_ms: f.delay_ms,
                });
            }
            if f.drop_per_mille > 1000 {
                return Err(E::DropPerMille(f.drop_per_mille));
            }
            if f.kind != CaseFaultKind::Throttle && (f.drop_per_mille != 0 || f.delay_ms != 0) {
                return Err(E::ThrottleTermsOnOtherFault);
            }
        }
        for (i, f) in self.faults.iter().enumerate() {
            if self.faults[..i]
                .iter()
                .any(|g| g.observer == f.observer && g.kind == f.kind)
            {
                return Err(E::DuplicateFault {
                    kind: f.kind,
                    observer: f.observer.clone(),
                });
            }
        }
        for s in &self.offer_sites {
            s.parse::<proto::Site>().map_err(E::OfferSite)?;
        }
        self.work_units()?;
        if self.modalities.is_empty()
            || self.modalities.contains(&Receiver::Ideal)
            || (1..self.modalities.len())
                .any(|i| self.modalities[..i].contains(&self.modalities[i]))
        {
            return Err(E::Modalities(self.modalities.clone()));
        }
        if self.expected.messages.len() != self.observers {
            return Err(E::ExpectedMessages {
                entries: self.expected.messages.len(),
                observers: self.observers,
            });
        }
        for (o, sites) in &self.expected.services {
            if !names.contains(o) {
                return Err(E::UnknownServiceObserver(o.clone()));
            }
            for s in sites {
                s.parse::<proto::Site>().map_err(|error| E::ServiceSite {
                    observer: o.clone(),
                    error,
                })?;
            }
        }
        Ok(())
    }

    /// The initial work units the case sets, by site (empty: the default task state); an
    /// entry naming no site, or more than [`MAX_WORK_UNITS`], is refused naming it.
    pub fn work_units(&self) -> Result<BTreeMap<proto::Site, u32>, CaseCheckError> {
        let mut out = BTreeMap::new();
        for (name, units) in &self.work {
            let bad = |why: String| CaseCheckError::Work {
                site: name.clone(),
                units: *units,
                why,
            };
            // Only the names a case writes elsewhere (`A`, `B`), not the payload ids.
            if !["A", "B"].contains(&name.as_str()) {
                return Err(bad("the sites are A and B".into()));
            }
            let site: proto::Site = name.parse().map_err(|e| bad(format!("{e}")))?;
            if *units > MAX_WORK_UNITS {
                return Err(bad(format!("at most {MAX_WORK_UNITS} units per site")));
            }
            out.insert(site, *units);
        }
        Ok(out)
    }

    /// The `--work` argument of the scheduler, `A=24,B=40`, when the case sets any.
    pub fn work_arg(&self) -> Option<String> {
        (!self.work.is_empty()).then(|| {
            self.work
                .iter()
                .map(|(site, units)| format!("{site}={units}"))
                .collect::<Vec<_>>()
                .join(",")
        })
    }

    /// Sim time (ns) at which `observer`'s stream drops out, if it does.
    pub fn dropout_ns(&self, observer: &str) -> Option<u64> {
        self.faults
            .iter()
            .find(|f| f.observer == observer && f.kind == CaseFaultKind::Dropout)
            .map(|f| (f.at_s * 1e9).round() as u64)
    }

    /// True if `observer` (O1, O2, …) is one of the case's observers.
    pub fn has_observer(&self, observer: &str) -> bool {
        (0..self.observers).any(|i| proto::scene::observer_name(i) == observer)
    }

    /// True if `observer`'s input is black from start-up.
    pub fn black(&self, observer: &str) -> bool {
        self.faults
            .iter()
            .any(|f| f.observer == observer && f.kind == CaseFaultKind::Black)
    }
}

/// The modality to run `case` in: `asked`, or events when the case applies to it (else RGB);
/// an error when the case does not apply to it.
pub fn run_modality(case: &Case, asked: Option<Modality>) -> Result<Modality, CaseError> {
    let modality = match asked {
        Some(m) => m,
        None if case.modalities.contains(&Receiver::Events) => Modality::Events,
        None => Modality::Rgb,
    };
    if !case.modalities.contains(&Receiver::from(modality)) {
        return Err(CaseError::ModalityNotListed {
            case: case.name.clone(),
            modality,
            listed: case.modalities.clone(),
        });
    }
    Ok(modality)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error and its causes, `: `-joined (as `anyhow` prints `{:#}`).
    fn chain(e: &dyn std::error::Error) -> String {
        let mut out = e.to_string();
        let mut cause = e.source();
        while let Some(c) = cause {
            out = format!("{out}: {c}");
            cause = c.source();
        }
        out
    }

    #[test]
    fn every_built_in_case_loads_and_states_its_modalities() {
        for (name, text) in BUILT_IN {
            let c = Case::load(name).unwrap();
            assert_eq!(&c.name, name);
            assert!(
                text.lines().any(|l| l.starts_with("modalities = ")),
                "{name} does not state its modalities"
            );
        }
        let events_only = Case::load("dropout-o2").unwrap();
        assert_eq!(events_only.modalities, [Receiver::Events]);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_rejected_with_the_origin_named() {
        let dir = std::env::temp_dir().join(format!("waggle-case-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (text, needle) in [
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nbogus=1\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "bogus",
            ),
            (
                "name='x'\nobservers=9\nmodalities=['rgb']\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "outside",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\noffer_sites=['C']\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "offer_sites",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\n[[faults]]\nobserver='O4'\nkind='black'\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "O4",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['events','events']\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "each once",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['ideal']\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "ideal applies",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\ntime_limit_s=nan\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "time_limit_s = NaN",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\ntime_limit_s=-10\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "time_limit_s = -10",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\ntime_limit_s=inf\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "time_limit_s = inf",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\ntime_limit_s=0\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "time_limit_s = 0",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nmax_broadcasts=0\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "max_broadcasts = 0",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nmax_broadcasts=9\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "max_broadcasts = 9",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nframe_check='crc8'\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "frame_check",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nrounds=0\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "rounds = 0",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nrounds=-1\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "rounds",
            ),
            (
                "name=''\nobservers=1\nmodalities=['rgb']\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "name is empty",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\n[[faults]]\nobserver='O1'\nkind='dropout'\nat_s=nan\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "faults[O1].at_s = NaN",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\n[[faults]]\nobserver='O1'\nkind='dropout'\nat_s=1e300\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "faults[O1].at_s",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\n[[faults]]\nobserver='O1'\nkind='dropout'\nat_s=3\n[[faults]]\nobserver='O1'\nkind='dropout'\nat_s=4\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "two Dropout faults on O1",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\n[[faults]]\nobserver='O1'\nkind='throttle'\ndelay_ms=99999999\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "delay_ms",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nwork={C=3}\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "work.C = 3",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nwork={A=10001}\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "work.A = 10001",
            ),
            (
                "name='x'\nobservers=1\nmodalities=['rgb']\nwork={A=-1}\n[expected]\nmessages=[0]\nwork_units=0\nservices={}\n",
                "work",
            ),
        ] {
            let path = dir.join("case.toml");
            std::fs::write(&path, text).unwrap();
            let err = chain(&Case::load(path.to_str().unwrap()).unwrap_err());
            assert!(err.contains(needle) && err.contains("case.toml"), "{err}");
        }
        assert!(chain(&Case::load("nope").unwrap_err()).contains("neither a built-in case"));
    }

    #[test]
    fn work_units_reach_the_scheduler_argument_only_when_set() {
        let c = Case::load("long-hour").unwrap();
        assert_eq!(c.work_arg().as_deref(), Some("A=24,B=40"));
        let units = c.work_units().unwrap();
        assert_eq!(units[&proto::Site::A], 24);
        assert_eq!(units[&proto::Site::B], 40);
        for (name, _) in BUILT_IN.iter().filter(|(n, _)| *n != "long-hour") {
            let c = Case::load(name).unwrap();
            assert_eq!(c.work_arg(), None, "{name}");
            assert!(c.work_units().unwrap().is_empty());
        }
    }
}
