//! `observer-node --id Oi --modality rgb|events --session S`: one observer process.
//!
//! Its whole view of the world is three subscriptions — its own sensor (`sensor/Oi/*`), the
//! clock and the session controls (`sched/session`) — plus liveliness tokens. It publishes its
//! tokens, released frames, decisions and one `status{k}` per tick (docs/DESIGN.md §2–§3).
//!
//! The process is a thin shell around [`perception::observer::ObserverCore`] (the tick
//! assembler and the observer runtime, driven as one): tick k is processed once `clock{k}` has arrived,
//! the session controls of tick k−1 are applied and packet k is in hand — or judged missing: a
//! later packet arrived or the camera said it dropped it (`sensor/Oi/dropped`; both decided by
//! the assembler), the camera's liveliness token is gone, or — a last resort for a camera that is
//! alive but silent — `--grace-ms` of wall time passed since `clock{k}`. The wall clock
//! lives here, in the shell, never in the assembler. Input the decoder rejects is logged and
//! dropped; it never ends the process. The process ends on `MissionEnd`, or when the simulator
//! and the scheduler are both gone.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use bus::{Bus, Inbound, NodeArgs, Process, Rejects};
use clap::Parser;
use node_args::ObserverArgs;
use perception::observer::{ObserverCore, Processed};
use perception::runtime::ObserverRuntime;
use perception::tick::{MissingReason, SensorPacket};
use proto::scene::Placement;
use proto::{
    ClockTick, EventPacket, Keys, Modality, ObserverId, PacketDropped, Rectification, RejectReason,
    RgbReassembler, RgbUpdate, Role, Roster, SegmenterConfig, SessionTick,
};
use receiver_plugin::{ObserverInfo, PluginChain};

#[derive(Parser)]
#[command(name = "observer-node", version, about = "One Waggle observer process")]
struct Args {
    #[command(flatten)]
    own: ObserverArgs,
    #[command(flatten)]
    node: NodeArgs,
}

fn main() -> Result<()> {
    node_args::init_logging();
    let args = Args::parse();
    let node = &args.node;
    let runtime = runtime(&args.own, Roster::default_scene(node.observers))?;
    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    // The only three data subscriptions of an observer (see the isolation test).
    bus.subscribe(&keys.sensor_any(&args.own.id))?;
    bus.subscribe(&keys.clock())?;
    bus.subscribe(&keys.sched_session())?;
    node.join(
        &mut bus,
        &Process::new(Role::Observer, args.own.id.as_str()),
    )
    .context("start-up handshake")?;

    let mut observer = Observer::new(&args, keys, runtime)?;
    observer.run(&mut bus)?;
    tracing::info!(
        observer = %args.own.id,
        ticks = observer.core.next_tick(),
        missing = observer.missing,
        "observer done"
    );
    bus.put(
        &observer
            .keys
            .rejects(Role::Observer, args.own.id.as_str())?,
        &observer.rejects.report(),
    )?;
    bus.close()?;
    Ok(())
}

/// The observer's runtime: Waggle's receiver for its modality, or the plug-in `--receiver`
/// names, in a worker process this one starts and feeds only its own sensor's input.
fn runtime(own: &ObserverArgs, roster: Roster) -> Result<ObserverRuntime> {
    let Some(spec) = &own.receiver else {
        return ObserverRuntime::new(own.id.clone(), roster, own.modality)
            .map(|r| r.with_frame_check(own.frame_check))
            .context("building the receiver");
    };
    let home_m = roster
        .entries()
        .iter()
        .find(|e| e.observer == own.id)
        .map(|e| e.home_m)
        .with_context(|| format!("{} is not on the roster", own.id))?;
    let placement = Placement::aimed_from(home_m);
    let mode = Rectification::default();
    let info = ObserverInfo::new(
        own.id.to_string(),
        own.modality,
        &placement,
        mode,
        own.plugin_seed.unwrap_or(0),
    );
    let segmenter = SegmenterConfig::for_modality(own.modality).rectified(placement.camera(), mode);
    let chain = PluginChain::open(
        spec,
        &receiver_plugin::worker::python(),
        &info,
        segmenter,
        own.plugin_time_limit_ms.map(Duration::from_millis),
    )
    .with_context(|| format!("starting the receiver {spec}"))?;
    tracing::info!(observer = %own.id, receiver = %spec, "receiving with a plug-in");
    Ok(
        ObserverRuntime::with_receiver(own.id.clone(), roster, Box::new(chain))
            .with_frame_check(own.frame_check),
    )
}

/// The process's state: the pure observer core, plus what only a process has (keys, the
/// wall-clock arrival time of each pending `clock{k}`).
struct Observer {
    id: ObserverId,
    modality: Modality,
    keys: Keys,
    core: ObserverCore,
    /// Rebuilds RGB frames from the camera's updates.
    rgb: RgbReassembler,
    /// When each `clock{k}` not yet processed arrived (for the grace period).
    clocks: BTreeMap<u64, Instant>,
    grace: Duration,
    clock_key: String,
    session_key: String,
    sensor_key: String,
    dropped_key: String,
    camera_alive: String,
    sim_alive: String,
    scheduler_alive: String,
    /// Ticks whose packet was judged missing.
    missing: u64,
    /// Messages dropped.
    rejects: Rejects,
    /// The plug-in receiver's failure was logged (it is said once).
    failure_said: bool,
}

impl Observer {
    fn new(args: &Args, keys: Keys, runtime: ObserverRuntime) -> Result<Self> {
        let sensor_key = match args.own.modality {
            Modality::Rgb => keys.sensor_rgb(&args.own.id),
            Modality::Events => keys.sensor_events(&args.own.id),
        };
        Ok(Self {
            id: args.own.id.clone(),
            modality: args.own.modality,
            core: ObserverCore::new(runtime),
            rgb: RgbReassembler::default(),
            clocks: BTreeMap::new(),
            grace: Duration::from_millis(args.own.grace_ms),
            clock_key: keys.clock(),
            session_key: keys.sched_session(),
            sensor_key,
            dropped_key: keys.sensor_dropped(&args.own.id),
            camera_alive: keys.alive(Role::Camera, args.own.id.as_str())?,
            sim_alive: keys.alive(Role::Sim, Role::Sim.as_str())?,
            scheduler_alive: keys.alive(Role::Scheduler, Role::Scheduler.as_str())?,
            rejects: Rejects::new(format!("observer-{}", args.own.id), &keys),
            keys,
            missing: 0,
            failure_said: false,
        })
    }

    /// Processes what arrives until the mission ends or the simulator and scheduler are gone.
    fn run(&mut self, bus: &mut Bus) -> Result<()> {
        loop {
            if !self.advance(bus)? {
                return Ok(());
            }
            match bus.recv(self.wait()) {
                Some(Inbound::Data { key, payload }) => self.receive(&key, &payload),
                Some(Inbound::Liveliness { .. }) | None => {
                    if !bus.is_alive(&self.sim_alive) && !bus.is_alive(&self.scheduler_alive) {
                        tracing::info!(observer = %self.id, "simulator and scheduler gone: exiting");
                        return Ok(());
                    }
                }
            }
        }
    }

    /// Advances as far as what has arrived allows; false once the session ended the mission.
    fn advance(&mut self, bus: &mut Bus) -> Result<bool> {
        loop {
            let (camera_alive, clocks, grace) = (&self.camera_alive, &self.clocks, self.grace);
            let processed = self.core.next(|tick| {
                if !bus.is_alive(camera_alive) {
                    Some(MissingReason::CameraGone)
                } else if clocks
                    .get(&tick)
                    .is_some_and(|since| since.elapsed() >= grace)
                {
                    Some(MissingReason::GraceExpired)
                } else {
                    None
                }
            });
            match processed.context("processing a tick")? {
                Some(p) => self.publish(bus, p)?,
                None => return Ok(!self.core.ended()),
            }
        }
    }

    /// Publishes what tick `p.tick` produced.
    fn publish(&mut self, bus: &mut Bus, p: Processed) -> Result<()> {
        let Processed {
            tick,
            input,
            report,
        } = p;
        if let Some(why) = input.missing() {
            self.missing += 1;
            tracing::warn!(observer = %self.id, tick, why = why.as_str(), "packet missing");
        }
        let keys = &self.keys;
        for t in &report.tokens {
            bus.put(&keys.observer_tokens(&self.id), t)?;
        }
        for f in &report.frames {
            bus.put(&keys.observer_frames(&self.id), f)?;
        }
        if let Some(d) = &report.decision {
            bus.put(&keys.observer_decision(&self.id), d)?;
        }
        if let Some(track) = &report.track {
            bus.put(&keys.observer_track(&self.id), track)?;
        }
        bus.put(&keys.observer_status(&self.id), &report.status)?;
        self.clocks.remove(&tick);
        if !self.failure_said
            && let Some(why) = self.core.receiver_failure()
        {
            self.failure_said = true;
            tracing::error!(observer = %self.id, tick, %why, "the receiver failed: deaf from now on");
        }
        Ok(())
    }

    /// How long to wait for the next message: until the grace period of the pending tick
    /// expires (between 1 and 100 ms), or 100 ms when no clock is pending.
    fn wait(&self) -> Duration {
        self.clocks
            .get(&self.core.next_tick())
            .map_or(Duration::from_millis(100), |since| {
                self.grace
                    .saturating_sub(since.elapsed())
                    .clamp(Duration::from_millis(1), Duration::from_millis(100))
            })
    }

    /// Hands one message to the assembler; a message the decoder rejects, a stale packet and
    /// anything on a key it does not read are counted and dropped.
    fn receive(&mut self, key: &str, payload: &[u8]) {
        if key == self.clock_key {
            if let Some(c) = self.rejects.decode::<ClockTick>(key, payload) {
                if c.tick >= self.core.next_tick() {
                    self.clocks.insert(c.tick, Instant::now());
                }
                self.core.clock(c.tick);
            }
        } else if key == self.session_key {
            if let Some(s) = self.rejects.decode::<SessionTick>(key, payload) {
                self.core.session(s.tick, s.controls);
            }
        } else if key == self.dropped_key {
            if let Some(d) = self.rejects.decode::<PacketDropped>(key, payload) {
                if d.observer == self.id {
                    self.core.dropped(d.tick);
                } else {
                    let why = format!("drop notice of {} on {}'s key", d.observer, self.id);
                    self.rejects.reject(key, RejectReason::OutOfContract, &why);
                }
            }
        } else if key == self.sensor_key {
            let packet: Option<SensorPacket> = match self.modality {
                Modality::Rgb => self
                    .rejects
                    .decode::<RgbUpdate>(key, payload)
                    .and_then(|u| match self.rgb.apply(u) {
                        Ok(f) => Some(f.into()),
                        Err(e) => {
                            self.rejects.reject(key, RejectReason::OutOfContract, &e);
                            None
                        }
                    }),
                Modality::Events => self
                    .rejects
                    .decode::<EventPacket>(key, payload)
                    .map(Into::into),
            };
            if let Some(p) = packet {
                let (tick, kept) = self.core.packet(p);
                if !kept {
                    self.rejects.reject(
                        key,
                        RejectReason::OutOfContract,
                        &format_args!("packet of tick {tick}, already processed"),
                    );
                }
            }
        } else {
            self.rejects.reject(
                key,
                RejectReason::UnexpectedKey,
                &"not this observer's input",
            );
        }
    }
}
