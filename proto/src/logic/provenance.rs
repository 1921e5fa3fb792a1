//! Building a decision from an observer's own offer cache, and the provenance audit.
//!
//! For every accepted assignment the audit checks
//! `max over sites of t(final NULL) ≤ t(decision) ≤ t(departure)` and that both source frames
//! (one for A, one for B) were released by the deciding observer's own stream. A decision may
//! precede departure because the safety router can queue the observer.

use serde::{Deserialize, Serialize};

use crate::allocation::{OfferCache, Roster};
use crate::keys::ObserverId;
use crate::observer::{Decision, SourceFrame};
use crate::payload::Site;

/// Computes `observer`'s decision for the cache's round, or `None` while the cache is missing
/// an offer for A or B.
pub fn decide(
    observer: &ObserverId,
    cache: &OfferCache,
    roster: &Roster,
    decided_ns: u64,
) -> Option<Decision> {
    let allocation = cache.allocate(roster)?;
    Some(Decision {
        observer: observer.clone(),
        round: cache.round(),
        decided_ns,
        assignment: allocation.get(observer).copied().flatten(),
        sources: cache
            .entries()
            .map(|c| SourceFrame {
                observer: observer.clone(),
                frame_seq: c.frame_seq,
                offer: c.offer,
                final_null_ns: c.final_null_ns,
            })
            .collect(),
        allocation,
    })
}

/// Why an accepted assignment fails the provenance audit.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
pub enum AuditViolation {
    #[error("decision of {observer} has no assignment to audit")]
    NotAnAssignment { observer: ObserverId },
    #[error("decision of {observer} has no source frame for site {site}")]
    MissingSourceFrame { observer: ObserverId, site: Site },
    #[error("decision of {observer} has {count} source frames for site {site}")]
    RepeatedSourceFrame {
        observer: ObserverId,
        site: Site,
        count: usize,
    },
    #[error("decision of {observer} uses a frame for {site} released by {frame_observer}")]
    ForeignSourceFrame {
        observer: ObserverId,
        site: Site,
        frame_observer: ObserverId,
    },
    #[error(
        "{observer} decided at {decided_ns} ns, before the final NULL of {site} at {final_null_ns} ns"
    )]
    DecisionBeforeFrame {
        observer: ObserverId,
        site: Site,
        final_null_ns: u64,
        decided_ns: u64,
    },
    #[error("{observer} departed at {departure_ns} ns, before deciding at {decided_ns} ns")]
    DepartureBeforeDecision {
        observer: ObserverId,
        decided_ns: u64,
        departure_ns: u64,
    },
}

/// Audits one accepted assignment against its departure time.
pub fn audit_assignment(decision: &Decision, departure_ns: u64) -> Result<(), AuditViolation> {
    let observer = &decision.observer;
    if decision.assignment.is_none() {
        return Err(AuditViolation::NotAnAssignment {
            observer: observer.clone(),
        });
    }
    for site in Site::ALL {
        let frames: Vec<&SourceFrame> = decision
            .sources
            .iter()
            .filter(|s| s.offer.site == site)
            .collect();
        let frame = match frames.as_slice() {
            [] => {
                return Err(AuditViolation::MissingSourceFrame {
                    observer: observer.clone(),
                    site,
                });
            }
            [one] => *one,
            many => {
                return Err(AuditViolation::RepeatedSourceFrame {
                    observer: observer.clone(),
                    site,
                    count: many.len(),
                });
            }
        };
        if frame.observer != *observer {
            return Err(AuditViolation::ForeignSourceFrame {
                observer: observer.clone(),
                site,
                frame_observer: frame.observer.clone(),
            });
        }
        if frame.final_null_ns > decision.decided_ns {
            return Err(AuditViolation::DecisionBeforeFrame {
                observer: observer.clone(),
                site,
                final_null_ns: frame.final_null_ns,
                decided_ns: decision.decided_ns,
            });
        }
    }
    if decision.decided_ns > departure_ns {
        return Err(AuditViolation::DepartureBeforeDecision {
            observer: observer.clone(),
            decided_ns: decision.decided_ns,
            departure_ns,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::allocation::CachedOffer;
    use crate::codec::Validate;

    fn cache() -> OfferCache {
        let mut c = OfferCache::new(1);
        c.insert(CachedOffer {
            offer: "011010".parse().unwrap(),
            frame_seq: 0,
            final_null_ns: 100,
        });
        c.insert(CachedOffer {
            offer: "100111".parse().unwrap(),
            frame_seq: 1,
            final_null_ns: 200,
        });
        c
    }

    fn o(name: &str) -> ObserverId {
        ObserverId::new(name).unwrap()
    }

    #[test]
    fn decide_uses_only_the_own_cache_and_waits_for_both_sites() {
        let roster = Roster::default_scene(3);
        let mut partial = OfferCache::new(1);
        partial.insert(CachedOffer {
            offer: "100111".parse().unwrap(),
            frame_seq: 0,
            final_null_ns: 5,
        });
        assert_eq!(decide(&o("O1"), &partial, &roster, 10), None);
        let d = decide(&o("O3"), &cache(), &roster, 250).unwrap();
        assert_eq!(d.assignment, Some(Site::B));
        assert_eq!(d.round, 1);
        assert_eq!(d.sources.len(), 2);
        assert!(d.sources.iter().all(|s| s.observer == o("O3")));
        assert!(d.validate().is_ok());
        assert_eq!(audit_assignment(&d, 250), Ok(()));
        assert_eq!(audit_assignment(&d, 9_000), Ok(()));
    }

    #[test]
    fn audit_catches_each_violation() {
        let roster = Roster::default_scene(3);
        let d = decide(&o("O1"), &cache(), &roster, 250).unwrap();
        assert_eq!(
            audit_assignment(&d, 249),
            Err(AuditViolation::DepartureBeforeDecision {
                observer: o("O1"),
                decided_ns: 250,
                departure_ns: 249
            })
        );
        let early = Decision {
            decided_ns: 150,
            ..d.clone()
        };
        assert_eq!(
            audit_assignment(&early, 300),
            Err(AuditViolation::DecisionBeforeFrame {
                observer: o("O1"),
                site: Site::B,
                final_null_ns: 200,
                decided_ns: 150
            })
        );
        let mut foreign = d.clone();
        foreign.sources[0].observer = o("O2");
        assert!(matches!(
            audit_assignment(&foreign, 300),
            Err(AuditViolation::ForeignSourceFrame { site: Site::A, .. })
        ));
        let mut missing = d.clone();
        missing.sources.remove(1);
        assert!(matches!(
            audit_assignment(&missing, 300),
            Err(AuditViolation::MissingSourceFrame { site: Site::B, .. })
        ));
        let mut twice = d.clone();
        twice.sources.push(twice.sources[0].clone());
        assert!(matches!(
            audit_assignment(&twice, 300),
            Err(AuditViolation::RepeatedSourceFrame {
                site: Site::A,
                count: 2,
                ..
            })
        ));
        let none = Decision {
            assignment: None,
            ..d
        };
        assert!(matches!(
            audit_assignment(&none, 300),
            Err(AuditViolation::NotAnAssignment { .. })
        ));
    }
}
