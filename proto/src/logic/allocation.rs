//! The per-observer offer cache and the deterministic local allocation policy.
//!
//! Each observer computes the allocation from its *own* cache: once it holds complete offers
//! for both A and B in the current round, it ranks active offers by decreasing quality (site id
//! breaking ties) and, for each site in that order, assigns up to the advertised capacity from
//! the still-unassigned roster ordered by home-to-site distance, then observer name. It then
//! executes only its own entry. Identical caches give identical allocations; nothing reconciles
//! divergent ones.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::keys::ObserverId;
use crate::payload::{Offer, Site};
use crate::scene::{distance_m, observer_home_m};

/// Each observer's assignment (`None` = unassigned).
pub type Allocation = BTreeMap<ObserverId, Option<Site>>;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AllocationError {
    #[error("observer {0} appears twice in the roster")]
    DuplicateObserver(ObserverId),
    #[error("observer {0} has a non-finite home position")]
    NonFiniteHome(ObserverId),
    #[error("two offers for site {0}")]
    DuplicateSite(Site),
}

/// One observer known to every observer (the shared prior).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RosterEntry {
    pub observer: ObserverId,
    pub home_m: [f64; 3],
}

/// All observers of the scenario with their home positions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Roster {
    entries: Vec<RosterEntry>,
}

impl Roster {
    pub fn new(entries: Vec<RosterEntry>) -> Result<Self, AllocationError> {
        let mut seen = std::collections::BTreeSet::new();
        for e in &entries {
            if !seen.insert(&e.observer) {
                return Err(AllocationError::DuplicateObserver(e.observer.clone()));
            }
            if e.home_m.iter().any(|v| !v.is_finite()) {
                return Err(AllocationError::NonFiniteHome(e.observer.clone()));
            }
        }
        Ok(Self { entries })
    }

    /// The default scene's `n` observers `O1 … On` at their arc homes.
    pub fn default_scene(n: usize) -> Self {
        Self {
            entries: (0..n)
                .map(|i| RosterEntry {
                    observer: ObserverId::from_index(i),
                    home_m: observer_home_m(i, n),
                })
                .collect(),
        }
    }

    pub fn entries(&self) -> &[RosterEntry] {
        &self.entries
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Collects a list of offers into one offer per site, rejecting a repeated site.
pub fn offers_by_site(offers: &[Offer]) -> Result<BTreeMap<Site, Offer>, AllocationError> {
    let mut map = BTreeMap::new();
    for o in offers {
        if map.insert(o.site, *o).is_some() {
            return Err(AllocationError::DuplicateSite(o.site));
        }
    }
    Ok(map)
}

/// Active offers in allocation order: decreasing quality, then increasing site id.
pub fn ranked_active_offers(offers: &BTreeMap<Site, Offer>) -> Vec<Offer> {
    let mut active: Vec<Offer> = offers
        .values()
        .filter(|o| !o.withdrawn())
        .copied()
        .collect();
    active.sort_by(|a, b| {
        b.quality
            .cmp(&a.quality)
            .then(a.site.id().cmp(&b.site.id()))
    });
    active
}

/// The paper's allocation policy over the whole roster.
pub fn allocate(offers: &BTreeMap<Site, Offer>, roster: &Roster) -> Allocation {
    let mut result: Allocation = roster
        .entries
        .iter()
        .map(|e| (e.observer.clone(), None))
        .collect();
    let mut unassigned: Vec<&RosterEntry> = roster.entries.iter().collect();
    for offer in ranked_active_offers(offers) {
        let site_m = offer.site.position_m();
        unassigned.sort_by(|a, b| {
            distance_m(a.home_m, site_m)
                .total_cmp(&distance_m(b.home_m, site_m))
                .then_with(|| a.observer.cmp(&b.observer))
        });
        let take = usize::from(offer.capacity).min(unassigned.len());
        for e in unassigned.drain(..take) {
            result.insert(e.observer.clone(), Some(offer.site));
        }
    }
    result
}

/// An offer held by an observer together with the frame it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct CachedOffer {
    pub offer: Offer,
    /// Sequence number of the source frame in this observer's frame stream.
    pub frame_seq: u64,
    /// Time of the source frame's releasing NULL.
    pub final_null_ns: u64,
}

/// One observer's latest complete offer per site in the current round.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OfferCache {
    round: u32,
    by_site: BTreeMap<Site, CachedOffer>,
}

impl OfferCache {
    pub fn new(round: u32) -> Self {
        Self {
            round,
            by_site: BTreeMap::new(),
        }
    }

    pub fn round(&self) -> u32 {
        self.round
    }

    /// Starts a new round: offers of earlier rounds no longer count.
    pub fn start_round(&mut self, round: u32) {
        self.round = round;
        self.by_site.clear();
    }

    /// Stores a decoded offer (a later frame for the same site replaces the earlier one);
    /// returns the replaced entry.
    pub fn insert(&mut self, cached: CachedOffer) -> Option<CachedOffer> {
        self.by_site.insert(cached.offer.site, cached)
    }

    pub fn get(&self, site: Site) -> Option<&CachedOffer> {
        self.by_site.get(&site)
    }

    /// True once complete offers for both A and B are held (withdrawals count).
    pub fn is_complete(&self) -> bool {
        Site::ALL.iter().all(|s| self.by_site.contains_key(s))
    }

    /// The held offers, one per site.
    pub fn offers(&self) -> BTreeMap<Site, Offer> {
        self.by_site.iter().map(|(s, c)| (*s, c.offer)).collect()
    }

    /// The held entries in site order.
    pub fn entries(&self) -> impl Iterator<Item = &CachedOffer> {
        self.by_site.values()
    }

    /// The allocation over `roster`, or `None` while an offer for A or B is still missing.
    pub fn allocate(&self, roster: &Roster) -> Option<Allocation> {
        self.is_complete().then(|| allocate(&self.offers(), roster))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn o(bits: &str) -> Offer {
        bits.parse().unwrap()
    }

    fn run(n: usize, offers: &[&str]) -> Vec<Option<Site>> {
        let offers: Vec<Offer> = offers.iter().map(|b| o(b)).collect();
        allocate(&offers_by_site(&offers).unwrap(), &Roster::default_scene(n))
            .into_values()
            .collect()
    }

    use Site::{A, B};

    #[test]
    fn nominal_round_1_sends_o1_o2_to_a_and_o3_to_b() {
        assert_eq!(
            run(3, &["011010", "100111"]),
            vec![Some(A), Some(A), Some(B)]
        );
    }

    #[test]
    fn nominal_round_2_withdrawal_sends_everyone_to_b() {
        assert_eq!(
            run(3, &["010000", "100111"]),
            vec![Some(B), Some(B), Some(B)]
        );
    }

    #[test]
    fn one_observer_does_a_then_b() {
        // Task state for N = 1: A 1 unit (011001), B 2 units (100110); then A withdrawn.
        assert_eq!(run(1, &["011001", "100110"]), vec![Some(A)]);
        assert_eq!(run(1, &["010000", "100101"]), vec![Some(B)]);
    }

    #[test]
    fn two_observers_split_then_both_go_to_b() {
        // N = 2: A 1 unit (011001), B 3 units (100111); round 2: A withdrawn, B 2 units left.
        assert_eq!(run(2, &["011001", "100111"]), vec![Some(A), Some(B)]);
        assert_eq!(run(2, &["010000", "100110"]), vec![Some(B), Some(B)]);
    }

    #[test]
    fn o2_black_round_2_with_one_unit_left_at_a() {
        // O2 never decodes, so only O1 served A in round 1: A has 1 unit left (011001).
        assert_eq!(
            run(3, &["011001", "100111"]),
            vec![Some(A), Some(B), Some(B)]
        );
    }

    #[test]
    fn quality_ranks_first_and_site_id_breaks_ties() {
        // B outranks A on quality: the B-nearest observer goes to B first.
        assert_eq!(run(3, &["010101", "101101"]), vec![Some(A), None, Some(B)]);
        // Equal quality: A (id 1) is served first and takes its nearest observers.
        assert_eq!(
            run(3, &["011010", "101011"]),
            vec![Some(A), Some(A), Some(B)]
        );
        assert_eq!(
            run(3, &["010101", "100111"]),
            vec![Some(A), Some(B), Some(B)]
        );
    }

    #[test]
    fn capacity_zero_or_quality_zero_withdraws() {
        assert_eq!(run(3, &["011000", "100011"]), vec![None, None, None]);
    }

    #[test]
    fn equal_distances_fall_back_to_observer_name() {
        let home = [0.0, -1.0, 1.3];
        let roster = Roster::new(vec![
            RosterEntry {
                observer: ObserverId::new("O2").unwrap(),
                home_m: home,
            },
            RosterEntry {
                observer: ObserverId::new("O1").unwrap(),
                home_m: home,
            },
        ])
        .unwrap();
        let alloc = allocate(&offers_by_site(&[o("011001")]).unwrap(), &roster);
        assert_eq!(alloc[&ObserverId::new("O1").unwrap()], Some(A));
        assert_eq!(alloc[&ObserverId::new("O2").unwrap()], None);
    }

    #[test]
    fn the_cache_waits_for_both_sites_and_resets_per_round() {
        let roster = Roster::default_scene(3);
        let mut cache = OfferCache::new(1);
        assert_eq!(cache.allocate(&roster), None);
        cache.insert(CachedOffer {
            offer: o("100111"),
            frame_seq: 0,
            final_null_ns: 10,
        });
        assert_eq!(cache.allocate(&roster), None, "B alone is not enough");
        cache.insert(CachedOffer {
            offer: o("011010"),
            frame_seq: 1,
            final_null_ns: 20,
        });
        let alloc = cache.allocate(&roster).expect("complete");
        assert_eq!(
            alloc.into_values().collect::<Vec<_>>(),
            vec![Some(A), Some(A), Some(B)]
        );
        cache.start_round(2);
        assert!(!cache.is_complete());
        cache.insert(CachedOffer {
            offer: o("010000"),
            frame_seq: 2,
            final_null_ns: 30,
        });
        assert_eq!(cache.allocate(&roster), None);
        let old = cache.insert(CachedOffer {
            offer: o("100110"),
            frame_seq: 3,
            final_null_ns: 40,
        });
        assert_eq!(old, None);
        let replaced = cache.insert(CachedOffer {
            offer: o("100111"),
            frame_seq: 4,
            final_null_ns: 50,
        });
        assert_eq!(replaced.map(|c| c.frame_seq), Some(3));
        let alloc = cache.allocate(&roster).expect("complete");
        assert!(alloc.values().all(|s| *s == Some(B)));
    }

    #[test]
    fn roster_and_offer_lists_reject_duplicates() {
        let e = RosterEntry {
            observer: ObserverId::new("O1").unwrap(),
            home_m: [0.0; 3],
        };
        assert!(matches!(
            Roster::new(vec![e.clone(), e.clone()]),
            Err(AllocationError::DuplicateObserver(_))
        ));
        assert!(matches!(
            Roster::new(vec![RosterEntry {
                home_m: [f64::NAN, 0.0, 0.0],
                ..e
            }]),
            Err(AllocationError::NonFiniteHome(_))
        ));
        assert_eq!(
            offers_by_site(&[o("011010"), o("010000")]),
            Err(AllocationError::DuplicateSite(A))
        );
    }
}
