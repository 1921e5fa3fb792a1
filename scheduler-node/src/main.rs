//! `scheduler-node --session S …`: the scheduler process.
//!
//! Tick k closes once the scheduler holds the ground truth at t_k (the `sim/state` stamped t_k)
//! and `status{k}` of every observer whose liveliness token is present (an observer that dies
//! stops being waited for). Decisions are taken from the statuses, so none can arrive after the
//! tick it belongs to. It then steps [`Scheduler`] exactly like the in-process runner and
//! publishes, every tick and in this order: `sched/session` (the tick's controls, possibly
//! none), `sched/broadcast` (the broadcast starting now, if any) and `sched/cmd{k}`. On the
//! mission's last tick `cmd` carries `mission_end` and `sched/report` the account of the
//! mission.

use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bus::{Bus, Inbound, NodeArgs, Process, Rejects};
use clap::Parser;
use node_args::SchedulerArgs;
use proto::{
    BroadcastTick, ClockTick, Departure, EndReason, MissionReport, ObserverId, ObserverStatus,
    RejectReason, Role, SessionTick, SimState, Site, TICK_NS,
};
use scheduler::{DecisionNotice, EventKind, Scheduler, SchedulerConfig, observer_positions};

#[derive(Parser)]
#[command(
    name = "scheduler-node",
    version,
    about = "The Waggle scheduler process"
)]
struct Args {
    #[command(flatten)]
    own: SchedulerArgs,
    #[command(flatten)]
    node: NodeArgs,
}

fn parse_sites(list: &str) -> Result<Vec<Site>> {
    list.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<Site>()
                .map_err(|e| anyhow::anyhow!("--offers: {e}"))
        })
        .collect()
}

/// `--work A=24,B=40`: each named site's initial work units.
fn parse_work(list: &str) -> Result<BTreeMap<Site, u32>> {
    let mut out = BTreeMap::new();
    for entry in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (site, units) = entry
            .split_once('=')
            .with_context(|| format!("--work {list}: {entry:?} is not SITE=UNITS"))?;
        let site = site
            .parse::<Site>()
            .map_err(|e| anyhow::anyhow!("--work {list}: {e}"))?;
        let units = units
            .trim()
            .parse::<u32>()
            .with_context(|| format!("--work {list}: {units:?} is not a unit count"))?;
        if out.insert(site, units).is_some() {
            bail!("--work {list}: site {site:?} named twice");
        }
    }
    Ok(out)
}

fn main() -> Result<()> {
    node_args::init_logging();
    let args = Args::parse();
    let node = &args.node;
    let modality = args.own.modality;
    let mut config = SchedulerConfig::new(node.observers, modality)
        .with_offer_sites(&parse_sites(&args.own.offers)?);
    config.rounds = args.own.rounds;
    if let Some(work) = &args.own.work {
        config.work = parse_work(work)?;
    }
    config.max_broadcasts = args.own.max_broadcasts;
    config.frame_check = args.own.frame_check;
    config.flights = args.own.flights;
    if let Some(limit) = args.own.time_limit_s
        && !(limit.is_finite() && limit > 0.0 && limit <= 1.0e6)
    {
        bail!("--time-limit-s {limit}: must be a finite number of seconds in (0, 1e6]");
    }
    config.time_limit_ns = args.own.time_limit_s.map(|s| (s * 1e9).round() as u64);
    let mut scheduler = Scheduler::new(config).context("configuring the scheduler")?;

    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    bus.subscribe(&keys.sim_state())?;
    bus.subscribe(&keys.observer_status_any())?;
    node.join(&mut bus, &Process::singleton(Role::Scheduler))
        .context("start-up handshake")?;
    let observers: Vec<ObserverId> = (0..node.observers).map(ObserverId::from_index).collect();
    let alive_key: BTreeMap<ObserverId, String> = observers
        .iter()
        .map(|o| Ok((o.clone(), keys.alive(Role::Observer, o.as_str())?)))
        .collect::<Result<_>>()?;
    let sim_alive = keys.alive(Role::Sim, Role::Sim.as_str())?;
    let mut inbox = Inbox {
        sim_state_key: keys.sim_state(),
        status_key: observers
            .iter()
            .map(|o| (o.clone(), keys.observer_status(o)))
            .collect(),
        rejects: Rejects::new(Role::Scheduler.as_str(), &keys),
        states: BTreeMap::new(),
        statuses: BTreeMap::new(),
    };
    let mut tick = 0u64;
    loop {
        let t_k = tick * TICK_NS;
        let alive: BTreeSet<ObserverId> = observers
            .iter()
            .filter(|o| bus.is_alive(&alive_key[*o]))
            .cloned()
            .collect();
        let have = inbox.statuses.get(&tick);
        let ready = inbox.states.contains_key(&t_k)
            && alive
                .iter()
                .all(|o| have.is_some_and(|s| s.contains_key(o)));
        if !ready {
            match bus.recv(Duration::from_millis(200)) {
                Some(Inbound::Data { key, payload }) => inbox.take(&key, &payload, tick),
                _ => {
                    if !bus.is_alive(&sim_alive) {
                        bail!("the simulator disappeared at tick {tick}");
                    }
                }
            }
            continue;
        }
        let state = inbox.states.remove(&t_k).expect("checked");
        let of_tick = inbox.statuses.remove(&tick).unwrap_or_default();
        let mut decisions: Vec<DecisionNotice> = of_tick
            .values()
            .filter_map(|s| s.decision.as_ref().map(DecisionNotice::from))
            .collect();
        decisions.sort();
        let positions = observer_positions(&state);
        let out = scheduler.step(&scheduler::SchedulerInput {
            clock: ClockTick::at(tick).context("tick overflow")?,
            positions_m: &positions,
            decisions: &decisions,
            alive: &alive,
        })?;
        for e in &out.events {
            tracing::info!(tick, t_s = e.t_ns as f64 * 1e-9, event = ?e.kind, "scheduler");
        }
        bus.put(
            &keys.sched_session(),
            &SessionTick {
                tick,
                controls: out.session.clone(),
            },
        )?;
        bus.put(
            &keys.sched_broadcast(),
            &BroadcastTick {
                tick,
                broadcast: out.broadcast_message(),
            },
        )?;
        bus.put(&keys.sched_cmd(), &out.command())?;
        if let Some(reason) = out.mission_end {
            let report = report(&scheduler, tick, reason);
            bus.put(&keys.sched_report(), &report)?;
            tracing::info!(tick, ?reason, work_units = report.work_units, "mission end");
            break;
        }
        tick += 1;
    }
    // Stay until the simulator and the observers have taken the last tick's messages: closing
    // undeclares our token at control priority, which may overtake data still in flight.
    let consumers: Vec<&String> = std::iter::once(&sim_alive)
        .chain(alive_key.values())
        .collect();
    let until = std::time::Instant::now() + Duration::from_secs(10);
    while consumers.iter().any(|k| bus.is_alive(k)) && std::time::Instant::now() < until {
        bus.recv(Duration::from_millis(50));
    }
    bus.put(
        &keys.rejects(Role::Scheduler, Role::Scheduler.as_str())?,
        &inbox.rejects.report(),
    )?;
    bus.close()?;
    Ok(())
}

/// What the scheduler reads, gathered per tick; everything else counted and dropped.
struct Inbox {
    sim_state_key: String,
    status_key: BTreeMap<ObserverId, String>,
    rejects: Rejects,
    /// Ground truth at tick boundaries, by stamp.
    states: BTreeMap<u64, SimState>,
    statuses: BTreeMap<u64, BTreeMap<ObserverId, ObserverStatus>>,
}

impl Inbox {
    /// Takes one message while assembling `tick`.
    fn take(&mut self, key: &str, payload: &[u8], tick: u64) {
        if key == self.sim_state_key {
            let Some(s) = self.rejects.decode::<SimState>(key, payload) else {
                return;
            };
            // Only the states at tick boundaries matter here (the others are the cameras'
            // render instants inside a tick).
            if s.stamp_ns != s.tick * TICK_NS {
                return;
            }
            let why = match in_window(s.tick, tick) {
                Err(why) => why,
                Ok(()) => match self.states.entry(s.stamp_ns) {
                    Entry::Vacant(slot) => {
                        slot.insert(s);
                        return;
                    }
                    Entry::Occupied(_) => "a second state for its tick".to_string(),
                },
            };
            self.rejects.reject(key, RejectReason::OutOfContract, &why);
            return;
        }
        let Some(from) = self
            .status_key
            .iter()
            .find_map(|(o, k)| (k == key).then_some(o.clone()))
        else {
            let why = "no such observer in this session";
            self.rejects.reject(key, RejectReason::UnexpectedKey, &why);
            return;
        };
        let Some(s) = self.rejects.decode::<ObserverStatus>(key, payload) else {
            return;
        };
        let why = if s.observer != from {
            format!("status of {} on {from}'s key", s.observer)
        } else if let Err(why) = in_window(s.tick, tick) {
            why
        } else {
            match self
                .statuses
                .entry(s.tick)
                .or_default()
                .entry(s.observer.clone())
            {
                Entry::Vacant(slot) => {
                    slot.insert(s);
                    return;
                }
                Entry::Occupied(_) => "a second status for its tick".to_string(),
            }
        };
        self.rejects.reject(key, RejectReason::OutOfContract, &why);
    }
}

/// How far ahead of the tick being assembled a message may be: the lockstep never lets a
/// peer run more than a tick ahead, so anything beyond is not from the session's peers.
const TICK_WINDOW: u64 = 4;

/// Whether a message for `msg_tick` belongs to the window of `current` (not past, not far
/// ahead).
fn in_window(msg_tick: u64, current: u64) -> std::result::Result<(), String> {
    if msg_tick < current {
        return Err(format!(
            "tick {msg_tick} is past (assembling tick {current})"
        ));
    }
    if msg_tick > current + TICK_WINDOW {
        return Err(format!(
            "tick {msg_tick} is more than {TICK_WINDOW} ahead of tick {current}"
        ));
    }
    Ok(())
}

fn report(scheduler: &Scheduler, tick: u64, end_reason: EndReason) -> MissionReport {
    let stats = scheduler.stats();
    MissionReport {
        tick,
        end_ns: tick * TICK_NS,
        end_reason,
        work_units: stats.work_units,
        services: stats.services.clone(),
        departures: scheduler
            .log()
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Departure {
                    observer,
                    site,
                    round,
                    ..
                } => Some(Departure {
                    observer: observer.clone(),
                    round: *round,
                    site: *site,
                    t_ns: e.t_ns,
                }),
                _ => None,
            })
            .collect(),
        rejected_decisions: stats.rejections(),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_sites;
    use proto::Site;

    #[test]
    fn offer_lists_parse_including_the_empty_one() {
        assert_eq!(parse_sites("A,B").unwrap(), [Site::A, Site::B]);
        assert_eq!(parse_sites("A").unwrap(), [Site::A]);
        assert!(parse_sites("").unwrap().is_empty());
        assert!(parse_sites("A,C").is_err());
    }
}
