//! `waggle run CASE`: a whole case as separate OS processes talking over Zenoh only
//! (DESIGN.md §2–§3) — the simulator, one camera and one observer process per observer, the
//! performer and the scheduler — started, supervised and summarised by this launcher.
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
//! [`sweep`] runs many cases, each as its own `waggle run`.

pub mod bench;
pub mod fault;
pub mod gather;
pub mod process;
pub mod summarise;
pub mod supervise;
pub mod sweep;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use bus::{Bus, Endpoints, NodeArgs, SessionSecrets, handshake};
use proto::{Modality, ObserverId, Receiver, RenderPath, Role};

use crate::case::{Case, case_source};
use crate::run_dir::lock::RunLock;
use crate::run_dir::{CASE_FILE, LOG_DIR, RECORDING_FILE, RunFiles, RunSummary};
use fault::{ExtraFaults, Injected, injected_faults};
use process::{Proc, Spawner};
use summarise::{RunInfo, summarise};
use supervise::Supervisor;

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
    /// No progress bar.
    pub quiet: bool,
    /// Do not record the session.
    pub no_record: bool,
    /// Record every RGB frame (by default one in 25).
    pub record_all_rgb: bool,
    /// The launcher's own endpoints (default: listen on a free loopback port).
    pub endpoints: Endpoints,
    /// How the cameras render (both paths publish identical bytes).
    pub render: RenderPath,
}

/// The modality to run `case` in: `asked`, or events when the case applies to it (else RGB);
/// an error when the case does not apply to it.
pub fn run_modality(case: &Case, asked: Option<Modality>) -> Result<Modality> {
    let modality = match asked {
        Some(m) => m,
        None if case.modalities.contains(&Receiver::Events) => Modality::Events,
        None => Modality::Rgb,
    };
    if !case.modalities.contains(&Receiver::from(modality)) {
        bail!(
            "case {} does not apply to the {} modality (it lists {:?})",
            case.name,
            modality.as_str(),
            case.modalities
        );
    }
    Ok(modality)
}

/// Where one run lives.
struct RunPlace {
    session: String,
    /// Held until the run directory is written.
    _lock: RunLock,
    out_dir: PathBuf,
    log_dir: PathBuf,
    bin_dir: PathBuf,
}

impl RunPlace {
    fn new(opts: &RunOptions) -> Result<Self> {
        let session = match &opts.session {
            Some(s) => s.clone(),
            None => format!(
                "run-{}-{}",
                std::process::id(),
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_millis())
            ),
        };
        let out_dir = match &opts.out {
            Some(d) => d.clone(),
            None => std::env::temp_dir().join(format!("waggle-{session}")),
        };
        let lock = RunLock::acquire(&out_dir)?;
        let log_dir = out_dir.join(LOG_DIR);
        std::fs::create_dir_all(&log_dir)
            .with_context(|| format!("creating {}", log_dir.display()))?;
        let bin_dir = match &opts.bin_dir {
            Some(d) => d.clone(),
            None => std::env::current_exe()?
                .parent()
                .context("locating the directory of waggle")?
                .to_path_buf(),
        };
        Ok(Self {
            session,
            _lock: lock,
            out_dir,
            log_dir,
            bin_dir,
        })
    }
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct RunDone {
    pub summary: RunSummary,
    /// The run directory written.
    pub out_dir: PathBuf,
}

/// Runs `case` in `modality` as processes; writes the run directory and returns the summary.
pub fn run_case(case: &Case, modality: Modality, opts: &RunOptions) -> Result<RunDone> {
    let started = Instant::now();
    let injected = injected_faults(case, &opts.extra_faults)?;
    let observers: Vec<ObserverId> = (0..case.observers).map(ObserverId::from_index).collect();
    let place = RunPlace::new(opts)?;

    // The launcher's own session is the session's router: every child is a client of it.
    let mut mine = opts.endpoints.clone();
    if mine.listen.is_empty() {
        mine.listen
            .push(format!("tcp/127.0.0.1:{}", free_loopback_port()?));
    }
    let (mut bus, secrets) = open_router(&place.session, &mine, case.observers, opts)?;
    let keys = bus.keys().clone();
    for key in gather::subscriptions(&observers) {
        bus.subscribe(&keys.of(&key))?;
    }
    bus.subscribe(&keys.rejects_any())?;
    let me = handshake::Process::singleton(Role::Launcher);
    handshake::announce(&mut bus, &me)?;

    let spawner = Spawner {
        bin_dir: &place.bin_dir,
        log_dir: &place.log_dir,
        node: NodeArgs {
            session: place.session.clone(),
            observers: case.observers,
            standalone: false,
            recorder: !opts.no_record,
            startup_timeout_s: 120.0,
            deny: Vec::new(),
            client: true,
            credentials: None,
            endpoints: Endpoints {
                connect: children_connect(&mine),
                listen: Vec::new(),
            },
        },
        secrets: secrets.as_ref(),
    };
    let children = Children {
        case,
        modality,
        opts,
        observers: &observers,
        injected: &injected,
        keys: &keys,
    };
    let mut procs: Vec<Proc> = Vec::new();
    let spawned = children.spawn_all(&spawner, &place.out_dir, &mut procs);
    let stop = bus::on_stop_signal();
    let result = spawned.and_then(|()| {
        Supervisor {
            bus: &mut bus,
            procs: &mut procs,
            me: &me,
            case,
            observers: &observers,
            injected: &injected,
            stop: &stop,
            quiet: opts.quiet,
        }
        .run()
    });
    stop_all(&mut procs);
    let supervised = result.map_err(|e| with_logs(e, &place.log_dir, &procs))?;
    let _ = bus.close();

    let info = RunInfo {
        case,
        modality,
        render: opts.render,
        session: &place.session,
        started,
        injected: &injected,
    };
    let out = summarise(&info, supervised, &procs);
    RunFiles::write(&place.out_dir, &out.summary, &out.observers, &out.session)?;
    Ok(RunDone {
        summary: out.summary,
        out_dir: place.out_dir,
    })
}

/// Stops every child and reaps it (reading its final CPU time).
fn stop_all(procs: &mut [Proc]) {
    for p in procs.iter_mut() {
        p.kill();
    }
    for p in procs.iter_mut() {
        let _ = p.child.wait();
        let _ = p.poll();
    }
}

/// The error with the log directory and the stderr tail of every child that failed by itself.
fn with_logs(e: anyhow::Error, log_dir: &Path, procs: &[Proc]) -> anyhow::Error {
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

/// Opens the launcher's session as the session's router: with per-process credentials and the
/// per-role access-control list, or open (`--no-auth`, loopback only, with a warning).
fn open_router(
    session: &str,
    mine: &Endpoints,
    observers: usize,
    opts: &RunOptions,
) -> Result<(Bus, Option<SessionSecrets>)> {
    if opts.no_auth {
        let exposed = mine.non_loopback_listeners();
        if !exposed.is_empty() {
            bail!(
                "--no-auth with a non-loopback --listen ({}) would open the session to the \
                 network: drop --no-auth, or listen on 127.0.0.1",
                exposed.join(", ")
            );
        }
        eprintln!(
            "warning: --no-auth: the bus is open — any local process can join session {session}, \
             read every key (ground truth included) and publish on any"
        );
        let config = bus::open_router_config(mine)?;
        let bus = Bus::open_config(session, config).context("opening the launcher's router")?;
        return Ok((bus, None));
    }
    let keys = proto::Keys::new(session)?;
    let access = bus::access::role_access(&keys, observers, !opts.no_record);
    let users: Vec<String> = access.iter().map(|a| a.user.clone()).collect();
    let secrets = SessionSecrets::create(&std::env::temp_dir(), session, &users)
        .context("creating the session's credentials")?;
    let config = bus::router_config(
        mine,
        secrets.dictionary(),
        &bus::access::router_acl(&keys, &access),
    )?;
    let bus = Bus::open_config(session, config).context("opening the launcher's router")?;
    Ok((bus, Some(secrets)))
}

fn free_loopback_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").context("finding a free port")?;
    Ok(l.local_addr()?.port())
}

/// What children connect to: every listen endpoint of the launcher (on loopback), plus every
/// connect endpoint.
fn children_connect(mine: &Endpoints) -> Vec<String> {
    mine.listen
        .iter()
        .map(|l| {
            l.replace("0.0.0.0", "127.0.0.1")
                .replace("[::]", "127.0.0.1")
        })
        .chain(mine.connect.iter().cloned())
        .collect()
}

/// The children of one run and their arguments.
struct Children<'a> {
    case: &'a Case,
    modality: Modality,
    opts: &'a RunOptions,
    observers: &'a [ObserverId],
    injected: &'a [Injected],
    keys: &'a proto::Keys,
}

impl Children<'_> {
    /// Starts the simulator, scheduler, performer, each observer's camera and observer, and
    /// the recorder; `procs` holds every child started, even when one fails to start.
    fn spawn_all(
        &self,
        spawner: &Spawner<'_>,
        out_dir: &Path,
        procs: &mut Vec<Proc>,
    ) -> Result<()> {
        let m = self.modality.as_str().to_string();
        procs.push(spawner.spawn("sim", "sim-node", &["run".into()])?);
        procs.push(spawner.spawn("scheduler", "scheduler-node", &self.scheduler_args(&m))?);
        procs.push(spawner.spawn("performer", "performer-node", &[])?);
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
            procs.push(spawner.spawn(&format!("camera-{o}"), "sim-node", &camera_args)?);
            let observer_args = self.observer_args(o, &m);
            procs.push(spawner.spawn(&format!("observer-{o}"), "observer-node", &observer_args)?);
        }
        if !self.opts.no_record {
            let mut recorder_args = recorder_args(&self.opts.case_arg, self.case, &m, out_dir)?;
            if self.opts.record_all_rgb {
                recorder_args.push("--all-rgb".into());
            }
            let mut recorder = spawner.spawn("recorder", "recorder-node", &recorder_args)?;
            recorder.graceful = true;
            procs.push(recorder);
        }
        Ok(())
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

/// The case's text with any command-line override of `flights` written into it, so the
/// recorded case is the one that flew.
fn case_text_as_flown(case_arg: &str, case: &Case) -> Result<String> {
    let text = case_source(case_arg)?;
    let written: Case = toml::from_str(&text).context("re-reading the case text")?;
    if written.flights == case.flights {
        return Ok(text);
    }
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("flights"))
        .collect();
    Ok(format!(
        "# flights set on the command line\nflights = \"{}\"\n{}\n",
        case.flights,
        kept.join("\n")
    ))
}

/// `recorder-node` arguments for a run writing `out_dir/session.mcap`; writes the case text
/// to `out_dir/case.toml` so the recording holds the case and its expected outcome.
pub fn recorder_args(
    case_arg: &str,
    case: &Case,
    modality: &str,
    out_dir: &Path,
) -> Result<Vec<String>> {
    let case_file = out_dir.join(CASE_FILE);
    std::fs::write(&case_file, case_text_as_flown(case_arg, case)?)
        .with_context(|| format!("writing {}", case_file.display()))?;
    Ok(vec![
        "--out".into(),
        out_dir.join(RECORDING_FILE).display().to_string(),
        "--case-name".into(),
        case.name.clone(),
        "--case-file".into(),
        case_file.display().to_string(),
        "--modality".into(),
        modality.to_string(),
    ])
}
