//! The scenario's task state: virtual work units per site and the offers a round advertises.
//!
//! For `N` observers, A starts with `max(1, N − 1)` units at quality 2 and B with `N + 1` units
//! at quality 1 (N = 3 gives the paper's default: A 2 units, B 4 units). The advertised capacity
//! is the remaining work capped at 3; a depleted site is advertised as the withdrawal `q = 0,
//! c = 0` (round 2 of the nominal case sends A as `010000`). A service decrements the counter.
//! A case may set a site's initial units itself (its `work` key, [`TaskState::with_units`]).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::payload::{FIELD_MAX, Offer, Site};

/// Advertised quality of site A.
pub const QUALITY_A: u8 = 2;
/// Advertised quality of site B.
pub const QUALITY_B: u8 = 1;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TaskError {
    #[error("a scenario needs at least one observer")]
    NoObservers,
    #[error("site {site} has no work left to serve")]
    Depleted { site: Site },
}

/// Remaining work and quality per site.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TaskState {
    remaining: BTreeMap<Site, u32>,
    quality: BTreeMap<Site, u8>,
}

impl TaskState {
    /// The initial task state for `n_observers` observers.
    pub fn initial(n_observers: usize) -> Result<Self, TaskError> {
        if n_observers == 0 {
            return Err(TaskError::NoObservers);
        }
        let n = u32::try_from(n_observers).unwrap_or(u32::MAX - 1);
        Ok(Self {
            remaining: BTreeMap::from([(Site::A, n.saturating_sub(1).max(1)), (Site::B, n + 1)]),
            quality: BTreeMap::from([(Site::A, QUALITY_A), (Site::B, QUALITY_B)]),
        })
    }

    /// The initial task state for `n_observers` observers, with the units of each site `units`
    /// names instead of the default (a long mission needs more work than the paper's).
    pub fn with_units(n_observers: usize, units: &BTreeMap<Site, u32>) -> Result<Self, TaskError> {
        let mut state = Self::initial(n_observers)?;
        for (site, n) in units {
            state.remaining.insert(*site, *n);
        }
        Ok(state)
    }

    /// Remaining work units at `site`.
    pub fn remaining(&self, site: Site) -> u32 {
        self.remaining.get(&site).copied().unwrap_or(0)
    }

    /// Total remaining work units.
    pub fn total_remaining(&self) -> u32 {
        self.remaining.values().sum()
    }

    pub fn quality(&self, site: Site) -> u8 {
        self.quality.get(&site).copied().unwrap_or(0)
    }

    /// The offer currently advertised for `site`.
    pub fn offer(&self, site: Site) -> Offer {
        let remaining = self.remaining(site);
        if remaining == 0 {
            return Offer::withdrawal(site);
        }
        let capacity = u8::try_from(remaining.min(u32::from(FIELD_MAX))).unwrap_or(FIELD_MAX);
        Offer {
            site,
            quality: self.quality(site).min(FIELD_MAX),
            capacity,
        }
    }

    /// The offers of one round, in site order (A, then B).
    pub fn round_offers(&self) -> [Offer; 2] {
        Site::ALL.map(|s| self.offer(s))
    }

    /// Records one completed service at `site`; returns the units left there.
    pub fn serve(&mut self, site: Site) -> Result<u32, TaskError> {
        let left = self.remaining.entry(site).or_insert(0);
        if *left == 0 {
            return Err(TaskError::Depleted { site });
        }
        *left -= 1;
        Ok(*left)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bits(state: &TaskState) -> [String; 2] {
        state.round_offers().map(|o| o.to_bits())
    }

    #[test]
    fn nominal_three_observer_rounds_match_the_paper() {
        let mut t = TaskState::initial(3).unwrap();
        assert_eq!((t.remaining(Site::A), t.remaining(Site::B)), (2, 4));
        assert_eq!(bits(&t), ["011010", "100111"]);
        // Round 1: O1, O2 serve A and O3 serves B.
        t.serve(Site::A).unwrap();
        t.serve(Site::A).unwrap();
        t.serve(Site::B).unwrap();
        assert_eq!(bits(&t), ["010000", "100111"]);
        assert_eq!(t.serve(Site::A), Err(TaskError::Depleted { site: Site::A }));
        for _ in 0..3 {
            t.serve(Site::B).unwrap();
        }
        assert_eq!(t.total_remaining(), 0);
        assert_eq!(bits(&t), ["010000", "100000"]);
    }

    #[test]
    fn one_and_two_observers_follow_the_formula() {
        let t1 = TaskState::initial(1).unwrap();
        assert_eq!((t1.remaining(Site::A), t1.remaining(Site::B)), (1, 2));
        assert_eq!(bits(&t1), ["011001", "100110"]);
        let t2 = TaskState::initial(2).unwrap();
        assert_eq!((t2.remaining(Site::A), t2.remaining(Site::B)), (1, 3));
        assert_eq!(bits(&t2), ["011001", "100111"]);
        assert_eq!(TaskState::initial(0), Err(TaskError::NoObservers));
    }

    #[test]
    fn a_case_can_set_each_sites_units() {
        let t = TaskState::with_units(3, &BTreeMap::from([(Site::A, 24), (Site::B, 40)])).unwrap();
        assert_eq!((t.remaining(Site::A), t.remaining(Site::B)), (24, 40));
        assert_eq!(bits(&t), ["011011", "100111"]);
        let only_b = TaskState::with_units(3, &BTreeMap::from([(Site::B, 0)])).unwrap();
        assert_eq!(
            (only_b.remaining(Site::A), only_b.remaining(Site::B)),
            (2, 0)
        );
        assert_eq!(
            TaskState::with_units(3, &BTreeMap::new()).unwrap(),
            TaskState::initial(3).unwrap()
        );
        assert_eq!(
            TaskState::with_units(0, &BTreeMap::new()),
            Err(TaskError::NoObservers)
        );
    }

    #[test]
    fn capacity_is_remaining_capped_at_three() {
        let t = TaskState::initial(8).unwrap();
        assert_eq!((t.remaining(Site::A), t.remaining(Site::B)), (7, 9));
        assert_eq!(t.offer(Site::A).capacity, 3);
        assert_eq!(t.offer(Site::B).capacity, 3);
    }
}
