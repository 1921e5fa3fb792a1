//! Injected faults (`fault/<o>`), consumed by that observer's camera process only.

use serde::{Deserialize, Serialize};

use crate::codec::Validate;
use crate::keys::ObserverId;

/// What goes wrong with an observer's input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FaultKind {
    /// Rendered frames are black before any conversion (packets still flow).
    BlackInput,
    /// The sensor stream stops: no packets are published.
    StreamDropout,
    /// The camera publisher is throttled: it drops `drop_per_mille` ‰ of its packets (chosen
    /// by a hash of the packet sequence number, so the same packets go in every run) and
    /// delays each remaining one by `delay_ms` of wall-clock time.
    Throttle { drop_per_mille: u16, delay_ms: u32 },
}

/// A fault on one observer's camera over `[from_ns, until_ns)` (`None` = to the end).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fault {
    pub observer: ObserverId,
    pub kind: FaultKind,
    pub from_ns: u64,
    pub until_ns: Option<u64>,
}

impl Fault {
    /// True when the fault is in effect at `t_ns`.
    pub fn active_at(&self, t_ns: u64) -> bool {
        t_ns >= self.from_ns && self.until_ns.is_none_or(|u| t_ns < u)
    }
}

impl Validate for Fault {
    fn validate(&self) -> Result<(), String> {
        if let FaultKind::Throttle { drop_per_mille, .. } = self.kind
            && drop_per_mille > 1000
        {
            return Err(format!(
                "throttle of {} drops {drop_per_mille} per mille",
                self.observer
            ));
        }
        if self.until_ns.is_some_and(|u| u <= self.from_ns) {
            return Err(format!(
                "fault on {} ends ({:?} ns) before it starts ({} ns)",
                self.observer, self.until_ns, self.from_ns
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_window_is_half_open() {
        let f = Fault {
            observer: ObserverId::new("O2").unwrap(),
            kind: FaultKind::StreamDropout,
            from_ns: 35_000_000_000,
            until_ns: Some(36_000_000_000),
        };
        assert!(!f.active_at(34_999_999_999));
        assert!(f.active_at(35_000_000_000));
        assert!(!f.active_at(36_000_000_000));
        assert!(
            Fault {
                until_ns: None,
                ..f.clone()
            }
            .active_at(u64::MAX)
        );
        assert!(
            Fault {
                until_ns: Some(1),
                ..f
            }
            .validate()
            .is_err()
        );
    }
}
