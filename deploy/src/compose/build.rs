//! The compose file of a case: every node of the session with its arguments, placed on hosts.

use anyhow::Result;
use proto::{Modality, ObserverId, RenderPath, Role};

use super::place::{Placement, place};
use super::sensor::SensorSpec;
use super::{COMPOSE_VERSION, Compose, Faults, Node, Router};
use crate::case::Case;
use crate::fault::{ExtraFaults, Injected, injected_faults};

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
    /// A recorder takes part.
    pub record: bool,
    /// Record a view image of every RGB frame.
    pub record_all_rgb: bool,
    pub render: RenderPath,
    /// The event cameras' sensor model (none: the paper's ideal sensors, no argument).
    pub sensor: SensorSpec,
    /// Router listeners (default [`LOOPBACK_ROUTER`]) and connect endpoints.
    pub router_listen: Vec<String>,
    pub router_connect: Vec<String>,
    /// `ROLE=HOST` placements, applied in order (default: every node on [`DEFAULT_HOST`]).
    pub placements: Vec<Placement>,
}

/// The compose file of `case` with `opts`.
pub fn compose(case: &Case, opts: &ComposeOptions) -> Result<Compose> {
    opts.sensor.check(opts.modality)?;
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
        faults: Faults::from_extra(&opts.extra_faults),
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

fn node(role: &str, binary: &str, args: Vec<String>) -> Node {
    Node {
        role: role.to_string(),
        host: DEFAULT_HOST.to_string(),
        binary: binary.to_string(),
        args,
    }
}

impl NodeArgs<'_> {
    /// The simulator, scheduler, performer, each observer's camera and observer, and the
    /// recorder — the order `waggle up` starts them in.
    fn nodes(&self) -> Vec<Node> {
        let m = self.opts.modality.as_str().to_string();
        let mut out = vec![
            node("sim", "sim-node", vec!["run".into()]),
            node("scheduler", "scheduler-node", self.scheduler_args(&m)),
            node("performer", "performer-node", Vec::new()),
        ];
        for o in self.observers {
            let mut camera_args = vec![
                "camera".into(),
                "--observer".into(),
                o.to_string(),
                "--modality".into(),
                m.clone(),
                "--render".into(),
                self.opts.render.to_string(),
            ];
            if self.injected.iter().any(|f| f.black_from_start(o)) {
                camera_args.push("--black".into());
            }
            if let Some(at_ns) = self.injected.iter().find_map(|f| f.dropout_from(o)) {
                camera_args.push("--dropout-ns".into());
                camera_args.push(at_ns.to_string());
            }
            camera_args.extend(self.opts.sensor.camera_args());
            out.push(node(&format!("camera-{o}"), "sim-node", camera_args));
            out.push(node(
                &format!("observer-{o}"),
                "observer-node",
                self.observer_args(o, &m),
            ));
        }
        if self.opts.record {
            let mut args = vec![
                "--case-name".into(),
                self.case.name.clone(),
                "--modality".into(),
                m,
            ];
            if self.opts.record_all_rgb {
                args.push("--all-rgb".into());
            }
            out.push(node(Role::Recorder.as_str(), "recorder-node", args));
        }
        out
    }

    fn scheduler_args(&self, modality: &str) -> Vec<String> {
        let mut a = vec![
            "--modality".into(),
            modality.to_string(),
            "--offers".into(),
            self.case.offer_sites.join(","),
            "--rounds".into(),
            self.case.rounds.to_string(),
        ];
        if let Some(limit) = self.case.time_limit_s {
            a.push("--time-limit-s".into());
            a.push(limit.to_string());
        }
        a.push("--flights".into());
        a.push(self.case.flights.to_string());
        a
    }

    fn observer_args(&self, o: &ObserverId, modality: &str) -> Vec<String> {
        let mut a = vec![
            "--id".into(),
            o.to_string(),
            "--modality".into(),
            modality.to_string(),
            "--grace-ms".into(),
            self.opts.grace_ms.to_string(),
        ];
        if self.opts.observer_acl {
            for key in observer_denied_keys(self.keys, o, self.observers) {
                a.push("--deny".into());
                a.push(key);
            }
        }
        a
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
