//! Counting what a process refuses instead of aborting on it.
//!
//! Every message a process receives goes through [`Rejects`]: undecodable bytes, keys that
//! name nothing of the session and well-formed messages that break the protocol are dropped,
//! counted by key and reason, and the first few are logged with both. The counts go out once,
//! as the process ends, on `rejects/<role>/<id>` ([`proto::RejectReport`]), for the summary.

use std::collections::BTreeMap;

use proto::{Keys, RejectCount, RejectReason, RejectReport, Validate};
use serde::de::DeserializeOwned;

/// How many rejects a process logs one by one before it only counts.
pub const LOGGED_REJECTS: u64 = 5;

/// The messages one process dropped.
#[derive(Debug, Clone)]
pub struct Rejects {
    process: String,
    prefix: String,
    counts: BTreeMap<(String, RejectReason), u64>,
    total: u64,
}

impl Rejects {
    /// An empty tally for `process` of the session whose keys are `keys`.
    pub fn new(process: impl Into<String>, keys: &Keys) -> Self {
        Self {
            process: process.into(),
            prefix: format!("{}/", keys.prefix()),
            counts: BTreeMap::new(),
            total: 0,
        }
    }

    /// Counts one dropped message on `key` (logged while fewer than [`LOGGED_REJECTS`] were).
    pub fn reject(&mut self, key: &str, reason: RejectReason, detail: &dyn std::fmt::Display) {
        let short = key.strip_prefix(&self.prefix).unwrap_or(key);
        // A hostile key can be long: keep the tally's keys bounded.
        let short: String = short.chars().take(160).collect();
        if self.total < LOGGED_REJECTS {
            tracing::warn!(process = %self.process, key = %short, %reason, %detail, "message dropped");
        } else if self.total == LOGGED_REJECTS {
            tracing::warn!(process = %self.process, "more messages dropped: counting only");
        }
        self.total += 1;
        *self.counts.entry((short, reason)).or_insert(0) += 1;
    }

    /// Adds `n` drops already logged elsewhere (no log line).
    pub fn add(&mut self, key: &str, reason: RejectReason, n: u64) {
        if n == 0 {
            return;
        }
        let short = key.strip_prefix(&self.prefix).unwrap_or(key);
        let short: String = short.trim_start_matches('/').chars().take(160).collect();
        self.total += n;
        *self.counts.entry((short, reason)).or_insert(0) += n;
    }

    /// Decodes a message received on `key`; counts it as undecodable and returns `None` when
    /// the bytes are not one.
    pub fn decode<T: DeserializeOwned + Validate>(
        &mut self,
        key: &str,
        payload: &[u8],
    ) -> Option<T> {
        match proto::decode(payload) {
            Ok(m) => Some(m),
            Err(e) => {
                self.reject(key, RejectReason::Undecodable, &e);
                None
            }
        }
    }

    /// Messages dropped so far.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// The count of `reason` on the key whose part after `waggle/<session>/` is `short_key`.
    pub fn count(&self, short_key: &str, reason: RejectReason) -> u64 {
        self.counts
            .get(&(short_key.to_string(), reason))
            .copied()
            .unwrap_or(0)
    }

    /// The wire report (sorted by key, then reason).
    pub fn report(&self) -> RejectReport {
        RejectReport {
            process: self.process.clone(),
            counts: self
                .counts
                .iter()
                .map(|((key, reason), count)| RejectCount {
                    key: key.clone(),
                    reason: *reason,
                    count: *count,
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn junk_is_counted_by_key_and_reason_and_reported_sorted() {
        let keys = Keys::new("s").unwrap();
        let mut r = Rejects::new("sim", &keys);
        assert!(r.decode::<proto::ClockTick>(&keys.clock(), &[]).is_none());
        assert!(
            r.decode::<proto::ClockTick>(&keys.clock(), &[9; 64])
                .is_none()
        );
        let good = proto::encode(&proto::ClockTick::at(3).unwrap());
        assert!(r.decode::<proto::ClockTick>(&keys.clock(), &good).is_some());
        r.reject(
            &keys.sched_cmd(),
            RejectReason::OutOfContract,
            &"tick 2 is past",
        );
        r.reject("elsewhere/x", RejectReason::UnexpectedKey, &"not ours");
        let long = "k".repeat(10_000);
        r.reject(&long, RejectReason::UnexpectedKey, &"long");
        assert_eq!(r.total(), 5);
        assert_eq!(r.count("clock", RejectReason::Undecodable), 2);
        let report = r.report();
        report.validate().unwrap();
        assert_eq!(report.total(), 5);
        assert_eq!(report.counts[0].key, "clock");
        assert!(report.counts.iter().all(|c| c.key.len() <= 160));
    }
}
