//! Why a mission ended: the scheduler's verdict, carried by `sched/report` and written into
//! every summary. On the wire and in JSON it is its name (`"RoundsComplete"`, …), so the bytes
//! are those of the text it replaced and a name no build knows is refused when decoding.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::modality::{UnknownName, parse_name};

/// Why the mission ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EndReason {
    /// Rule (a): the last round settled (every trip back home).
    RoundsComplete,
    /// Rule (a): a round settled with no work left anywhere, so no further round can help.
    AllWorkDone,
    /// Rule (b): a round's decision deadline passed without any observer deciding.
    NoDecision,
    /// Rule (c): a round broadcast nothing and its idle period elapsed.
    NoBroadcast,
    /// The case's hard time limit.
    TimeLimit,
}

impl EndReason {
    pub const ALL: [EndReason; 5] = [
        EndReason::RoundsComplete,
        EndReason::AllWorkDone,
        EndReason::NoDecision,
        EndReason::NoBroadcast,
        EndReason::TimeLimit,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            EndReason::RoundsComplete => "RoundsComplete",
            EndReason::AllWorkDone => "AllWorkDone",
            EndReason::NoDecision => "NoDecision",
            EndReason::NoBroadcast => "NoBroadcast",
            EndReason::TimeLimit => "TimeLimit",
        }
    }
}

impl std::fmt::Display for EndReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for EndReason {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        parse_name(
            &EndReason::ALL,
            EndReason::as_str,
            s,
            "end reason",
            "RoundsComplete, AllWorkDone, NoDecision, NoBroadcast, TimeLimit",
        )
    }
}

impl Serialize for EndReason {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for EndReason {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_end_reason_is_its_name_on_the_wire_and_in_json() {
        for r in EndReason::ALL {
            // The bytes of the text field it replaced: old recordings still decode.
            let text = r.as_str().to_string();
            assert_eq!(crate::encode(&r), crate::encode(&text));
            assert_eq!(serde_json::to_string(&r).unwrap(), format!("\"{text}\""));
            assert_eq!(
                serde_json::from_str::<EndReason>(&format!("\"{text}\"")).unwrap(),
                r
            );
            assert_eq!(text.parse::<EndReason>().unwrap(), r);
        }
        let err = serde_json::from_str::<EndReason>("\"Bored\"").unwrap_err();
        assert!(err.to_string().contains("Bored"), "{err}");
    }
}
