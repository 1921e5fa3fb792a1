//! Ideal observers for scheduler tests: each confirms an offer's final NULL exactly 3 s after
//! the performer starts that hold, keeps its own offer cache, decides with proto's allocation as
//! soon as the cache holds A and B, and tracks its setpoints perfectly.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};

use proto::allocation::{CachedOffer, OfferCache, Roster};
use proto::sched::SessionEvent;
use proto::{ClockTick, EndReason, Modality, ObserverId, Site, TICK_NS, decide};
use scheduler::{
    DecisionNotice, EventKind, Scheduler, SchedulerConfig, SchedulerInput, TickOutput,
};

pub const NS_PER_S: u64 = 1_000_000_000;
/// NULL confirmation time of the receivers.
pub const NULL_CONFIRM_NS: u64 = 3 * NS_PER_S;
const MAX_TICKS: u64 = 40_000; // 1600 s

#[derive(Clone)]
pub struct Case {
    pub config: SchedulerConfig,
    /// Observers (0-based) whose input is black: they never decode anything.
    pub black: BTreeSet<usize>,
    /// Observers (0-based) that miss the first broadcast of every round (and see its repeats).
    pub miss_first: BTreeSet<usize>,
    /// Observers whose process dies at the given sim time (no decisions, not alive).
    pub dies_at_ns: BTreeMap<usize, u64>,
    /// Extra (bad) decisions injected at given ticks.
    pub injected: BTreeMap<u64, Vec<DecisionNotice>>,
}

impl Case {
    pub fn new(n: usize, modality: Modality) -> Self {
        Self {
            config: SchedulerConfig::new(n, modality),
            black: BTreeSet::new(),
            miss_first: BTreeSet::new(),
            dies_at_ns: BTreeMap::new(),
            injected: BTreeMap::new(),
        }
    }
}

struct IdealObserver {
    id: ObserverId,
    cache: OfferCache,
    /// (confirmation time, cached offer) not yet confirmed.
    pending: Vec<(u64, CachedOffer)>,
    decided: bool,
    frames: u64,
}

pub struct Run {
    pub outputs: Vec<TickOutput>,
    /// Least distance between any two observers' commanded positions, sampled every 2 ms
    /// (`Scheduler::setpoints_at` is exact between ticks), m.
    pub min_separation_m: f64,
    pub sched: Scheduler,
    /// Complete frames per observer over the mission.
    pub frames: Vec<u64>,
    pub end: (EndReason, u64),
}

pub fn run(case: &Case) -> Run {
    let n = case.config.observers;
    let mut sched = Scheduler::new(case.config.clone()).expect("valid config");
    let roster = Roster::default_scene(n);
    let mut obs: Vec<IdealObserver> = (0..n)
        .map(|i| IdealObserver {
            id: ObserverId::from_index(i),
            cache: OfferCache::new(0),
            pending: Vec::new(),
            decided: false,
            frames: 0,
        })
        .collect();
    let mut positions: BTreeMap<ObserverId, [f64; 3]> = (0..n)
        .map(|i| (ObserverId::from_index(i), sched.homes_m()[i]))
        .collect();
    let mut outputs = Vec::new();
    let mut min_separation_m = f64::INFINITY;
    let mut round_broadcasts = 0;
    for k in 0..MAX_TICKS {
        let now = k * TICK_NS;
        let dead = |i: usize| case.dies_at_ns.get(&i).is_some_and(|t| now >= *t);
        let mut decisions = Vec::new();
        for (i, o) in obs.iter_mut().enumerate() {
            if dead(i) {
                continue;
            }
            let (ready, later): (Vec<_>, Vec<_>) =
                o.pending.drain(..).partition(|(t, _)| *t <= now);
            o.pending = later;
            for (_, c) in ready {
                o.frames += 1;
                o.cache.insert(c);
            }
            if !o.decided
                && let Some(d) = decide(&o.id, &o.cache, &roster, now)
            {
                o.decided = true;
                decisions.push(DecisionNotice::from(&d));
            }
        }
        if let Some(extra) = case.injected.get(&k) {
            decisions.extend(extra.iter().cloned());
        }
        let alive: BTreeSet<ObserverId> = (0..n)
            .filter(|&i| !dead(i))
            .map(ObserverId::from_index)
            .collect();
        let out = sched
            .step(&SchedulerInput {
                clock: ClockTick::at(k).unwrap(),
                positions_m: &positions,
                decisions: &decisions,
                alive: &alive,
            })
            .expect("tick");
        for c in &out.session {
            if let SessionEvent::RoundReset { round } = c.event {
                round_broadcasts = 0;
                for o in &mut obs {
                    o.cache.start_round(round);
                    o.pending.clear();
                    o.decided = false;
                }
            }
        }
        if let Some(b) = &out.broadcast {
            round_broadcasts += 1;
            for (i, o) in obs.iter_mut().enumerate() {
                if case.black.contains(&i)
                    || (round_broadcasts == 1 && case.miss_first.contains(&i))
                {
                    continue;
                }
                for (seq, (offer, s)) in b.offers.iter().zip(&b.scheduled).enumerate() {
                    assert_eq!(offer.to_payload(), s.payload);
                    let t = s.final_null_start_ns + NULL_CONFIRM_NS;
                    o.pending.push((
                        t,
                        CachedOffer {
                            offer: *offer,
                            frame_seq: o.frames + seq as u64,
                            final_null_ns: t,
                        },
                    ));
                }
            }
        }
        for s in &out.setpoints {
            positions.insert(s.observer.clone(), s.kin.pos_m);
        }
        min_separation_m = min_separation_m.min(least_separation(&sched, out.now_ns));
        let ended = out.mission_end.is_some();
        outputs.push(out);
        if ended {
            break;
        }
    }
    let end = sched.ended().expect("mission ended within the tick budget");
    Run {
        outputs,
        min_separation_m,
        end,
        frames: obs.iter().map(|o| o.frames).collect(),
        sched,
    }
}

impl Run {
    pub fn events(&self) -> impl Iterator<Item = (u64, &EventKind)> {
        self.sched.log().iter().map(|e| (e.t_ns, &e.kind))
    }

    /// Accepted assignments per round: round → observer → assignment.
    pub fn decisions(&self) -> BTreeMap<u32, BTreeMap<String, Option<Site>>> {
        let mut m: BTreeMap<u32, BTreeMap<String, Option<Site>>> = BTreeMap::new();
        for (_, e) in self.events() {
            if let EventKind::DecisionAccepted {
                observer,
                round,
                assignment,
                ..
            } = e
            {
                m.entry(*round)
                    .or_default()
                    .insert(observer.to_string(), *assignment);
            }
        }
        m
    }

    /// Trips as (observer, site, departure, return) in departure order.
    pub fn trips(&self) -> Vec<(String, Site, u64, u64)> {
        let mut open: BTreeMap<String, (Site, u64)> = BTreeMap::new();
        let mut trips = Vec::new();
        for (t, e) in self.events() {
            match e {
                EventKind::Departure { observer, site, .. } => {
                    assert!(open.insert(observer.to_string(), (*site, t)).is_none());
                }
                EventKind::ReturnedHome { observer } => {
                    let (site, dep) = open.remove(observer.as_str()).expect("departed");
                    trips.push((observer.to_string(), site, dep, t));
                }
                _ => {}
            }
        }
        assert!(open.is_empty(), "trips still open: {open:?}");
        trips.sort_by_key(|t| t.2);
        trips
    }

    /// Payload bits of every broadcast, per round.
    pub fn payloads(&self) -> Vec<Vec<String>> {
        self.sched
            .broadcasts()
            .iter()
            .map(|b| b.offers.iter().map(|o| o.to_bits()).collect())
            .collect()
    }

    /// Latest final-NULL confirmation of the last broadcast (the paper's "latest final
    /// reception").
    pub fn latest_final_reception_ns(&self) -> Option<u64> {
        self.sched
            .broadcasts()
            .last()
            .and_then(|b| b.scheduled.iter().map(|s| s.final_null_start_ns).max())
            .map(|t| t + NULL_CONFIRM_NS)
    }
}

/// Least pairwise distance of the commanded positions over the tick starting at `now`.
fn least_separation(sched: &Scheduler, now: u64) -> f64 {
    let mut least = f64::INFINITY;
    for t in (now..now + TICK_NS).step_by(2_000_000) {
        let p: Vec<[f64; 3]> = sched.setpoints_at(t).iter().map(|s| s.kin.pos_m).collect();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                least = least.min(proto::scene::distance_m(p[i], p[j]));
            }
        }
    }
    least
}

pub fn secs(ns: u64) -> f64 {
    ns as f64 * 1e-9
}
