//! Case files: which mission to fly, which faults to inject, and what the outcome must be.
//!
//! Built-in cases are the TOML files in `deploy/cases/`, compiled into the binary; a path to a
//! TOML file of the same shape works too. Unknown keys are rejected.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use proto::Modality;
use serde::Deserialize;

/// Built-in cases (name, TOML text), in the paper's table order.
pub const BUILT_IN: &[(&str, &str)] = &[
    // The paper's functional cases (`PAPER_CASES`), then the larger groups.
    ("one-observer", include_str!("../cases/one-observer.toml")),
    ("two-observers", include_str!("../cases/two-observers.toml")),
    ("nominal-3", include_str!("../cases/nominal-3.toml")),
    ("black-o2", include_str!("../cases/black-o2.toml")),
    ("no-broadcast", include_str!("../cases/no-broadcast.toml")),
    ("only-a", include_str!("../cases/only-a.toml")),
    ("dropout-o2", include_str!("../cases/dropout-o2.toml")),
    (
        "four-observers",
        include_str!("../cases/four-observers.toml"),
    ),
    ("six-observers", include_str!("../cases/six-observers.toml")),
    (
        "eight-observers",
        include_str!("../cases/eight-observers.toml"),
    ),
];

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

pub use proto::{FlightMode, Receiver};

/// The TOML text of a case given by name or path (what [`Case::load`] parses).
pub fn case_source(name_or_path: &str) -> Result<String> {
    match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, text)) => Ok((*text).to_string()),
        None => std::fs::read_to_string(name_or_path)
            .with_context(|| format!("reading case file {name_or_path}")),
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
    pub observer: String,
    pub kind: CaseFaultKind,
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

/// A time field must be a finite number of seconds in `0..=MAX_TIME_S`.
fn check_time_s(field: &str, value_s: f64) -> Result<()> {
    if !(value_s.is_finite() && (0.0..=MAX_TIME_S).contains(&value_s)) {
        bail!("{field} = {value_s} must be a finite number of seconds in 0..={MAX_TIME_S}");
    }
    Ok(())
}

/// A case file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    pub name: String,
    pub observers: usize,
    /// Sites the performer advertises each round, in order (empty: no broadcast).
    #[serde(default = "default_sites")]
    pub offer_sites: Vec<String>,
    #[serde(default = "default_rounds")]
    pub rounds: u32,
    /// Sensor modalities this case applies to (`rgb`, `events`; default both — every built-in
    /// case states it). The ideal receiver can fly every case.
    #[serde(default = "default_modalities")]
    pub modalities: Vec<Receiver>,
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Hard limit on simulated time.
    #[serde(default)]
    pub time_limit_s: Option<f64>,
    /// Safety router: `sequential` (default, one trip at a time, the paper) or `concurrent`
    /// (trips overlap on checked space-time reservations).
    #[serde(default)]
    pub flights: FlightMode,
    pub expected: Expected,
}

impl Case {
    /// A built-in case by name, or a TOML file by path.
    pub fn load(name_or_path: &str) -> Result<Self> {
        let (origin, text) = match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
            Some((n, t)) => (format!("built-in case {n}"), (*t).to_string()),
            None => {
                let path = Path::new(name_or_path);
                if !path.exists() {
                    let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
                    bail!(
                        "{name_or_path:?} is neither a built-in case ({}) nor a file",
                        names.join(", ")
                    );
                }
                (
                    path.display().to_string(),
                    std::fs::read_to_string(path)
                        .with_context(|| format!("reading {}", path.display()))?,
                )
            }
        };
        Self::from_text(&text, &origin)
    }

    /// A case from its TOML text; `origin` names it in errors.
    pub fn from_text(text: &str, origin: &str) -> Result<Self> {
        let case: Case = toml::from_str(text).with_context(|| format!("parsing {origin}"))?;
        case.check().with_context(|| format!("checking {origin}"))?;
        Ok(case)
    }

    /// Checks every field, naming the bad one, so a case is refused before any process
    /// starts (a child failing at start-up is not a validation).
    fn check(&self) -> Result<()> {
        if self.name.trim().is_empty() {
            bail!("name is empty");
        }
        if self.rounds == 0 {
            bail!("rounds = 0: a mission has at least one round");
        }
        if self.rounds > MAX_ROUNDS {
            bail!("rounds = {} exceeds {MAX_ROUNDS}", self.rounds);
        }
        if let Some(limit) = self.time_limit_s {
            check_time_s("time_limit_s", limit)?;
            if limit == 0.0 {
                bail!("time_limit_s = 0 would end the mission before it starts");
            }
        }
        if !(1..=proto::scene::MAX_OBSERVERS).contains(&self.observers) {
            bail!(
                "observers = {} is outside 1..={}",
                self.observers,
                proto::scene::MAX_OBSERVERS
            );
        }
        let names: Vec<String> = (0..self.observers)
            .map(proto::scene::observer_name)
            .collect();
        for f in &self.faults {
            if !names.contains(&f.observer) {
                bail!(
                    "fault names observer {:?}, but the case has {}",
                    f.observer,
                    names.join(", ")
                );
            }
            check_time_s(&format!("faults[{}].at_s", f.observer), f.at_s)?;
            if f.delay_ms > MAX_DELAY_MS {
                bail!(
                    "faults[{}].delay_ms = {} exceeds {MAX_DELAY_MS} ms",
                    f.observer,
                    f.delay_ms
                );
            }
            if f.drop_per_mille > 1000 {
                bail!("fault drop_per_mille = {} exceeds 1000", f.drop_per_mille);
            }
            if f.kind != CaseFaultKind::Throttle && (f.drop_per_mille != 0 || f.delay_ms != 0) {
                bail!("drop_per_mille and delay_ms apply to throttle faults only");
            }
        }
        for (i, f) in self.faults.iter().enumerate() {
            if self.faults[..i]
                .iter()
                .any(|g| g.observer == f.observer && g.kind == f.kind)
            {
                bail!(
                    "faults: two {:?} faults on {} (one per observer and kind)",
                    f.kind,
                    f.observer
                );
            }
        }
        for s in &self.offer_sites {
            s.parse::<proto::Site>()
                .map_err(|e| anyhow::anyhow!("offer_sites: {e}"))?;
        }
        if self.modalities.is_empty()
            || self.modalities.contains(&Receiver::Ideal)
            || (1..self.modalities.len())
                .any(|i| self.modalities[..i].contains(&self.modalities[i]))
        {
            bail!(
                "modalities = {:?}: list rgb and/or events, each once (ideal applies to every case)",
                self.modalities
            );
        }
        if self.expected.messages.len() != self.observers {
            bail!(
                "expected.messages has {} entries for {} observers",
                self.expected.messages.len(),
                self.observers
            );
        }
        for (o, sites) in &self.expected.services {
            if !names.contains(o) {
                bail!("expected.services names unknown observer {o:?}");
            }
            for s in sites {
                s.parse::<proto::Site>()
                    .map_err(|e| anyhow::anyhow!("expected.services.{o}: {e}"))?;
            }
        }
        Ok(())
    }

    /// Sim time (ns) at which `observer`'s stream drops out, if it does.
    pub fn dropout_ns(&self, observer: &str) -> Option<u64> {
        self.faults
            .iter()
            .find(|f| f.observer == observer && f.kind == CaseFaultKind::Dropout)
            .map(|f| (f.at_s * 1e9).round() as u64)
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
pub fn run_modality(case: &Case, asked: Option<Modality>) -> Result<Modality> {
    let modality = match asked {
        Some(m) => m,
        None if case.modalities.contains(&Receiver::Events) => Modality::Events,
        None => Modality::Rgb,
    };
    if !case.modalities.contains(&Receiver::from(modality)) {
        bail!(
            "case {} does not apply to the {} modality (it lists {:?})",
            case.name,
            modality.as_str(),
            case.modalities
        );
    }
    Ok(modality)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        ] {
            let path = dir.join("case.toml");
            std::fs::write(&path, text).unwrap();
            let err = format!("{:#}", Case::load(path.to_str().unwrap()).unwrap_err());
            assert!(err.contains(needle) && err.contains("case.toml"), "{err}");
        }
        assert!(
            format!("{:#}", Case::load("nope").unwrap_err()).contains("neither a built-in case")
        );
    }
}
