//! `sim-node run`: the physics process of a distributed session (docs/DESIGN.md §3).
//!
//! Tick k: physics has reached t_k; the node publishes `sim/state` for the render instants in
//! (t_{k−1}, t_k] (every 10 ms; tick 0 has the single instant 0), `sim/contacts{k}`, then
//! `clock{k}`. It then waits for the performer's `setpoint{k}` and the scheduler's `cmd{k}`, and
//! steps tick k+1 with those references extrapolated inside the tick with their feed-forward
//! velocity and acceleration ([`Kinematics::extrapolated`](proto::Kinematics::extrapolated)). A `cmd` flagged `mission_end` ends
//! the run.

use std::collections::BTreeMap;
use std::collections::btree_map::Entry;
use std::time::{Duration, Instant};

/// How long the messages of a peer whose token disappeared may still take to arrive.
const PEER_LOSS_GRACE: Duration = Duration::from_secs(3);

use anyhow::{Context, Result, bail};
use bus::{Bus, Inbound, NodeArgs, Rejects, handshake};
use proto::clock::EVENT_RENDER_PERIOD_NS;
use proto::{
    ClockTick, Contact, PerformerSetpoint, RejectReason, Role, SchedCommand, SimContacts, TICK_NS,
};
use sim::lockstep::{TickReferences, sim_state};
use sim::world::World;

#[derive(Debug, clap::Args)]
pub struct SimRunArgs {
    #[command(flatten)]
    node: NodeArgs,
}

pub fn run(args: SimRunArgs) -> Result<()> {
    let node = args.node;
    let mut world = World::new(node.observers).context("building the scene")?;
    let mut bus = Bus::open_node(&node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    bus.subscribe(&keys.performer_setpoint())?;
    bus.subscribe(&keys.sched_cmd())?;
    let everyone = node.processes();
    handshake::join(
        &mut bus,
        &handshake::Process::singleton(Role::Sim),
        &everyone,
        node.startup_timeout(),
    )
    .context("start-up handshake")?;
    handshake::wait_ready(&mut bus, &everyone, node.startup_timeout())
        .context("waiting for every process to be ready")?;
    tracing::info!(
        session = node.session,
        "every process ready: starting the clock"
    );

    let peers = [
        keys.alive(Role::Performer, Role::Performer.as_str())?,
        keys.alive(Role::Scheduler, Role::Scheduler.as_str())?,
    ];
    let mut setpoints: BTreeMap<u64, PerformerSetpoint> = BTreeMap::new();
    let mut commands: BTreeMap<u64, SchedCommand> = BTreeMap::new();
    let mut tick = 0u64;
    let mut rejects = Rejects::new(Role::Sim.as_str(), &keys);
    let mut dead_since: Option<Instant> = None;
    publish_state(&mut bus, &world, 0)?;
    publish_tick(&mut bus, &world, 0, Vec::new())?;
    loop {
        // Wait for setpoint{k} and cmd{k}.
        while !(setpoints.contains_key(&tick) && commands.contains_key(&tick)) {
            match bus.recv(Duration::from_millis(200)) {
                Some(Inbound::Data { key, payload }) if key == keys.performer_setpoint() => {
                    if let Some(sp) = rejects.decode::<PerformerSetpoint>(&key, &payload) {
                        admit(&mut rejects, &key, &mut setpoints, tick, sp.tick, sp);
                    }
                }
                Some(Inbound::Data { key, payload }) if key == keys.sched_cmd() => {
                    if let Some(cmd) = rejects.decode::<SchedCommand>(&key, &payload) {
                        admit(&mut rejects, &key, &mut commands, tick, cmd.tick, cmd);
                    }
                }
                Some(Inbound::Data { key, .. }) => {
                    rejects.reject(&key, RejectReason::UnexpectedKey, &"not subscribed");
                }
                _ => {
                    // A token's deletion travels at control priority and may overtake the
                    // peer's last messages: give them time to arrive before giving up.
                    if let Some(dead) = peers.iter().find(|p| !bus.is_alive(p)) {
                        let since = *dead_since.get_or_insert_with(Instant::now);
                        if since.elapsed() > PEER_LOSS_GRACE {
                            bail!("{dead} disappeared while the simulator waited for tick {tick}");
                        }
                    }
                }
            }
        }
        let setpoint = setpoints.remove(&tick).expect("checked above");
        let cmd = commands.remove(&tick).expect("checked above");
        setpoints.retain(|t, _| *t > tick);
        commands.retain(|t, _| *t > tick);
        if cmd.mission_end {
            tracing::info!(tick, "mission end");
            break;
        }
        let references = TickReferences::new(&world, &setpoint, &cmd);
        let t_k = world.time_ns();
        let mut contacts = Vec::new();
        let next = tick + 1;
        while world.time_ns() < t_k + TICK_NS {
            references.apply(&mut world);
            let before = world.contact_stats().contact_steps;
            world.step();
            let t = world.time_ns();
            if world.contact_stats().contact_steps > before {
                contacts.extend(world.contacts().into_iter().map(|(a, b, depth_m)| Contact {
                    step_ns: t,
                    body_a: a,
                    body_b: b,
                    depth_m,
                }));
            }
            if t.is_multiple_of(EVENT_RENDER_PERIOD_NS) {
                publish_state(&mut bus, &world, next)?;
            }
        }
        tick = next;
        publish_tick(&mut bus, &world, tick, contacts)?;
    }
    bus.put(
        &keys.rejects(Role::Sim, Role::Sim.as_str())?,
        &rejects.report(),
    )?;
    bus.close()?;
    Ok(())
}

/// How far ahead of the tick being stepped a reference may be: the lockstep never lets a peer
/// run more than a tick ahead, so anything beyond is not from the session's peers.
const TICK_WINDOW: u64 = 4;

/// Keeps `msg` for `msg_tick` when it is due now or soon and the first for its tick; counts
/// it as out of contract otherwise (past, far ahead or a duplicate).
fn admit<T>(
    rejects: &mut Rejects,
    key: &str,
    pending: &mut BTreeMap<u64, T>,
    tick: u64,
    msg_tick: u64,
    msg: T,
) {
    let why = if msg_tick < tick {
        format!("tick {msg_tick} is past (waiting for tick {tick})")
    } else if msg_tick > tick + TICK_WINDOW {
        format!("tick {msg_tick} is more than {TICK_WINDOW} ahead of tick {tick}")
    } else {
        match pending.entry(msg_tick) {
            Entry::Vacant(slot) => {
                slot.insert(msg);
                return;
            }
            Entry::Occupied(_) => format!("a second message for tick {msg_tick}"),
        }
    };
    rejects.reject(key, RejectReason::OutOfContract, &why);
}

fn publish_state(bus: &mut Bus, world: &World, tick: u64) -> Result<()> {
    let key = bus.keys().sim_state();
    bus.put(&key, &sim_state(world, tick))?;
    Ok(())
}

fn publish_tick(bus: &mut Bus, world: &World, tick: u64, contacts: Vec<Contact>) -> Result<()> {
    let stats = world.contact_stats();
    let key = bus.keys().sim_contacts();
    bus.put(
        &key,
        &SimContacts {
            tick,
            contacts,
            contact_steps: stats.contact_steps,
            min_separation_m: stats.min_separation_m,
        },
    )?;
    let key = bus.keys().clock();
    bus.put(&key, &ClockTick::at(tick).context("tick overflow")?)?;
    Ok(())
}
