//! The compose file of a case: every node of the session with its arguments, placed on hosts.

use anyhow::Result;
use bus::Process;
use node_args::{
    CameraArgs, NodeCommand, NodeLine, ObserverArgs, PerformerArgs, RecorderArgs, SchedulerArgs,
    SensorArgs,
};
use proto::{Modality, ObserverId, RenderPath, Role};

use super::place::{HostPlacement, place};
use super::{COMPOSE_VERSION, Compose, Node, Router};
use crate::case::Case;
use crate::fault::{ExtraFaults, Injected, injected_faults};
pub use commands::run::EventRecording;

/// The host every node runs on unless placed elsewhere.
pub const DEFAULT_HOST: &str = "local";

/// The router's listener when none is given: loopback, a free port chosen by `waggle up`.
pub const LOOPBACK_ROUTER: &str = "tcp/127.0.0.1:0";

/// What a session is made of (the options of `waggle compose` and `waggle run`).
#[derive(Debug, Clone)]
pub struct ComposeOptions {
    /// The case as named on the command line (a built-in name or a path).
    pub case_name: String,
    /// The case's text as flown.
    pub case_text: String,
    pub session: String,
    pub modality: Modality,
    /// Wall-clock time after which an observer judges a late packet missing, ms.
    pub grace_ms: u64,
    pub extra_faults: ExtraFaults,
    /// Every observer behind an access-control list denying it ground truth.
    pub observer_acl: bool,
    /// Authenticated bus (per-process credentials and per-role access lists).
    pub auth: bool,
    /// Accept a plain `tcp/` router listener beyond loopback (unencrypted).
    pub plain_tcp: bool,
    /// A recorder takes part.
    pub record: bool,
    /// Record a view image of every RGB frame.
    pub record_all_rgb: bool,
    /// What the recording keeps of the event cameras.
    pub record_events: EventRecording,
    pub render: RenderPath,
    /// The event cameras' sensor model (none: the paper's ideal sensors, no argument).
    pub sensor: SensorArgs,
    /// Router listeners (default [`LOOPBACK_ROUTER`]) and connect endpoints.
    pub router_listen: Vec<String>,
    pub router_connect: Vec<String>,
    /// `ROLE=HOST` placements, applied in order (default: every node on [`DEFAULT_HOST`]).
    pub placements: Vec<HostPlacement>,
    /// Observers whose camera is a real one on a ROS 2 topic (`--ros2-camera`).
    pub ros2_cameras: std::collections::BTreeMap<ObserverId, node_args::Ros2Source>,
    /// Observers whose receiver is a plug-in (`--receiver O2=python:MODULE:CLASS`).
    pub receivers: std::collections::BTreeMap<ObserverId, receiver_plugin::PluginSpec>,
    /// The plug-ins' wall-clock limit over the session, ms.
    pub plugin_time_limit_ms: Option<u64>,
}

/// The compose file of `case` with `opts`.
pub fn compose(case: &Case, opts: &ComposeOptions) -> Result<Compose> {
    opts.sensor.check(opts.modality)?;
    if let Some(o) = opts
        .receivers
        .keys()
        .find(|o| !case.has_observer(o.as_str()))
    {
        anyhow::bail!(
            "--receiver {}=…: the case has {} observers",
            o.as_str(),
            case.observers
        );
    }
    let injected = injected_faults(case, &opts.extra_faults)?;
    let observers: Vec<ObserverId> = (0..case.observers).map(ObserverId::from_index).collect();
    let keys = proto::Keys::new(&opts.session)?;
    let nodes = NodeArgs {
        case,
        opts,
        observers: &observers,
        injected: &injected,
        keys: &keys,
    }
    .nodes();
    let mut compose = Compose {
        version: COMPOSE_VERSION,
        session: opts.session.clone(),
        modality: opts.modality,
        case_name: opts.case_name.clone(),
        auth: opts.auth,
        plain_tcp: opts.plain_tcp,
        secrets: None,
        case: opts.case_text.clone(),
        router: Router {
            host: DEFAULT_HOST.to_string(),
            listen: if opts.router_listen.is_empty() {
                vec![LOOPBACK_ROUTER.to_string()]
            } else {
                opts.router_listen.clone()
            },
            connect: opts.router_connect.clone(),
        },
        sites: Vec::new(),
        faults: opts.extra_faults.clone(),
        nodes,
    };
    place(&mut compose, &opts.placements)?;
    Ok(compose)
}

/// The nodes of one session and their own arguments.
struct NodeArgs<'a> {
    case: &'a Case,
    opts: &'a ComposeOptions,
    observers: &'a [ObserverId],
    injected: &'a [Injected],
    keys: &'a proto::Keys,
}

fn node(role: Process, command: NodeCommand) -> Node {
    line(role, NodeLine::new(command))
}

fn line(role: Process, line: NodeLine) -> Node {
    Node {
        role,
        host: DEFAULT_HOST.to_string(),
        binary: line.binary().to_string(),
        args: line.to_args(),
    }
}

impl NodeArgs<'_> {
    /// The simulator, scheduler, performer, each observer's camera and observer, and the
    /// recorder — the order `waggle up` starts them in.
    fn nodes(&self) -> Vec<Node> {
        let modality = self.opts.modality;
        let keep_input = self.opts.record
            && self
                .opts
                .record_events
                .keeps_input(modality, &self.opts.sensor);
        let mut out = vec![
            node(Process::singleton(Role::Sim), NodeCommand::Sim),
            node(
                Process::singleton(Role::Scheduler),
                NodeCommand::Scheduler(self.scheduler_args()),
            ),
            node(
                Process::singleton(Role::Performer),
                NodeCommand::Performer(PerformerArgs {
                    frame_check: self.case.frame_check,
                }),
            ),
        ];
        for o in self.observers {
            let camera = CameraArgs {
                observer: o.clone(),
                modality,
                black: self.injected.iter().any(|f| f.black_from_start(o)),
                dropout_ns: self.injected.iter().find_map(|f| f.dropout_from(o)),
                throttle: self
                    .injected
                    .iter()
                    .filter_map(|f| f.throttle_of(o))
                    .collect(),
                render: self.opts.render,
                sensor: self.opts.sensor.clone(),
                publish_input: keep_input,
                ros2_source: self.opts.ros2_cameras.get(o).cloned().unwrap_or_default(),
            };
            out.push(node(
                Process::new(Role::Camera, o.as_str()),
                NodeCommand::Camera(camera),
            ));
            let receiver = self.opts.receivers.get(o).cloned();
            let observer = ObserverArgs {
                id: o.clone(),
                modality,
                grace_ms: self.opts.grace_ms,
                plugin_time_limit_ms: receiver.as_ref().and(self.opts.plugin_time_limit_ms),
                plugin_seed: receiver.as_ref().map(|_| self.opts.sensor.seed),
                receiver,
                frame_check: self.case.frame_check,
            };
            let deny = if self.opts.observer_acl {
                observer_denied_keys(self.keys, o, self.observers)
            } else {
                Vec::new()
            };
            let command = NodeCommand::Observer(observer);
            out.push(line(
                Process::new(Role::Observer, o.as_str()),
                NodeLine { command, deny },
            ));
        }
        if self.opts.record {
            let mut recorder = RecorderArgs::new(&self.case.name, modality);
            recorder.all_rgb = self.opts.record_all_rgb;
            recorder.events_from_input = keep_input;
            recorder.sensor = self.opts.sensor.clone();
            out.push(node(
                Process::singleton(Role::Recorder),
                NodeCommand::Recorder(recorder),
            ));
        }
        out
    }

    fn scheduler_args(&self) -> SchedulerArgs {
        SchedulerArgs {
            modality: self.opts.modality,
            offers: self.case.offer_sites.join(","),
            rounds: self.case.rounds,
            work: self.case.work_arg(),
            max_broadcasts: self.case.max_broadcasts,
            time_limit_s: self.case.time_limit_s,
            flights: self.case.flights,
            frame_check: self.case.frame_check,
        }
    }
}

/// What an observer's access-control list denies: everything but its own sensor, the clock,
/// the session controls and its own outputs.
fn observer_denied_keys(keys: &proto::Keys, me: &ObserverId, all: &[ObserverId]) -> Vec<String> {
    let mut out = vec![
        keys.sim_all(),
        keys.truth_all(),
        keys.performer_all(),
        keys.sched_cmd(),
        keys.sched_broadcast(),
        keys.sched_report(),
        keys.fault_any(),
    ];
    for o in all.iter().filter(|o| *o != me) {
        out.push(keys.observer_all(o));
        out.push(keys.sensor_any(o));
    }
    out
}
