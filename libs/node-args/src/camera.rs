//! `sim-node camera`'s own arguments, with the event sensor's model.

use proto::{Modality, ObserverId, RenderPath};

use crate::ArgList;
use crate::command::NodeArgsError;

/// One observer's camera process.
#[derive(Debug, Clone, PartialEq, Eq, clap::Args)]
pub struct CameraArgs {
    /// The observer whose camera this is (O1, O2, …).
    #[arg(long)]
    pub observer: ObserverId,
    /// The sensor it carries.
    #[arg(long, value_enum)]
    pub modality: Modality,
    /// Black input from start-up (the fault of the black-o2 case). Given on the command line so
    /// it is in force before the first render, whatever the arrival order of messages; the
    /// launcher also publishes it on `fault/Oi` for the record.
    #[arg(long)]
    pub black: bool,
    /// The stream stops at this sim time, ns (the dropout fault): nothing is published from the
    /// render at this instant on. Given on the command line, like `--black`, so it holds
    /// whatever the arrival order of messages; also published on `fault/Oi`.
    #[arg(long, value_name = "NS")]
    pub dropout_ns: Option<u64>,
    /// A throttle on the camera's publisher, `FROM_NS:DROP_PER_MILLE:DELAY_MS` (repeatable; the
    /// throttle fault): in force from the first render at or after `FROM_NS`, whatever the
    /// arrival order of messages; also published on `fault/Oi`.
    #[arg(long, value_name = "FROM_NS:DROP_PER_MILLE:DELAY_MS")]
    pub throttle: Vec<CameraThrottle>,
    /// How the camera renders: `damage` (default) redraws only what moved, `full` every pixel of
    /// every frame (the reference; both deliver identical bytes).
    #[arg(long, value_enum, default_value_t)]
    pub render: RenderPath,
    #[command(flatten)]
    pub sensor: SensorArgs,
    /// Also publish what the event sensor is fed (`camera/<o>/input`: its renders as RGB
    /// updates), for a recorder that keeps them instead of the packets and regenerates the
    /// packets on replay (the recording of a noisy sensor stays small).
    #[arg(long)]
    pub publish_input: bool,
    #[command(flatten)]
    pub ros2_source: Ros2Source,
}

/// Where `rmw_zenohd`, the ROS side's router, listens by default.
pub const DEFAULT_ROS2_ROUTER: &str = "tcp/localhost:7447";

/// A real camera in place of the simulated one: its packets come from a ROS 2 topic on
/// `rmw_zenoh` (`event_camera_msgs/msg/EventPacket`, `evt3`), cut on the session's 40 ms grid
/// from t = 0 of the camera's clock, which must be the session's; nothing is rendered.
#[derive(Debug, Clone, PartialEq, Eq, clap::Args)]
pub struct Ros2Source {
    /// Take the event packets from this ROS 2 topic instead of rendering (events only).
    #[arg(long = "ros2-source", value_name = "TOPIC")]
    pub topic: Option<String>,
    /// The ROS domain of --ros2-source.
    #[arg(long = "ros2-source-domain", value_name = "N", default_value_t = 0)]
    pub domain: u32,
    /// The ROS side's Zenoh router of --ros2-source.
    #[arg(long = "ros2-source-router", value_name = "ENDPOINT", default_value = DEFAULT_ROS2_ROUTER)]
    pub router: String,
    /// The real camera's calibration (ROS `camera_info` or OpenCV YAML): its events are
    /// remapped into the reference camera.
    #[arg(long = "ros2-source-calibration", value_name = "YAML")]
    pub calibration: Option<std::path::PathBuf>,
}

impl Default for Ros2Source {
    fn default() -> Self {
        Self {
            topic: None,
            domain: 0,
            router: DEFAULT_ROS2_ROUTER.to_string(),
            calibration: None,
        }
    }
}

impl Ros2Source {
    /// The arguments that reproduce these (none without a topic).
    pub fn to_args(&self) -> Vec<String> {
        let Some(topic) = &self.topic else {
            return Vec::new();
        };
        ArgList::new()
            .value("--ros2-source", topic)
            .value("--ros2-source-domain", self.domain)
            .value("--ros2-source-router", &self.router)
            .opt(
                "--ros2-source-calibration",
                self.calibration.as_ref().map(|p| p.display()),
            )
            .done()
    }
}

impl CameraArgs {
    /// The arguments that reproduce these (after the `camera` subcommand).
    pub fn to_args(&self) -> Vec<String> {
        let mut a = ArgList::new()
            .value("--observer", &self.observer)
            .value("--modality", self.modality.as_str())
            .value("--render", self.render)
            .flag("--black", self.black)
            .opt("--dropout-ns", self.dropout_ns)
            .flag("--publish-input", self.publish_input)
            .done();
        for t in &self.throttle {
            a.extend(["--throttle".to_string(), t.to_string()]);
        }
        a.extend(self.sensor.to_args());
        a.extend(self.ros2_source.to_args());
        a
    }
}

/// A throttle on a camera's publisher from a sim time on: it drops `drop_per_mille` ‰ of its
/// packets (announcing each on `sensor/<o>/dropped`) and delays the rest by `delay_ms` of wall
/// time. Written `FROM_NS:DROP_PER_MILLE:DELAY_MS`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CameraThrottle {
    pub from_ns: u64,
    pub drop_per_mille: u16,
    pub delay_ms: u32,
}

impl std::str::FromStr for CameraThrottle {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts: Vec<&str> = s.split(':').collect();
        let [from, drop, delay] = parts[..] else {
            return Err(format!(
                "{s:?} is not FROM_NS:DROP_PER_MILLE:DELAY_MS (e.g. 0:250:0)"
            ));
        };
        let from_ns = from
            .parse()
            .map_err(|_| format!("{s:?}: start {from:?} is not a whole number of ns"))?;
        let drop_per_mille = drop
            .parse::<u16>()
            .ok()
            .filter(|d| *d <= 1000)
            .ok_or_else(|| format!("{s:?}: drop {drop:?} is not a per mille in 0–1000"))?;
        let delay_ms = delay
            .parse()
            .map_err(|_| format!("{s:?}: delay {delay:?} is not a whole number of ms"))?;
        Ok(Self {
            from_ns,
            drop_per_mille,
            delay_ms,
        })
    }
}

impl std::fmt::Display for CameraThrottle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}:{}",
            self.from_ns, self.drop_per_mille, self.delay_ms
        )
    }
}

/// The event sensor's model of a session's cameras: a named preset and `events.*` terms over it,
/// and the run's seed. None of them: the paper's ideal sensor, and no argument at all, so such a
/// session's nodes and outputs are the ones it always had.
#[derive(Debug, Clone, Default, PartialEq, Eq, clap::Args)]
pub struct SensorArgs {
    /// A named sensor preset (`v2e-clean`, `v2e-default`, `v2e-noisy`, …) or a preset file's
    /// path (`waggle sensor-fit --out`): its `events.*` terms.
    #[arg(long = "sensor-preset", value_name = "NAME")]
    pub preset: Option<String>,
    /// An `events.*` term KEY=VALUE over the preset's (repeatable, later ones win).
    #[arg(long = "perturb", value_name = "KEY=VALUE")]
    pub perturb: Vec<String>,
    /// The run's seed: observer i's sensor noise draws from
    /// `stream_seed(seed, EventSensor, i)`, as in `waggle mission`.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl SensorArgs {
    /// True when the sensors are the paper's ideal ones (nothing to hand on).
    pub fn is_none(&self) -> bool {
        self.preset.is_none() && self.perturb.is_empty()
    }

    /// The arguments that reproduce these (none for the ideal sensor).
    pub fn to_args(&self) -> Vec<String> {
        if self.is_none() {
            return Vec::new();
        }
        let mut a = ArgList::new();
        a.opt("--sensor-preset", self.preset.as_ref());
        for t in &self.perturb {
            a.value("--perturb", t);
        }
        a.value("--seed", self.seed).done()
    }

    /// The perturbation the preset and terms make, refusing an unknown preset or term (naming
    /// it and the known ones) and any term outside the `events` group: a camera models the
    /// event sensor only (`rgb.*`, `link.*`, `geometry.*` and `flight.*` terms are modelled by
    /// `waggle trials` and `waggle mission`).
    pub fn perturbation(&self) -> Result<perturb::Perturbation, NodeArgsError> {
        let p = preset_perturbation(self.preset.as_deref(), &self.perturb)?;
        if let Some(a) = self
            .perturb
            .iter()
            .find(|a| !a.trim_start().starts_with("events."))
        {
            let key = a.split_once('=').map_or(a.as_str(), |(k, _)| k).trim();
            return Err(NodeArgsError::Sensor(format!(
                "--perturb {a}: only events.* terms apply here (the event cameras' sensor \
                 model), not {key}; `waggle trials` and `waggle mission` model the other groups"
            )));
        }
        Ok(p)
    }

    /// Checks the model for cameras carrying `modality`: a sensor model on RGB cameras is
    /// refused (it would change nothing).
    pub fn check(&self, modality: Modality) -> Result<(), NodeArgsError> {
        if self.is_none() {
            return Ok(());
        }
        self.perturbation()?;
        if modality != Modality::Events {
            return Err(NodeArgsError::Sensor(format!(
                "--sensor-preset/--perturb set the event cameras' sensor model; these cameras \
                 are {} (use --modality events)",
                modality.as_str()
            )));
        }
        Ok(())
    }

    /// The event sensor of observer `index` carrying `modality`, or `None` for the paper's
    /// ideal sensor (the camera is then built exactly as before).
    pub fn model(
        &self,
        modality: Modality,
        index: usize,
    ) -> Result<Option<event_camera::EventSensorModel>, NodeArgsError> {
        if self.is_none() {
            return Ok(None);
        }
        self.check(modality)?;
        let p = self.perturbation()?;
        let seed = perturb::seed::stream_seed(self.seed, perturb::seed::Stream::EventSensor, index);
        Ok(Some(p.event_sensor(seed)))
    }
}

/// The terms of `preset` — a built-in preset's name or the path of a preset file (any value
/// with `.` or `/`, read here: a node on another host needs the file at the same path) — then
/// `assignments` over them.
pub fn preset_perturbation<S: AsRef<str>>(
    preset: Option<&str>,
    assignments: &[S],
) -> Result<perturb::Perturbation, NodeArgsError> {
    let sensor = |e: String| NodeArgsError::Sensor(e);
    match preset {
        Some(path) if perturb::preset::is_preset_file(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| sensor(format!("reading the preset file {path}: {e}")))?;
            let terms = perturb::preset::parse_preset_file(&text)
                .map_err(|e| sensor(format!("the preset file {path}: {e}")))?;
            perturb::Perturbation::with_preset_terms(&terms, assignments)
                .map_err(|e| sensor(format!("the preset file {path}: {e}")))
        }
        name => {
            perturb::Perturbation::with_preset(name, assignments).map_err(|e| sensor(e.to_string()))
        }
    }
}
