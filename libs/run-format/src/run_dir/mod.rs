//! The run-directory formats, typed: one set of serde structs shared by the writer (the
//! launcher, `waggle run --out DIR`), the readers (`waggle audit`, `waggle report`, `waggle
//! replay`, `waggle sweep`) and the tests.
//!
//! A run directory holds `summary.json` ([`RunSummary`]), `observers.json` (an
//! [`ObserverRecord`] per observer), `session.json` ([`session::SessionRecord`]), the
//! recording `session.mcap` with its `case.toml`, and the process logs in `logs/`. A sweep
//! directory holds `sweep.json` ([`SweepManifest`]) and one run directory per run. The field
//! names and the JSON layout are the on-disk format: they do not change.

pub mod audit;
pub mod lock;
pub mod session;
pub mod track_spool;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use proto::{
    Decision, FrameEvent, Offer, ReleasedFrame, RenderPath, Site, TokenEvent, TrackSample,
};
use serde::{Deserialize, Deserializer, Serialize};

use session::SessionRecord;

/// `summary.json`: the mission summary (and, for `waggle run`, the run figures).
pub const SUMMARY_FILE: &str = "summary.json";
/// `observers.json`: every token, frame, decision and track sample of each observer.
pub const OBSERVERS_FILE: &str = "observers.json";
/// `session.json`: performer spans, session controls, trips, stays and the scheduler's report.
pub const SESSION_FILE: &str = "session.json";
/// The session recording written by `recorder-node`.
pub const RECORDING_FILE: &str = "session.mcap";
/// The case's TOML text, stored beside the recording (and inside it).
pub const CASE_FILE: &str = "case.toml";
/// The process logs of a run.
pub const LOG_DIR: &str = "logs";
/// `sweep.json` of a sweep directory.
pub const SWEEP_FILE: &str = "sweep.json";

/// Why a run directory's files could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// A file of the run directory could not be read.
    #[error("reading {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// `dir/file` is not the JSON its format expects.
    #[error("parsing {}/{file}", dir.display())]
    Parse {
        dir: PathBuf,
        file: &'static str,
        #[source]
        source: serde_json::Error,
    },
    /// Writing a file of the run directory failed.
    #[error(transparent)]
    Write(#[from] std::io::Error),
    /// A record could not be serialised.
    #[error(transparent)]
    Serialize(#[from] serde_json::Error),
}

/// Nanoseconds to seconds (a division, so whole milliseconds print exactly).
pub fn ns_s(ns: u64) -> f64 {
    ns as f64 / 1e9
}

/// `r<round>:<site>` (`-` when nothing is assigned): a decision as the summary lists it.
pub fn decision_label(d: &Decision) -> String {
    format!(
        "r{}:{}",
        d.round,
        d.assignment.map_or("-".to_string(), |x| x.to_string())
    )
}

/// Reads a number that may have been written as `null` (serde_json writes NaN and the
/// infinities so) back as NaN.
pub fn null_as_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// One observer's line of the mission summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverSummary {
    pub complete_messages: usize,
    pub payloads: Vec<String>,
    pub final_null_s: Vec<f64>,
    pub decisions: Vec<String>,
    pub services: Vec<String>,
    pub tokens: usize,
}

impl ObserverSummary {
    /// One observer's summary from what it released and decided (in order), the services the
    /// scheduler completed for it and its token count. A complete message is an offer the
    /// observer released in a round (a released frame whose payload is a valid offer, what the
    /// agent caches); a round that flies its broadcast again counts each offer once.
    pub fn from_record(
        frames: &[FrameEvent],
        decisions: &[Decision],
        services: &[(u32, Site)],
        tokens: usize,
    ) -> Self {
        let messages: std::collections::BTreeSet<(u32, u8)> = frames
            .iter()
            .filter(|f| Offer::from_payload(f.frame.payload).is_ok())
            .map(|f| (f.round, f.frame.payload))
            .collect();
        let frames: Vec<&ReleasedFrame> = frames.iter().map(|f| &f.frame).collect();
        Self {
            complete_messages: messages.len(),
            payloads: frames
                .iter()
                .map(|f| format!("{:06b}", f.payload))
                .collect(),
            final_null_s: frames.iter().map(|f| ns_s(f.final_null_ns())).collect(),
            decisions: decisions.iter().map(decision_label).collect(),
            services: services.iter().map(|(_, site)| site.to_string()).collect(),
            tokens,
        }
    }
}

/// Where an observer watched the performer from: its home in the formation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObserverViewpoint {
    /// Angle between its line of sight and the gesture plane's normal (0 = head-on).
    pub viewing_angle_deg: f64,
    /// Distance from home to the performer's hover point.
    pub distance_m: f64,
    /// Height above the hover altitude seen from the performer (0 on the paper's arc).
    pub elevation_deg: f64,
}

/// A frame an observer released whose payload the performer did not fly in that round: noise
/// or a misread turned into a confident message (judged apart from lost messages).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct FalseRelease {
    pub observer: String,
    pub round: u32,
    /// The released payload, b1 first (`011001`).
    pub released: String,
    /// What the performer flew in that round, in order.
    pub flown: Vec<String>,
}

/// What became of the offers flown to one observer: each flown payload of a round is received
/// (released by the observer in that round) or lost; false releases are counted apart.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OfferReception {
    pub flown: u64,
    pub received: u64,
    pub lost: u64,
    pub false_releases: u64,
}

impl std::ops::AddAssign for OfferReception {
    fn add_assign(&mut self, o: Self) {
        self.flown += o.flown;
        self.received += o.received;
        self.lost += o.lost;
        self.false_releases += o.false_releases;
    }
}

/// The mission summary shared by `waggle mission` (in-process) and `waggle run` (distributed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionSummary {
    pub case: String,
    /// The receiver; `null` only in the audit of a recording cut before its session metadata.
    pub modality: Option<proto::Receiver>,
    pub observers: BTreeMap<String, ObserverSummary>,
    pub work_units: u32,
    pub mission_time_s: f64,
    /// Why the mission ended; `null` when no mission report arrived.
    pub end_reason: Option<proto::EndReason>,
    pub contact_steps: u64,
    #[serde(deserialize_with = "null_as_nan")]
    pub min_separation_m: f64,
    pub provenance_violations: Vec<String>,
    pub pass: bool,
    pub reasons: Vec<String>,
    #[serde(deserialize_with = "null_as_nan")]
    pub wall_seconds: f64,
    /// Each observer's viewing angle and distance.
    #[serde(default)]
    pub viewpoints: BTreeMap<String, ObserverViewpoint>,
    /// Observers that released no frame while others released some (structurally deaf, or
    /// blinded): named here whether or not the case expected it.
    #[serde(default)]
    pub deaf_observers: Vec<String>,
    /// The safety router the mission flew with.
    #[serde(default)]
    pub flights: proto::FlightMode,
    /// Released frames whose payload was not flown in their round (observer order, then
    /// release order); omitted when there are none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub false_releases: Vec<FalseRelease>,
}

/// Per-process figures in the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessFigures {
    pub cpu_s: f64,
    pub exit: String,
    pub killed_by_fault: bool,
}

/// The routes one camera's renders took (from its [`proto::CameraReport`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CameraRenders {
    pub full: u64,
    pub damage: u64,
    pub skipped: u64,
    /// Pixels drawn and read back by damage renders.
    pub damage_px: u64,
    /// Whether damage renders rasterised only their rectangle (MuJoCo's GL loader interposed).
    pub scissored: bool,
}

impl From<&proto::CameraReport> for CameraRenders {
    fn from(r: &proto::CameraReport) -> Self {
        Self {
            full: r.full_renders,
            damage: r.damage_renders,
            skipped: r.skipped_renders,
            damage_px: r.damage_px,
            scissored: r.scissored,
        }
    }
}

/// `summary.json` of a distributed run: the shared mission summary plus run figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    #[serde(flatten)]
    pub mission: MissionSummary,
    pub session: String,
    /// Wall time from the first to the last tick divided by the simulated time.
    #[serde(deserialize_with = "null_as_nan")]
    pub wall_over_sim: f64,
    /// Wall time from launch until the clock started, s.
    #[serde(deserialize_with = "null_as_nan")]
    pub startup_s: f64,
    /// Sensor packets each observer judged missing.
    pub missing_packets: BTreeMap<String, u64>,
    /// Distance of each observer from its home at the end, m.
    pub home_error_m: BTreeMap<String, f64>,
    /// The farthest each observer got from its home during the mission, m.
    pub max_excursion_m: BTreeMap<String, f64>,
    /// Each camera's digest of every payload it published (equal across fault-free runs, and
    /// across render paths).
    pub sensor_digests: BTreeMap<String, String>,
    /// How the cameras rendered.
    #[serde(default)]
    pub render: RenderPath,
    /// How many of each camera's renders took each route.
    #[serde(default)]
    pub camera_renders: BTreeMap<String, CameraRenders>,
    /// The event cameras' sensor model when it is not the paper's ideal one (`--sensor-preset`,
    /// `--perturb events.*`); absent for ideal sensors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorRecord>,
    pub processes: BTreeMap<String, ProcessFigures>,
    /// Injected faults with the sim time they took effect.
    pub faults: Vec<String>,
    /// Every fault message that reached the bus, each marked injected by the launcher or not.
    #[serde(default)]
    pub faults_seen: Vec<String>,
    /// What each process dropped instead of obeying (undecodable, unexpected-key and
    /// out-of-contract messages), by key and reason; a process that sent no report (killed,
    /// or older) is absent, one that dropped nothing has an empty list.
    #[serde(default)]
    pub rejects: BTreeMap<String, Vec<proto::RejectCount>>,
    /// What the session's router refused before any process saw it, when this run's launcher
    /// hosted it.
    #[serde(default, skip_serializing_if = "RouterRefusals::is_empty")]
    pub router_refusals: RouterRefusals,
    pub interrupted: bool,
}

/// Connections and messages a router refused, by why (counted from its Zenoh session's own
/// reports: Zenoh offers no other hook).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RouterRefusals {
    /// `quic/` connections whose TLS handshake failed (a certificate of another CA, expired,
    /// self-signed, or none).
    pub certificate: u64,
    /// Links whose Zenoh handshake failed (no or a wrong password, a malformed opening).
    pub handshake: u64,
    /// Authenticated links that matched no access rule (a password with another process's
    /// certificate): everything they send or ask for is denied.
    pub no_access_rule: u64,
    /// Data messages (puts, deletes) of admitted links that a rule denied, either way: a process
    /// publishing a key it does not own, or a key it may not read about to be sent to it. A
    /// lower bound (see `deploy::launch::refusals`).
    #[serde(default)]
    pub denied_messages: u64,
}

impl RouterRefusals {
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    pub fn total(&self) -> u64 {
        self.certificate + self.handshake + self.no_access_rule + self.denied_messages
    }
}

/// The event cameras' sensor model of a run, as `summary.json` records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorRecord {
    /// The named preset, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// The `--perturb` terms over it, in the order given (later ones win).
    #[serde(default)]
    pub terms: Vec<String>,
    /// Every term the sensors ran with that differs from its default, sorted by key.
    pub perturb: BTreeMap<String, f64>,
    /// The run's seed: observer i's sensor draws from `stream_seed(seed, EventSensor, i)`.
    pub seed: u64,
}

impl RunSummary {
    /// Messages dropped by every process together.
    pub fn rejects_total(&self) -> u64 {
        self.rejects.values().flatten().map(|c| c.count).sum()
    }
}

/// Everything one observer published, for `observers.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ObserverRecord {
    pub tokens: Vec<TokenEvent>,
    pub frames: Vec<FrameEvent>,
    pub decisions: Vec<Decision>,
    /// The observer's image-plane track while receiving (`observer/<o>/track`).
    #[serde(default)]
    pub track: Vec<TrackSample>,
}

/// Everything `waggle run` writes into a run directory as JSON.
#[derive(Debug, Clone)]
pub struct RunFiles {
    pub summary: RunSummary,
    pub observers: BTreeMap<String, ObserverRecord>,
    /// Absent for runs made before the launcher wrote it.
    pub session: Option<SessionRecord>,
}

impl RunFiles {
    /// Reads `summary.json`, `observers.json` and (when present) `session.json` of `dir`.
    pub fn load(dir: &Path) -> Result<Self, RunDirError> {
        fn parse<T: serde::de::DeserializeOwned>(
            dir: &Path,
            file: &'static str,
        ) -> Result<T, RunDirError> {
            let path = dir.join(file);
            let text = std::fs::read_to_string(&path)
                .map_err(|source| RunDirError::Read { path, source })?;
            serde_json::from_str(&text).map_err(|source| RunDirError::Parse {
                dir: dir.to_path_buf(),
                file,
                source,
            })
        }
        let summary: RunSummary = parse(dir, SUMMARY_FILE)?;
        let observers = parse(dir, OBSERVERS_FILE)?;
        let session = match dir.join(SESSION_FILE).exists() {
            true => Some(parse(dir, SESSION_FILE)?),
            false => None,
        };
        Ok(Self {
            summary,
            observers,
            session,
        })
    }

    /// Writes the three files into `dir` (pretty JSON, the on-disk format). `observers` is a
    /// map of [`ObserverRecord`]s or of anything that serialises as one (the launcher's
    /// [`track_spool::SpooledRecord`]); each file is streamed, never built in memory whole.
    pub fn write<R: Serialize>(
        dir: &Path,
        summary: &RunSummary,
        observers: &BTreeMap<String, R>,
        session: &SessionRecord,
    ) -> Result<(), RunDirError> {
        fn stream(path: PathBuf, value: &impl Serialize) -> Result<(), RunDirError> {
            let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
            serde_json::to_writer_pretty(&mut w, value)?;
            std::io::Write::flush(&mut w)?;
            Ok(())
        }
        stream(dir.join(SUMMARY_FILE), summary)?;
        stream(dir.join(OBSERVERS_FILE), observers)?;
        stream(dir.join(SESSION_FILE), session)
    }
}

/// One planned run of a sweep, as recorded in `sweep.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedRun {
    pub case: String,
    pub modality: String,
    /// Run directory, relative to the sweep directory.
    pub dir: String,
    /// How `waggle run` ended (`exit 0`, `exit 1`, `signal 9`, `not started`).
    pub exit: String,
    pub wall_s: f64,
    /// The end of its stderr when it wrote no summary.
    pub error_tail: Option<String>,
}

/// `sweep.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SweepManifest {
    pub runs: Vec<PlannedRun>,
    pub jobs: usize,
    pub wall_s: f64,
    pub interrupted: bool,
}
