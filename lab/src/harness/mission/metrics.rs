//! What a mission achieved and what it cost, from the scheduler's log alone: the quantities a
//! comparison against baselines needs (paper §7) — work units, reward, unserved capacity,
//! completion time, wasted trips, reassignment delay after a withdrawal and communication cost.

use commands::Policy;
use std::collections::BTreeMap;

use proto::{GestureConfig, Site, broadcast};
use scheduler::{EventKind, Scheduler};
use serde::{Deserialize, Serialize};

/// One observer's response to a withdrawal.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Reassignment {
    pub observer: String,
    /// The site withdrawn, which this observer served in the round before.
    pub withdrawn: String,
    pub round: u32,
    /// Where it went in the withdrawal round (`null`: stayed home).
    pub went_to: Option<String>,
    /// From the withdrawal broadcast's start to its departure for another site, s (`null`: it
    /// was not reassigned — stayed home or flew to the withdrawn site again).
    pub delay_s: Option<f64>,
}

/// A mission's outcome measures.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MissionMetrics {
    pub policy: Policy,
    pub work_units: u32,
    /// Σ over completed services of the site's quality.
    pub reward: u64,
    /// Units of work left at the sites when the mission ended.
    pub unserved_capacity: u32,
    pub completion_time_s: f64,
    /// Arrivals at a site found depleted.
    pub wasted_trips: u32,
    pub reassignments: Vec<Reassignment>,
    /// Communication cost: motion symbols (tokens) the policy relied on, and their seconds of
    /// broadcast (acquisition sweep included). Zero for the fixed policy, which reads nothing.
    pub broadcast_symbols: u64,
    pub broadcast_s: f64,
    /// The performer's tracking of its reference, when wind or the cascade controller flew
    /// (absent in still air under ideal stabilisation, so those outputs are as before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub performer_tracking: Option<crate::harness::flight::air::Tracking>,
}

fn seconds(ns: u64) -> f64 {
    ns as f64 * 1e-9
}

/// The measures of a finished mission run by `scheduler` under `policy`.
pub fn measure(scheduler: &Scheduler, policy: Policy, end_ns: u64) -> MissionMetrics {
    let stats = scheduler.stats();
    let task = scheduler.task();
    let reward = stats
        .services
        .values()
        .flatten()
        .map(|(_, site)| u64::from(task.quality(*site)))
        .sum();
    let (symbols, broadcast_ns) = if policy == Policy::Fixed {
        (0, 0)
    } else {
        communication(scheduler)
    };
    MissionMetrics {
        policy,
        work_units: stats.work_units,
        reward,
        unserved_capacity: task.total_remaining(),
        completion_time_s: seconds(end_ns),
        wasted_trips: stats.no_work_arrivals,
        reassignments: reassignments(scheduler),
        broadcast_symbols: symbols,
        broadcast_s: seconds(broadcast_ns),
        performer_tracking: None,
    }
}

/// Tokens flown and broadcast time over every broadcast of the mission.
fn communication(scheduler: &Scheduler) -> (u64, u64) {
    let mut symbols = 0;
    let mut ns = 0;
    for plan in scheduler.broadcasts() {
        ns += plan.end_ns.saturating_sub(plan.start_ns);
        let payloads: Vec<u8> = plan.offers.iter().map(|o| o.to_payload()).collect();
        if let Ok(s) = broadcast(
            plan.start_ns,
            &payloads,
            plan.acquisition,
            &GestureConfig::default(),
            scheduler.config().frame_check,
        ) {
            symbols += s
                .timeline()
                .iter()
                .filter(|span| span.symbol.token().is_some())
                .count() as u64;
        }
    }
    (symbols, ns)
}

/// For every site withdrawn in a round (offered with capacity 0 after being offered with
/// work), how each observer that served it in the round before responded.
fn reassignments(scheduler: &Scheduler) -> Vec<Reassignment> {
    let log = scheduler.log();
    let mut offered: BTreeMap<u32, Vec<(Site, u8)>> = BTreeMap::new();
    let mut broadcast_ns: BTreeMap<u32, u64> = BTreeMap::new();
    let mut departures: BTreeMap<(String, u32), (Site, u64)> = BTreeMap::new();
    for e in log {
        match &e.kind {
            EventKind::RoundStarted { round, offers } => {
                offered.insert(
                    *round,
                    offers.iter().map(|o| (o.site, o.capacity)).collect(),
                );
            }
            EventKind::BroadcastStarted { round, .. } => {
                // From the round's first broadcast: a repeat is part of the delay.
                broadcast_ns.entry(*round).or_insert(e.t_ns);
            }
            EventKind::Departure {
                observer,
                site,
                round,
                ..
            } => {
                departures.insert((observer.to_string(), *round), (*site, e.t_ns));
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    for (&round, offers) in &offered {
        let Some(previous) = round.checked_sub(1).and_then(|r| offered.get(&r)) else {
            continue;
        };
        for &(site, capacity) in offers {
            let had_work = previous.iter().any(|&(s, c)| s == site && c > 0);
            if capacity != 0 || !had_work {
                continue;
            }
            let start_ns = broadcast_ns.get(&round).copied();
            for (observer, services) in &scheduler.stats().services {
                if !services.iter().any(|&(r, s)| r == round - 1 && s == site) {
                    continue;
                }
                let went = departures.get(&(observer.to_string(), round));
                out.push(Reassignment {
                    observer: observer.to_string(),
                    withdrawn: site.to_string(),
                    round,
                    went_to: went.map(|(s, _)| s.to_string()),
                    delay_s: match (went, start_ns) {
                        (Some(&(s, t)), Some(b)) if s != site => Some(seconds(t.saturating_sub(b))),
                        _ => None,
                    },
                });
            }
        }
    }
    out
}
