//! `sim-node camera --observer Oi`: one observer's camera as its own process.
//!
//! It mirrors the simulator's ground truth (`sim/state`) into its own [`World`], renders the
//! observer's view at each of the sensor's render instants and publishes what the sensor
//! delivers — one RGB frame or one event packet (empty ones included) per tick — on
//! `sensor/Oi/rgb` or `sensor/Oi/events`. Injected faults come on the command line (and on
//! `fault/Oi`): black input (before any conversion), dropout, and throttling (drop a fixed,
//! hash-chosen fraction of packets, each announced on `sensor/Oi/dropped`, and/or delay each by
//! wall-clock time). Each fault is logged with the sim time it took effect.
//! The process ends when the simulator's liveliness token disappears.

use std::time::Duration;

use anyhow::{Context, Result};
use bus::{Bus, Inbound, NodeArgs, Process, Rejects};
use node_args::CameraArgs;
use proto::Modality;
use proto::camera::digest;
use proto::clock::EVENT_RENDER_PERIOD_NS;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};
use proto::{
    CameraReport, Fault, FaultKind, FrameChange, ObserverId, PacketDropped, PixelRect,
    RejectReason, RgbFrame, RgbUpdate, Role, SimState,
};
use sim::lockstep::mirror;
use sim::render::{CameraRenderer, RenderCounts, RenderPath};

use crate::ros2_source::Ros2Camera;
use sim::sensor::{ObserverSensor, SensorFeed, SensorOutput};
use sim::world::World;

/// `sim-node camera`'s command line: the camera's own arguments (the contract the composer
/// builds, [`node_args::CameraArgs`]) and the session-wide ones.
#[derive(Debug, clap::Args)]
pub struct CameraCli {
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    node: NodeArgs,
}

/// The camera's account of its run, for the launcher (`camera/<o>/report`); the same figures
/// go to stdout for whoever reads the log.
fn camera_report(
    observer: &ObserverId,
    render: RenderPath,
    (published, dropped, digest): (u64, u64, u64),
    counts: RenderCounts,
) -> CameraReport {
    let report = CameraReport {
        observer: observer.clone(),
        packets: published,
        dropped,
        digest,
        render,
        full_renders: counts.full,
        damage_renders: counts.damage,
        skipped_renders: counts.skipped,
        damage_px: counts.damage_px,
        scissored: sim::render::scissor_interposed(),
    };
    // Determinism evidence: equal across fault-free runs and across render paths.
    println!("sensor-digest {observer} {}", report.digest_line());
    println!(
        "render-counts {observer} path={render} full={} damage={} skipped={} damage_px={} scissored={}",
        report.full_renders,
        report.damage_renders,
        report.skipped_renders,
        report.damage_px,
        report.scissored
    );
    report
}

/// The wire form of RGB frame `f` (the reconstruction contract of [`RgbUpdate`]): only
/// its changed rectangle when it differs from the frame published just before
/// (`last_published`) by `change`, else the whole frame, and the whole frame at least every
/// `key_every` frames. Records `f` as the last published.
fn rgb_wire(
    f: &RgbFrame,
    change: FrameChange,
    last_published: &mut Option<u64>,
    key_every: u64,
) -> Vec<u8> {
    let follows = last_published.is_some_and(|prev| prev + 1 == f.seq);
    let keyframe_due = f.seq.is_multiple_of(key_every);
    let update = match change {
        FrameChange::Within(rect) if follows && !keyframe_due => {
            RgbUpdate::delta(f, f.seq - 1, rect)
        }
        FrameChange::Nothing if follows && !keyframe_due => RgbUpdate::delta(
            f,
            f.seq - 1,
            PixelRect {
                x: 0,
                y: 0,
                width: 0,
                height: 0,
            },
        ),
        _ => RgbUpdate::key(f),
    };
    *last_published = Some(f.seq);
    proto::encode(&update)
}

/// A key frame of an event sensor's input at least this often (renders): the input stream
/// only feeds a recorder on a reliable link, so key frames are for a cut recording to resume
/// from, not for loss; every 5 s at 100 Hz.
const INPUT_KEY_EVERY: u64 = 500;

/// Publishes what an event sensor is fed (`--publish-input`), as RGB updates numbered from 0.
struct InputOutbox {
    key: String,
    next_seq: u64,
    last_seq: Option<u64>,
}

impl InputOutbox {
    fn send(&mut self, bus: &mut Bus, input: SensorFeed<'_>) -> Result<()> {
        let frame = RgbFrame::rendered(
            self.next_seq,
            input.stamp_ns,
            (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX),
            input.rgb.to_vec(),
        );
        self.next_seq += 1;
        let wire = rgb_wire(&frame, input.change, &mut self.last_seq, INPUT_KEY_EVERY);
        bus.put_bytes(&self.key, wire)?;
        Ok(())
    }
}

/// True when a throttle dropping `per_mille` ‰ drops packet `seq` (a fixed hash of the
/// sequence number: the same packets go in every run).
pub fn throttle_drops(seq: u64, per_mille: u16) -> bool {
    let h = seq.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
    h % 1000 < u64::from(per_mille)
}

/// Where a camera's outputs go, and its account of them.
struct Outbox {
    observer: ObserverId,
    out_key: String,
    dropped_key: String,
    /// Packets published, dropped by a throttle, and the running digest of the published ones.
    published: u64,
    dropped: u64,
    digest: u64,
    /// The last RGB frame sent, the base of the next update.
    last_rgb_seq: Option<u64>,
}

impl Outbox {
    /// The outbox of `args`' camera, nothing sent yet.
    fn new(args: &CameraArgs, keys: &proto::Keys) -> Self {
        let out_key = match args.modality {
            Modality::Rgb => keys.sensor_rgb(&args.observer),
            Modality::Events => keys.sensor_events(&args.observer),
        };
        Self {
            observer: args.observer.clone(),
            out_key,
            dropped_key: keys.sensor_dropped(&args.observer),
            published: 0,
            dropped: 0,
            digest: 0,
            last_rgb_seq: None,
        }
    }

    /// Publishes one sensor output, or drops it under `throttle` (drop ‰, delay ms) and says so.
    fn send(
        &mut self,
        bus: &mut Bus,
        output: &SensorOutput,
        throttle: Option<(u16, u32)>,
        change: FrameChange,
    ) -> Result<()> {
        // The digest covers the delivered frame or packet itself, whatever the transport sends
        // (RGB goes as updates, see `rgb_wire`).
        let (seq, tick, bytes) = match output {
            SensorOutput::Rgb(f) => (f.seq, f.tick(), proto::encode(f)),
            SensorOutput::Events(p) => (p.seq, p.tick(), proto::encode(p)),
        };
        if let Some((drop, delay_ms)) = throttle {
            if throttle_drops(seq, drop) {
                self.dropped += 1;
                // Said, so the observer's verdict never waits on the wall clock.
                let notice = PacketDropped {
                    observer: self.observer.clone(),
                    tick,
                    seq,
                };
                bus.put(&self.dropped_key, &notice)?;
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(u64::from(delay_ms)));
        }
        self.digest = digest(self.digest, &bytes);
        self.published += 1;
        let wire = match output {
            SensorOutput::Rgb(f) => {
                rgb_wire(f, change, &mut self.last_rgb_seq, RgbUpdate::KEY_EVERY)
            }
            SensorOutput::Events(_) => bytes,
        };
        bus.put_bytes(&self.out_key, wire)?;
        Ok(())
    }
}

/// Renders and senses once; with `inputs`, publishes what the sensor was fed as well.
fn capture(
    sensor: &mut ObserverSensor,
    world: &mut World,
    renderer: &mut CameraRenderer,
    inputs: Option<&mut InputOutbox>,
    bus: &mut Bus,
) -> Result<Vec<SensorOutput>> {
    let Some(inputs) = inputs else {
        return Ok(sensor.capture(world, renderer)?);
    };
    let mut sent = Ok(());
    let outputs = sensor.capture_observed(world, renderer, &mut |input| {
        if sent.is_ok() {
            sent = inputs.send(bus, input);
        }
    })?;
    sent.context("publishing the sensor's input")?;
    Ok(outputs)
}

/// The 0-based index of `observer` among the session's `observers`.
fn observer_index(observer: &ObserverId, observers: usize) -> Result<usize> {
    (0..observers)
        .find(|&i| proto::scene::observer_name(i) == observer.as_str())
        .with_context(|| format!("{observer} is not one of the {observers} observers"))
}

/// Decodes a `sim/state`; the simulator publishes one per render instant, in order, from 0,
/// so anything else is counted and dropped.
fn admit_state(
    rejects: &mut Rejects,
    key: &str,
    payload: &[u8],
    last_state_ns: Option<u64>,
) -> Option<SimState> {
    let state = rejects.decode::<SimState>(key, payload)?;
    let due_ns = last_state_ns.map_or(Some(0), |t| t.checked_add(EVENT_RENDER_PERIOD_NS));
    if Some(state.stamp_ns) != due_ns {
        let why = format!("state at {} ns while {due_ns:?} ns is due", state.stamp_ns);
        rejects.reject(key, RejectReason::OutOfContract, &why);
        return None;
    }
    Some(state)
}

/// What `faults` do at `t_ns`: `None` when the stream has stopped (dropout), else black
/// input and the throttle (drop ‰, delay ms) if any.
fn in_force(faults: &[Fault], t_ns: u64) -> Option<(bool, Option<(u16, u32)>)> {
    if faults
        .iter()
        .any(|f| f.kind == FaultKind::StreamDropout && f.active_at(t_ns))
    {
        return None;
    }
    let black = faults
        .iter()
        .any(|f| f.kind == FaultKind::BlackInput && f.active_at(t_ns));
    let throttle = faults.iter().find_map(|f| match f.kind {
        FaultKind::Throttle {
            drop_per_mille,
            delay_ms,
        } if f.active_at(t_ns) => Some((drop_per_mille, delay_ms)),
        _ => None,
    });
    Some((black, throttle))
}

/// Takes a fault message for `observer`'s camera (a new one is logged and kept).
fn take_fault(
    rejects: &mut Rejects,
    key: &str,
    payload: &[u8],
    observer: &ObserverId,
    faults: &mut Vec<Fault>,
) {
    let Some(fault) = rejects.decode::<Fault>(key, payload) else {
        return;
    };
    if fault.observer != *observer {
        let why = format!("fault for {} on {observer}'s key", fault.observer);
        rejects.reject(key, RejectReason::OutOfContract, &why);
        return;
    }
    if !faults.contains(&fault) {
        tracing::warn!(%observer, ?fault, "fault received");
        faults.push(fault);
    }
}

/// What a camera reads from the bus, and what it has learnt from it: the faults in force, the
/// last state admitted, what it refused.
struct Inbox {
    observer: ObserverId,
    state_key: String,
    fault_key: String,
    sim_alive: String,
    rejects: Rejects,
    faults: Vec<Fault>,
    /// Whether a state has been accepted (the simulator has started).
    started: bool,
    last_state_ns: Option<u64>,
}

/// What [`Inbox::next`] found.
enum Turn {
    /// A `sim/state` due next, admitted but not yet accepted ([`Inbox::accept`]).
    State(SimState),
    /// Nothing for the camera to act on (a fault taken, a message refused, a wait run out).
    Nothing,
    /// The simulator has gone: the camera ends.
    SimGone,
}

impl Inbox {
    fn new(args: &CameraArgs, keys: &proto::Keys) -> Result<Self> {
        Ok(Self {
            observer: args.observer.clone(),
            state_key: keys.sim_state(),
            fault_key: keys.fault(&args.observer),
            sim_alive: keys.alive(Role::Sim, Role::Sim.as_str())?,
            rejects: Rejects::new(format!("camera-{}", args.observer), keys),
            faults: command_line_faults(args),
            started: false,
            last_state_ns: None,
        })
    }

    /// The next message, waiting up to `wait`: a state due next is handed out, a fault taken,
    /// anything else counted and dropped.
    fn next(&mut self, bus: &mut Bus, wait: Duration) -> Turn {
        let Some(item) = bus.recv(wait) else {
            return if self.started && !bus.is_alive(&self.sim_alive) {
                Turn::SimGone
            } else {
                Turn::Nothing
            };
        };
        match item {
            Inbound::Data { key, payload } if key == self.state_key => {
                admit_state(&mut self.rejects, &key, &payload, self.last_state_ns)
                    .map_or(Turn::Nothing, Turn::State)
            }
            Inbound::Data { key, payload } if key == self.fault_key => {
                take_fault(
                    &mut self.rejects,
                    &key,
                    &payload,
                    &self.observer,
                    &mut self.faults,
                );
                Turn::Nothing
            }
            Inbound::Data { key, .. } => {
                self.rejects
                    .reject(&key, RejectReason::UnexpectedKey, &"not subscribed");
                Turn::Nothing
            }
            Inbound::Liveliness { key, alive: false } if key == self.sim_alive => Turn::SimGone,
            Inbound::Liveliness { .. } => Turn::Nothing,
        }
    }

    /// Records `state` as the session's time: the next state is due one period after it.
    fn accept(&mut self, state: &SimState) {
        self.started = true;
        self.last_state_ns = Some(state.stamp_ns);
    }
}

/// The faults given on the command line (`--black`, `--dropout-ns`, `--throttle`): in force
/// from the start, whatever order the fault messages arrive in.
fn command_line_faults(args: &CameraArgs) -> Vec<Fault> {
    let fault = |kind, from_ns| Fault {
        observer: args.observer.clone(),
        kind,
        from_ns,
        until_ns: None,
    };
    let mut faults = Vec::new();
    if args.black {
        faults.push(fault(FaultKind::BlackInput, 0));
    }
    if let Some(at_ns) = args.dropout_ns {
        faults.push(fault(FaultKind::StreamDropout, at_ns));
    }
    for t in &args.throttle {
        let kind = FaultKind::Throttle {
            drop_per_mille: t.drop_per_mille,
            delay_ms: t.delay_ms,
        };
        faults.push(fault(kind, t.from_ns));
    }
    faults
}

pub fn run(cli: CameraCli) -> Result<()> {
    let CameraCli { camera: args, node } = cli;
    if let Some(topic) = args.ros2_source.topic.clone() {
        return run_ros2(&args, &node, &topic);
    }
    let index = observer_index(&args.observer, node.observers)?;
    let mut world = World::new(node.observers).context("building the scene")?;
    let mut renderer =
        CameraRenderer::new(&world, args.render).context("creating the offscreen renderer")?;
    let kind = args.modality;
    let mut sensor = match args.sensor.model(kind, index)? {
        None => ObserverSensor::new(kind, index, false)?,
        Some(model) => {
            tracing::info!(observer = %args.observer, ?model, "event sensor model");
            ObserverSensor::with_event_sensor(kind, index, false, model)?
        }
    };
    let period_ns = sensor.render_period_ns();

    let (mut bus, keys) = join(&args, &node)?;
    let mut outbox = Outbox::new(&args, &keys);
    // Only an event camera has an input other than its output.
    let mut input_outbox = (args.publish_input && kind == Modality::Events).then(|| InputOutbox {
        key: keys.camera_input(&args.observer),
        next_seq: 0,
        last_seq: None,
    });
    let mut inbox = Inbox::new(&args, &keys)?;
    let mut black = false;
    let mut throttle: Option<(u16, u32)> = None;
    loop {
        match inbox.next(&mut bus, Duration::from_millis(200)) {
            Turn::SimGone => break,
            Turn::Nothing => {}
            Turn::State(state) => {
                if let Err(e) = mirror(&mut world, &state) {
                    inbox
                        .rejects
                        .reject(&inbox.state_key, RejectReason::OutOfContract, &e);
                    continue;
                }
                inbox.accept(&state);
                // No render at t = 0 (the first render instant is one period in).
                if state.stamp_ns == 0 || !state.stamp_ns.is_multiple_of(period_ns) {
                    continue;
                }
                let t = state.stamp_ns;
                let Some((want_black, want_throttle)) = in_force(&inbox.faults, t) else {
                    continue;
                };
                if want_black != black {
                    tracing::warn!(observer = %args.observer, t_s = t as f64 * 1e-9, black = want_black, "black-input fault");
                    black = want_black;
                    sensor.set_black(black);
                }
                if want_throttle != throttle {
                    tracing::warn!(observer = %args.observer, t_s = t as f64 * 1e-9, ?want_throttle, "throttle fault");
                    throttle = want_throttle;
                }
                let inputs = input_outbox.as_mut();
                let outputs = capture(&mut sensor, &mut world, &mut renderer, inputs, &mut bus)?;
                for output in outputs {
                    outbox.send(&mut bus, &output, throttle, sensor.rgb_change())?;
                }
            }
        }
    }
    close(
        bus,
        &keys,
        &args,
        &outbox,
        renderer.counts(),
        &inbox.rejects,
    )
}

/// The camera process with a real camera on a ROS 2 topic as its source
/// ([`crate::ros2_source`]): the same bus contract, faults (but black input, which needs a
/// render) and report, with packets from the topic instead of renders.
fn run_ros2(args: &CameraArgs, node: &NodeArgs, topic: &str) -> Result<()> {
    if args.modality != Modality::Events {
        anyhow::bail!("--ros2-source {topic}: a ROS 2 camera feeds event cameras only");
    }
    if args.black || args.publish_input {
        anyhow::bail!("--ros2-source {topic}: --black and --publish-input need a rendering camera");
    }
    let mut camera = Ros2Camera::start(&args.ros2_source, topic, &args.observer)?;
    let (mut bus, keys) = join(args, node)?;
    let mut outbox = Outbox::new(args, &keys);
    let mut inbox = Inbox::new(args, &keys)?;
    loop {
        camera.poll();
        if let Some(now_ns) = inbox.last_state_ns {
            while let Some(packet) = camera.due(now_ns) {
                // A dropout ends the stream; a throttle drops or delays as for a rendered one.
                let Some((_, throttle)) = in_force(&inbox.faults, packet.end_ns) else {
                    continue;
                };
                let output = SensorOutput::Events(packet);
                outbox.send(&mut bus, &output, throttle, FrameChange::All)?;
            }
        }
        // Short waits: the ROS topic is polled between the bus's messages.
        match inbox.next(&mut bus, Duration::from_millis(10)) {
            Turn::SimGone => break,
            Turn::Nothing => {}
            Turn::State(state) => inbox.accept(&state),
        }
    }
    close(
        bus,
        &keys,
        args,
        &outbox,
        RenderCounts::default(),
        &inbox.rejects,
    )
}

/// Opens the bus as `args.observer`'s camera, subscribed to what a camera reads, and joins the
/// session.
fn join(args: &CameraArgs, node: &NodeArgs) -> Result<(Bus, proto::Keys)> {
    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    bus.subscribe(&keys.sim_state())?;
    bus.subscribe(&keys.fault(&args.observer))?;
    node.join(
        &mut bus,
        &Process::new(Role::Camera, args.observer.as_str()),
    )
    .context("start-up handshake")?;
    Ok((bus, keys))
}

/// Publishes the camera's report and its rejects, and leaves the bus.
fn close(
    mut bus: Bus,
    keys: &proto::Keys,
    args: &CameraArgs,
    outbox: &Outbox,
    counts: RenderCounts,
    rejects: &Rejects,
) -> Result<()> {
    let report = camera_report(
        &args.observer,
        args.render,
        (outbox.published, outbox.dropped, outbox.digest),
        counts,
    );
    bus.put(&keys.camera_report(&args.observer), &report)?;
    bus.put(
        &keys.rejects(Role::Camera, args.observer.as_str())?,
        &rejects.report(),
    )?;
    bus.close()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{rgb_wire, throttle_drops};
    use proto::{FrameChange, PixelRect, RgbFrame, RgbReassembler, RgbUpdate};

    #[test]
    fn rgb_updates_rebuild_every_frame_and_key_frames_come_when_due() {
        let frame = |seq: u64, v: u8| RgbFrame {
            seq,
            stamp_ns: seq * 40_000_000,
            width: 4,
            height: 3,
            valid: true,
            continuous: true,
            rgb: (0..36).map(|i| if i < 6 { v } else { i as u8 }).collect(),
        };
        let top = FrameChange::Within(PixelRect {
            x: 0,
            y: 0,
            width: 2,
            height: 1,
        });
        let mut last = None;
        let mut rx = RgbReassembler::default();
        let mut kinds = Vec::new();
        for seq in 0..60u64 {
            // Frame 30 is throttled away: never published.
            if seq == 30 {
                continue;
            }
            let f = frame(seq, (seq / 2) as u8);
            let change = match seq {
                10 => FrameChange::All,
                s if s % 2 == 0 => top,
                _ => FrameChange::Nothing,
            };
            let wire = rgb_wire(&f, change, &mut last, RgbUpdate::KEY_EVERY);
            let update: RgbUpdate = proto::decode(&wire).unwrap();
            kinds.push((seq, update.base_seq.is_none()));
            assert_eq!(rx.apply(update).unwrap(), f, "frame {seq}");
        }
        let keys: Vec<u64> = kinds.iter().filter(|k| k.1).map(|k| k.0).collect();
        assert_eq!(keys, vec![0, 10, 25, 31, 50]);
    }

    #[test]
    fn throttle_drops_about_the_asked_fraction_and_always_the_same_packets() {
        let dropped = (0..10_000).filter(|&s| throttle_drops(s, 250)).count();
        assert!((2_200..2_800).contains(&dropped), "{dropped}");
        assert_eq!((0..1000).filter(|&s| throttle_drops(s, 0)).count(), 0);
        assert_eq!((0..1000).filter(|&s| throttle_drops(s, 1000)).count(), 1000);
        let a: Vec<u64> = (0..100).filter(|&s| throttle_drops(s, 300)).collect();
        let b: Vec<u64> = (0..100).filter(|&s| throttle_drops(s, 300)).collect();
        assert_eq!(a, b);
    }
}
