//! `waggle run`: the session a case defines (case, modality, faults, bus, recording) and how this machine launches its share of it, shared with `waggle compose` and `waggle up`.

use crate::fault::{BlackSpec, KillSpec, ThrottleSpec};
use bus::Endpoints;
use clap::Args;
use node_args::SensorArgs;
use proto::Modality;
use std::path::PathBuf;

/// What defines a session: the case, its modality, faults, bus and recording (shared by
/// `waggle run` and `waggle compose`).
#[derive(Debug, Args)]
pub struct SessionArgs {
    #[arg(help = run_format::case::case_arg_help())]
    pub case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    pub modality: Option<Modality>,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    #[command(flatten)]
    pub flights: crate::common::CaseOverrides,
    /// The event cameras' sensor model: a preset and `events.*` terms (other groups are
    /// modelled by `waggle trials` and `waggle mission` only).
    #[command(flatten)]
    pub perturb: crate::common::PerturbArgs,
    #[command(flatten)]
    pub receivers: crate::common::MissionReceiversArg,
    /// Seed of the event sensors' noise draws (with --sensor-preset/--perturb): observer i draws
    /// from stream i of it, as in `waggle mission --seed`, so both build the same sensors.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Session id (default: `run-<pid>-<unix ms>`); every key lives under `waggle/<session>/`.
    #[arg(long)]
    pub session: Option<String>,
    /// Wall-clock time after which an observer judges missing a packet its camera neither sent
    /// nor said it dropped, ms: a last resort for a silent camera (throttle drops and dead
    /// cameras are told by the camera and its liveliness, never by this wait).
    #[arg(long, default_value_t = node_args::DEFAULT_GRACE_MS)]
    pub grace_ms: u64,
    /// Extra fault: black input of this observer from start-up (e.g. `O2`); repeatable.
    #[arg(long)]
    pub black: Vec<BlackSpec>,
    /// Extra fault: SIGKILL this observer's camera at a sim time, `O2@35`; repeatable.
    #[arg(long)]
    pub kill: Vec<KillSpec>,
    /// Extra fault: throttle a camera, `O1@0:250:0` = observer@from_s:drop per mille:delay ms.
    #[arg(long)]
    pub throttle: Vec<ThrottleSpec>,
    /// Run every observer behind a Zenoh access-control list that denies it ground truth
    /// (`sim/**`, `truth/**`), the performer's and scheduler's commands, faults and every other
    /// observer's keys (docs/DESIGN.md §2: the run must still pass).
    #[arg(long)]
    pub observer_acl: bool,
    /// Open bus for debugging with Zenoh tools: no authentication, no per-role access control
    /// (prints a warning; refused with a non-loopback router). By default every process
    /// authenticates to the session's router with its own per-session credentials and may
    /// publish only its own keys and read only what it needs.
    #[arg(long)]
    pub no_auth: bool,
    /// Accept a router listening on plain `tcp/` beyond loopback: authenticated, but not
    /// encrypted. Without it such a router is refused; listen on `quic/` instead (mutual TLS with
    /// the session's certificates).
    #[arg(long)]
    pub plain_tcp: bool,
    /// Do not record the session (by default `recorder-node` writes DIR/session.mcap, with the
    /// case in its metadata; see `waggle audit` and `waggle replay`).
    #[arg(long)]
    pub no_record: bool,
    /// A view image of every RGB frame in the recording (by default one in 25, i.e. 1 Hz; the
    /// raw channel holds every frame losslessly either way).
    #[arg(long)]
    pub record_all_rgb: bool,
    /// What the recording keeps of the event cameras: `packets` (every packet), `input` (what
    /// each sensor was fed — its renders — from which `waggle replay` regenerates the packets
    /// bit for bit with the recorded sensor model and seed), or `auto`: the input when the
    /// sensors have a noise model, the packets otherwise.
    #[arg(long, value_enum, default_value_t)]
    pub record_events: EventRecording,
}

/// How this machine's launcher runs its share of a session (shared by `waggle run` and
/// `waggle up`).
#[derive(Debug, Args)]
pub struct LaunchArgs {
    /// The run directory: summary.json, observers.json (the simulator's host), session.mcap (the
    /// recorder's host), host.json (other hosts) and every local process's log in DIR/logs
    /// (default: a temporary directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    pub bin_dir: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Watch the run live: serve the view channels (event and RGB images, poses, the 3D scene,
    /// the log) over a Foxglove WebSocket on 127.0.0.1:PORT (Foxglove: Open connection), from
    /// the recorder's host.
    #[arg(long, value_name = "PORT")]
    pub live: Option<u16>,
    /// Also publish the run live as ROS 2 topics in this ROS domain, as ROS 2 Jazzy's
    /// `rmw_zenoh` does (the topics and types of `waggle export ros2`), from the recorder's
    /// host: `ros2 topic echo` under RMW_IMPLEMENTATION=rmw_zenoh_cpp sees them.
    #[arg(long, value_name = "N")]
    pub ros2_domain: Option<u32>,
    /// The ROS side's Zenoh router for --ros2-domain (default: tcp/localhost:7447, where
    /// `ros2 run rmw_zenoh_cpp rmw_zenohd` listens).
    #[arg(long, value_name = "ENDPOINT", requires = "ros2_domain")]
    pub ros2_router: Option<String>,
    /// Sample the resident memory (VmRSS) of every process this launcher runs, itself
    /// included, each time sim time crosses a multiple of N seconds: DIR/rss.csv, a row per
    /// sample (sim s, then kB per process, by name). A measurement: it changes no other output.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub rss_every_s: Option<u32>,
}

#[derive(Debug, Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub session: SessionArgs,
    #[command(flatten)]
    pub launch: LaunchArgs,
    /// The session router's endpoints (default: listen on a free loopback port). Children
    /// connect to every listen endpoint given here, plus every connect endpoint.
    #[command(flatten)]
    pub endpoints: Endpoints,
    /// A real camera for an observer, `O2=TOPIC`: O2's event packets come from this ROS 2
    /// topic of the --ros2-domain graph (`event_camera_msgs/msg/EventPacket` in evt3, the
    /// camera's clock the session's) instead of a render; its observer process, the session
    /// controls and the live view run as for a simulated camera (repeatable; events only).
    #[arg(long, value_name = "OBSERVER=TOPIC", value_parser = parse_ros2_camera, requires = "ros2_domain")]
    pub ros2_camera: Vec<Ros2CameraSpec>,
}

/// `--ros2-camera OBSERVER=TOPIC`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2CameraSpec {
    pub observer: proto::ObserverId,
    pub topic: String,
}

fn parse_ros2_camera(s: &str) -> Result<Ros2CameraSpec, String> {
    let Some((observer, topic)) = s.split_once('=') else {
        return Err(format!(
            "{s:?} is not OBSERVER=TOPIC (e.g. O2=/camera/events)"
        ));
    };
    let observer = proto::ObserverId::new(observer).map_err(|e| format!("{observer:?}: {e}"))?;
    if !topic.starts_with('/') || topic.len() < 2 {
        return Err(format!(
            "topic {topic:?} is not an absolute ROS name (e.g. /camera/events)"
        ));
    }
    Ok(Ros2CameraSpec {
        observer,
        topic: topic.to_string(),
    })
}

/// What a recording keeps of the event cameras (`--record-events`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum EventRecording {
    /// Their input when the sensors have a noise model (`--sensor-preset`/`--perturb`), their
    /// packets otherwise.
    #[default]
    Auto,
    /// Every packet, as published.
    Packets,
    /// What each sensor was fed (its renders, `camera/<o>/input`); `waggle replay` regenerates
    /// the packets bit for bit with the recorded sensor model and seed. A noisy sensor's
    /// packets hold ≈ 8 bytes per event, ≈ 10⁸ events per camera-minute under `v2e-noisy`;
    /// its renders change only where something moves.
    Input,
}

impl EventRecording {
    /// True when a recording of a session with `modality` cameras and `sensor` keeps the
    /// input.
    pub fn keeps_input(self, modality: Modality, sensor: &SensorArgs) -> bool {
        modality == Modality::Events
            && match self {
                EventRecording::Auto => !sensor.is_none(),
                EventRecording::Packets => false,
                EventRecording::Input => true,
            }
    }
}
