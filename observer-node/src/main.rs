//! `observer-node --id Oi --modality rgb|events --session S`: one observer process.
//!
//! Its whole view of the world is three subscriptions — its own sensor (`sensor/Oi/*`), the
//! clock and the session controls (`sched/session`) — plus liveliness tokens. It publishes its
//! tokens, released frames, decisions and one `status{k}` per tick (DESIGN.md §2–§3).
//!
//! Tick k is processed once `clock{k}` has arrived, the session controls of tick k−1 are applied
//! and packet k is in hand — or judged missing: a later packet arrived, the camera's liveliness
//! token is gone, or `--grace-ms` of wall time passed since `clock{k}` (throttled publishers).
//! The process ends on `MissionEnd`, or when the simulator and the scheduler are both gone.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bus::{Bus, Inbound, NodeArgs, Process};
use clap::Parser;
use perception::perception::SensorInput;
use perception::runtime::{ObserverRuntime, TickData};
use proto::{
    ClockTick, EventPacket, Modality, ObserverId, RgbFrame, Role, Roster, SessionTick, TICK_NS,
};

#[derive(Parser)]
#[command(name = "observer-node", version, about = "One Waggle observer process")]
struct Args {
    /// This observer's id (O1, O2, …).
    #[arg(long)]
    id: ObserverId,
    /// The sensor it carries.
    #[arg(long, value_enum)]
    modality: Modality,
    /// Wall-clock time after `clock{k}` at which a packet that has not arrived is missing, ms.
    #[arg(long, default_value_t = 10_000)]
    grace_ms: u64,
    #[command(flatten)]
    node: NodeArgs,
}

/// A sensor packet held until its tick is processed.
enum Packet {
    Rgb(RgbFrame),
    Events(EventPacket),
}

impl Packet {
    fn input(&self) -> SensorInput<'_> {
        match self {
            Packet::Rgb(f) => SensorInput::Rgb(f),
            Packet::Events(p) => SensorInput::Events(p),
        }
    }
}

fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    let args = Args::parse();
    let node = &args.node;
    let modality = args.modality;
    let mut runtime = ObserverRuntime::new(
        args.id.clone(),
        Roster::default_scene(node.observers),
        modality,
    )
    .context("building the receiver")?;
    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    // The only three data subscriptions of an observer (see the isolation test).
    bus.subscribe(&keys.sensor_any(&args.id))?;
    bus.subscribe(&keys.clock())?;
    bus.subscribe(&keys.sched_session())?;
    node.join(&mut bus, &Process::new(Role::Observer, args.id.as_str()))
        .context("start-up handshake")?;

    let camera_alive = keys.alive(Role::Camera, args.id.as_str())?;
    let sim_alive = keys.alive(Role::Sim, Role::Sim.as_str())?;
    let scheduler_alive = keys.alive(Role::Scheduler, Role::Scheduler.as_str())?;
    let sensor_key = match args.modality {
        Modality::Rgb => keys.sensor_rgb(&args.id),
        Modality::Events => keys.sensor_events(&args.id),
    };
    let grace = Duration::from_millis(args.grace_ms);
    let mut clocks: BTreeMap<u64, Instant> = BTreeMap::new();
    let mut sessions: BTreeMap<u64, SessionTick> = BTreeMap::new();
    let mut packets: BTreeMap<u64, Packet> = BTreeMap::new();
    let mut latest_packet: Option<u64> = None;
    let mut next = 0u64;
    let mut sessions_applied = 0u64;
    let mut missing = 0u64;
    'run: loop {
        // Advance as far as what has arrived allows.
        loop {
            // The session controls of tick k−1 apply before packet k (DESIGN.md §3).
            if sessions_applied < next {
                let Some(s) = sessions.remove(&(next - 1)) else {
                    break;
                };
                runtime.apply_session(&s.controls);
                sessions_applied = next;
                if runtime.ended() {
                    break 'run;
                }
            }
            let Some(&since) = clocks.get(&next) else {
                break;
            };
            let packet = packets.remove(&next);
            let data = match &packet {
                _ if next == 0 => TickData::Nothing,
                Some(p) => TickData::Packet(p.input()),
                None => {
                    let why = if latest_packet.is_some_and(|l| l > next) {
                        "a later packet arrived"
                    } else if !bus.is_alive(&camera_alive) {
                        "the camera is gone"
                    } else if since.elapsed() >= grace {
                        "grace period expired"
                    } else {
                        break;
                    };
                    missing += 1;
                    tracing::warn!(observer = %args.id, tick = next, why, "packet missing");
                    TickData::Missing
                }
            };
            let report = runtime
                .step(next, data)
                .with_context(|| format!("tick {next}"))?;
            for t in &report.tokens {
                bus.put(&keys.observer_tokens(&args.id), t)?;
            }
            for f in &report.frames {
                bus.put(&keys.observer_frames(&args.id), f)?;
            }
            if let Some(d) = &report.decision {
                bus.put(&keys.observer_decision(&args.id), d)?;
            }
            if let Some(track) = &report.track {
                bus.put(&keys.observer_track(&args.id), track)?;
            }
            bus.put(&keys.observer_status(&args.id), &report.status)?;
            clocks.remove(&next);
            next += 1;
            packets.retain(|t, _| *t >= next);
        }
        let wait = clocks
            .get(&next)
            .map_or(Duration::from_millis(100), |since| {
                grace
                    .saturating_sub(since.elapsed())
                    .clamp(Duration::from_millis(1), Duration::from_millis(100))
            });
        match bus.recv(wait) {
            Some(Inbound::Data { key, payload }) if key == keys.clock() => {
                let c: ClockTick = bus::decode(&key, &payload)?;
                clocks.insert(c.tick, Instant::now());
            }
            Some(Inbound::Data { key, payload }) if key == keys.sched_session() => {
                let s: SessionTick = bus::decode(&key, &payload)?;
                sessions.insert(s.tick, s);
            }
            Some(Inbound::Data { key, payload }) if key == sensor_key => {
                let (tick, packet) = match args.modality {
                    Modality::Rgb => match bus::decode::<RgbFrame>(&key, &payload) {
                        Ok(f) => (f.stamp_ns / TICK_NS, Packet::Rgb(f)),
                        Err(e) => {
                            tracing::warn!(observer = %args.id, "rejected sensor message: {e}");
                            continue;
                        }
                    },
                    Modality::Events => match bus::decode::<EventPacket>(&key, &payload) {
                        Ok(p) => (p.end_ns / TICK_NS, Packet::Events(p)),
                        Err(e) => {
                            tracing::warn!(observer = %args.id, "rejected sensor message: {e}");
                            continue;
                        }
                    },
                };
                latest_packet = latest_packet.max(Some(tick));
                if tick >= next {
                    packets.insert(tick, packet);
                }
            }
            Some(Inbound::Data { key, .. }) => {
                bail!("observer {} received data on unexpected key {key}", args.id)
            }
            Some(Inbound::Liveliness { .. }) | None => {
                if !bus.is_alive(&sim_alive) && !bus.is_alive(&scheduler_alive) {
                    tracing::info!(observer = %args.id, "simulator and scheduler gone: exiting");
                    break 'run;
                }
            }
        }
    }
    tracing::info!(observer = %args.id, ticks = next, missing, "observer done");
    bus.close()?;
    Ok(())
}
