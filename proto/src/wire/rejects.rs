//! What a process refused (`rejects/<role>/<id>`): every message it dropped instead of
//! obeying, counted by key and reason, published once as it ends (docs/DESIGN.md §11: a
//! hostile or broken peer must never abort a run, and nothing it sends may be obeyed silently).

use serde::{Deserialize, Serialize};

use crate::codec::Validate;

/// Why a message was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum RejectReason {
    /// The bytes are not a message of the key's type (wrong version, truncated, junk, too
    /// large, or internally inconsistent).
    Undecodable,
    /// A key the process subscribed to by wildcard but that names nothing of this session
    /// (an unknown observer, a key outside the grammar).
    UnexpectedKey,
    /// A well-formed message that breaks the protocol: a tick already past or too far ahead,
    /// a duplicate, a body naming another observer than its key, a stamp out of sequence.
    OutOfContract,
}

impl RejectReason {
    pub fn as_str(self) -> &'static str {
        match self {
            RejectReason::Undecodable => "undecodable",
            RejectReason::UnexpectedKey => "unexpected key",
            RejectReason::OutOfContract => "out of contract",
        }
    }
}

impl std::fmt::Display for RejectReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How many messages on one key were dropped for one reason.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RejectCount {
    /// The key after `waggle/<session>/` (or the whole key when it is outside the session).
    pub key: String,
    pub reason: RejectReason,
    pub count: u64,
}

/// Every message one process dropped, sorted by key then reason.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RejectReport {
    /// The process (`sim`, `camera-O1`, `observer-O2`, …).
    pub process: String,
    pub counts: Vec<RejectCount>,
}

impl RejectReport {
    /// Total messages dropped.
    pub fn total(&self) -> u64 {
        self.counts.iter().map(|c| c.count).sum()
    }
}

impl Validate for RejectReport {
    fn validate(&self) -> Result<(), String> {
        if self.process.is_empty() {
            return Err("reject report without a process".into());
        }
        if let Some(c) = self.counts.iter().find(|c| c.count == 0) {
            return Err(format!("reject count of zero on {}", c.key));
        }
        let sorted = self
            .counts
            .windows(2)
            .all(|w| (&w[0].key, w[0].reason) < (&w[1].key, w[1].reason));
        if !sorted {
            return Err("reject counts not sorted by key and reason, or repeated".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(key: &str, reason: RejectReason, n: u64) -> RejectCount {
        RejectCount {
            key: key.into(),
            reason,
            count: n,
        }
    }

    #[test]
    fn a_report_round_trips_and_bad_ones_are_refused() {
        let r = RejectReport {
            process: "sim".into(),
            counts: vec![
                count("clock", RejectReason::Undecodable, 3),
                count("sched/cmd", RejectReason::Undecodable, 1),
                count("sched/cmd", RejectReason::OutOfContract, 2),
            ],
        };
        assert_eq!(
            crate::decode::<RejectReport>(&crate::encode(&r)).unwrap(),
            r
        );
        assert_eq!(r.total(), 6);
        let mut unsorted = r.clone();
        unsorted.counts.swap(0, 2);
        assert!(unsorted.validate().is_err());
        let mut zero = r.clone();
        zero.counts[0].count = 0;
        assert!(zero.validate().is_err());
        let nameless = RejectReport {
            process: String::new(),
            counts: vec![],
        };
        assert!(nameless.validate().is_err());
    }
}
