//! `waggle run CASE`: a whole case as separate OS processes talking over Zenoh only
//! (docs/DESIGN.md §2–§3) — the simulator, one camera and one observer process per observer,
//! the performer and the scheduler — started, supervised and summarised by this launcher.
//!
//! The launcher hosts the session's Zenoh router, listening on loopback unless told otherwise
//! (multicast scouting off); every child is a client of it. By default each child
//! authenticates with its own per-session credentials and the router's access-control list
//! lets it publish only its own keys and receive only what it subscribes to ([`bus::access`]);
//! `--no-auth` opens the router (loopback only). It takes part in the start-up handshake (so
//! it sees every message it subscribes to from tick 0), injects faults — black input and
//! throttling on `fault/Oi` before the clock starts, and the dropout as a real SIGKILL of the
//! camera process once the clock passes its sim time — and shows a progress bar. When the
//! scheduler's report is in and every child has exited, it writes `DIR/summary.json` (and
//! `DIR/observers.json`, every token, frame and decision) and prints the same table as
//! `waggle mission`. Ctrl-C stops every child and still writes what was gathered.
//!
//! `waggle sweep` (many cases, each as its own `waggle run`, then the report) is the `lab`
//! crate's.

pub mod bench;
pub mod gather;
pub mod own_log;
pub mod process;
pub mod refusals;
pub mod router;
pub mod rss;
pub mod summarise;
pub mod supervise;
pub mod up;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use bus::{Endpoints, SessionSecrets};
use proto::{Modality, RenderPath};

pub use crate::case::run_modality;
use crate::case::{Case, case_source};
use crate::compose;
use crate::compose::build::{ComposeOptions, EventRecording};

use crate::fault::ExtraFaults;
use crate::run_dir::lock::RunLock;
use crate::run_dir::{LOG_DIR, RunSummary};
use node_args::SensorArgs;
use process::Proc;
use up::{UpDone, UpOptions};

/// How to run a case as processes (the options of `waggle run`).
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The case as named on the command line (a built-in name or a path), for the recording.
    pub case_arg: String,
    /// Where the summary, the recording and the logs go (default: a temporary directory).
    pub out: Option<PathBuf>,
    /// Session id (default: `run-<pid>-<unix ms>`).
    pub session: Option<String>,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    pub bin_dir: Option<PathBuf>,
    /// Wall-clock time after which an observer judges a late packet missing, ms.
    pub grace_ms: u64,
    /// Faults beyond the case's own.
    pub extra_faults: ExtraFaults,
    /// Run every observer behind an access-control list denying it ground truth.
    pub observer_acl: bool,
    /// Open bus: no authentication and no per-role access control on the router.
    pub no_auth: bool,
    /// Accept a plain `tcp/` router listener beyond loopback.
    pub plain_tcp: bool,
    /// No progress bar.
    pub quiet: bool,
    /// Do not record the session.
    pub no_record: bool,
    /// Record every RGB frame (by default one in 25).
    pub record_all_rgb: bool,
    /// What the recording keeps of the event cameras.
    pub record_events: EventRecording,
    /// The launcher's own endpoints (default: listen on a free loopback port).
    pub endpoints: Endpoints,
    /// How the cameras render (both paths publish identical bytes).
    pub render: RenderPath,
    /// Serve the view channels live over a Foxglove WebSocket on this loopback port.
    pub live: Option<u16>,
    /// Publish the session live as ROS 2 topics on `rmw_zenoh`.
    pub ros2: Option<up::Ros2View>,
    /// Observers whose camera is a ROS 2 topic of the `ros2` graph, and the topic.
    pub ros2_cameras: std::collections::BTreeMap<proto::ObserverId, String>,
    /// The event cameras' sensor model (default: the paper's ideal sensors).
    pub sensor: SensorArgs,
    /// Observers whose receiver is a plug-in, each in its observer's own process.
    pub receivers: std::collections::BTreeMap<proto::ObserverId, receiver_plugin::PluginSpec>,
    /// The plug-ins' wall-clock limit over the session, ms.
    pub plugin_time_limit_ms: Option<u64>,
    /// Sample every process's resident memory each time sim time crosses a multiple of this
    /// many seconds, into `DIR/rss.csv`.
    pub rss_every_s: Option<u32>,
}

/// Where one run lives.
pub(crate) struct RunPlace {
    /// Held until the run directory is written.
    _lock: RunLock,
    pub(crate) out_dir: PathBuf,
    pub(crate) log_dir: PathBuf,
    pub(crate) bin_dir: PathBuf,
}

impl RunPlace {
    pub(crate) fn new(session: &str, out: Option<&Path>, bin_dir: Option<&Path>) -> Result<Self> {
        let out_dir = match out {
            Some(d) => d.to_path_buf(),
            None => std::env::temp_dir().join(format!("waggle-{session}")),
        };
        let lock = RunLock::acquire(&out_dir)?;
        let log_dir = out_dir.join(LOG_DIR);
        std::fs::create_dir_all(&log_dir)
            .with_context(|| format!("creating {}", log_dir.display()))?;
        let bin_dir = match bin_dir {
            Some(d) => d.to_path_buf(),
            None => std::env::current_exe()?
                .parent()
                .context("locating the directory of waggle")?
                .to_path_buf(),
        };
        Ok(Self {
            _lock: lock,
            out_dir,
            log_dir,
            bin_dir,
        })
    }
}

/// A new session id: `run-<pid>-<unix ms>`.
pub fn new_session_id() -> String {
    format!(
        "run-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis())
    )
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct RunDone {
    pub summary: RunSummary,
    /// The run directory written.
    pub out_dir: PathBuf,
}

impl RunOptions {
    /// The compose options of this run of `case` (every node on one host).
    pub fn compose_options(&self, case: &Case, modality: Modality) -> Result<ComposeOptions> {
        Ok(ComposeOptions {
            case_name: self.case_arg.clone(),
            case_text: case_text_as_flown(&self.case_arg, case)?,
            session: self.session.clone().unwrap_or_else(new_session_id),
            modality,
            grace_ms: self.grace_ms,
            extra_faults: self.extra_faults.clone(),
            observer_acl: self.observer_acl,
            auth: !self.no_auth,
            plain_tcp: self.plain_tcp,
            record: !self.no_record,
            record_all_rgb: self.record_all_rgb,
            record_events: self.record_events,
            render: self.render,
            sensor: self.sensor.clone(),
            router_listen: self.endpoints.listen.clone(),
            router_connect: self.endpoints.connect.clone(),
            placements: Vec::new(),
            ros2_cameras: self.ros2_sources(case)?,
            receivers: self.receivers.clone(),
            plugin_time_limit_ms: self.plugin_time_limit_ms,
        })
    }

    /// The cameras of `--ros2-camera`, each on the ROS graph of the live view's domain and
    /// router; an observer the case lacks, or a topic the live view itself publishes, is
    /// refused.
    fn ros2_sources(
        &self,
        case: &Case,
    ) -> Result<std::collections::BTreeMap<proto::ObserverId, node_args::Ros2Source>> {
        let mut out = std::collections::BTreeMap::new();
        for (observer, topic) in &self.ros2_cameras {
            let Some(view) = &self.ros2 else {
                bail!("--ros2-camera {observer}={topic} needs --ros2-domain");
            };
            if !case.has_observer(observer.as_str()) {
                bail!(
                    "--ros2-camera {observer}={topic}: the case has {} observers",
                    case.observers
                );
            }
            if (0..case.observers)
                .any(|i| *topic == format!("/{}/events", proto::ObserverId::from_index(i)))
            {
                bail!(
                    "--ros2-camera {observer}={topic}: the live view publishes {topic} itself \
                     (a loop); name the camera's own topic"
                );
            }
            let source = node_args::Ros2Source {
                topic: Some(topic.clone()),
                domain: view.domain,
                router: view
                    .router
                    .clone()
                    .unwrap_or_else(|| node_args::DEFAULT_ROS2_ROUTER.to_string()),
                calibration: None,
            };
            out.insert(observer.clone(), source);
        }
        Ok(out)
    }
}

/// Runs `case` in `modality` as processes on this machine — the compose file of the case
/// brought up on its one host, with credentials that live as long as the run — and returns
/// the summary.
pub fn run_case(case: &Case, modality: Modality, opts: &RunOptions) -> Result<RunDone> {
    let compose = compose::build::compose(case, &opts.compose_options(case, modality)?)?;
    if opts.no_auth {
        // Refused before anything is created.
        let exposed: Vec<&String> = compose
            .router
            .listen
            .iter()
            .filter(|l| !bus::is_loopback_endpoint(l))
            .collect();
        if !exposed.is_empty() {
            bail!(
                "--no-auth with a non-loopback --listen ({}) would open the session to the \
                 network: drop --no-auth, or listen on 127.0.0.1",
                exposed
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let secrets = if compose.auth {
        let removed = SessionSecrets::remove_stale(&std::env::temp_dir());
        if removed > 0 {
            tracing::info!(removed, "removed the credentials of killed launchers");
        }
        Some(
            SessionSecrets::create(&std::env::temp_dir(), &compose.session, &compose.users())
                .context("creating the session's credentials")?,
        )
    } else {
        None
    };
    let up_opts = UpOptions {
        host: None,
        out: opts.out.clone(),
        bin_dir: opts.bin_dir.clone(),
        quiet: opts.quiet,
        live: opts.live,
        ros2: opts.ros2.clone(),
        rss_every_s: opts.rss_every_s,
    };
    match up::up(&compose, secrets.as_ref(), &up_opts)? {
        UpDone::Supervised(done) => Ok(*done),
        UpDone::Host { .. } => bail!("the one-host run did not supervise its session"),
    }
}

/// Stops every child and reaps it (reading its final CPU time).
pub(crate) fn stop_all(procs: &mut [Proc]) {
    for p in procs.iter_mut() {
        p.kill();
    }
    for p in procs.iter_mut() {
        let _ = p.child.wait();
        let _ = p.poll();
    }
}

/// The error with the log directory and the stderr tail of every child that failed by itself.
pub(crate) fn with_logs(e: anyhow::Error, log_dir: &Path, procs: &[Proc]) -> anyhow::Error {
    let logs: Vec<String> = procs
        .iter()
        .filter(|p| p.failed_on_its_own())
        .map(|p| {
            format!(
                "--- {} ({}):\n{}",
                p.name,
                p.exit.as_deref().unwrap_or("?"),
                p.tail()
            )
        })
        .collect();
    e.context(format!(
        "logs in {}\n{}",
        log_dir.display(),
        logs.join("\n")
    ))
}

/// The case's text with any command-line override of `flights` or `frame_check` written into
/// it, so the recorded case is the one that flew (the audit times frames by its check).
pub fn case_text_as_flown(case_arg: &str, case: &Case) -> Result<String> {
    let text = case_source(case_arg)?;
    let written: Case = toml::from_str(&text).context("re-reading the case text")?;
    let overridden: Vec<(&str, String)> = [
        (
            "flights",
            written.flights != case.flights,
            case.flights.to_string(),
        ),
        (
            "frame_check",
            written.frame_check != case.frame_check,
            case.frame_check.to_string(),
        ),
    ]
    .into_iter()
    .filter_map(|(key, differs, value)| differs.then_some((key, value)))
    .collect();
    if overridden.is_empty() {
        return Ok(text);
    }
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            let l = l.trim_start();
            !overridden.iter().any(|(key, _)| l.starts_with(key))
        })
        .collect();
    let mut out = String::new();
    for (key, value) in &overridden {
        out.push_str(&format!(
            "# {key} set on the command line\n{key} = \"{value}\"\n"
        ));
    }
    Ok(format!("{out}{}\n", kept.join("\n")))
}
