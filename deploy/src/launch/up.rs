//! `waggle up FILE [--host NAME]`: starts and supervises the nodes a compose file places on
//! one host (or on every host), with that host's part of the session:
//! - the router's host hosts the session's Zenoh router in this process (per-process users,
//!   per-role access list; open only on loopback);
//! - the simulator's host supervises the session — handshake, faults, progress, the summary —
//!   as a client of the router when the router runs elsewhere;
//! - every other host's launcher is a client that follows only the clock (to stop a camera at
//!   its dropout time) and the mission report, and writes its own logs and `host.json`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bus::{Bus, Credentials, Endpoints, NodeArgs, SessionSecrets, handshake};
use node_args::{NodeCommand, RecorderOutput};
use proto::{Key, ObserverId, RenderPath, Role};

use super::process::{Proc, Spawner};
use super::rss::RssSampler;
use super::summarise::{RunInfo, summarise};
use super::supervise::{Duty, Supervisor};
use super::{RunDone, RunPlace, own_log, stop_all, with_logs};
use crate::compose::{Compose, SiteRouter};
use crate::run_dir::{CASE_FILE, ProcessFigures, RECORDING_FILE, RouterRefusals, RunFiles};

/// A host's record of its own nodes (`DIR/host.json` on a host that does not supervise).
pub const HOST_FILE: &str = "host.json";

/// How to bring a compose file up.
#[derive(Debug, Clone, Default)]
pub struct UpOptions {
    /// Run only the nodes placed on this host (default: every node, on this machine).
    pub host: Option<String>,
    /// The run directory (default: a temporary directory).
    pub out: Option<PathBuf>,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    pub bin_dir: Option<PathBuf>,
    /// No progress bar.
    pub quiet: bool,
    /// Serve the view channels live over a Foxglove WebSocket on this loopback port (the
    /// recorder's host).
    pub live: Option<u16>,
    /// Publish the session live as ROS 2 topics on `rmw_zenoh` (the recorder's host).
    pub ros2: Option<Ros2View>,
    /// Sample this host's processes' resident memory each time sim time crosses a multiple of
    /// this many seconds, into `DIR/rss.csv`.
    pub rss_every_s: Option<u32>,
}

/// The live ROS 2 view: ROS domain and the ROS side's Zenoh router (default `rmw_zenohd`'s).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2View {
    pub domain: u32,
    pub router: Option<String>,
}

/// A host's own record.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct HostRecord {
    pub session: String,
    pub host: String,
    pub processes: BTreeMap<String, ProcessFigures>,
    pub faults: Vec<String>,
    pub report_seen: bool,
    pub interrupted: bool,
    /// What a site router hosted here refused (absent when nothing).
    #[serde(default, skip_serializing_if = "RouterRefusals::is_empty")]
    pub router_refusals: RouterRefusals,
}

/// What `up` did: the summary when this host supervised the session.
#[derive(Debug, Clone)]
pub enum UpDone {
    Supervised(Box<RunDone>),
    Host {
        record: HostRecord,
        out_dir: PathBuf,
    },
}

/// This invocation's share of the session.
struct Share {
    /// The hosts whose nodes it starts.
    hosts: Vec<String>,
    routing: bool,
    /// The site router this invocation hosts (its host's launcher is that router).
    site: Option<SiteRouter>,
    supervising: bool,
    /// The process name it has on the bus.
    me: handshake::Process,
}

impl Share {
    fn of(compose: &Compose, host: Option<&str>) -> Result<Self> {
        let all = compose.hosts();
        let hosts = match host {
            None => all,
            Some(h) if all.iter().any(|a| a == h) => vec![h.to_string()],
            Some(h) => bail!(
                "host {h:?} is not in the compose file (it places nodes on: {})",
                all.join(", ")
            ),
        };
        let routing = hosts.contains(&compose.router.host);
        // One machine playing every host needs no chain: everything dials the one router.
        let site = match hosts.as_slice() {
            [h] if !routing => compose.site_on(h).cloned(),
            _ => None,
        };
        let supervising = hosts.iter().any(|h| h == compose.supervisor_host());
        let me = if supervising {
            handshake::Process::singleton(Role::Launcher)
        } else {
            handshake::Process::host_launcher(&hosts[0])
        };
        Ok(Self {
            hosts,
            routing,
            site,
            supervising,
            me,
        })
    }
}

/// Starts and supervises this host's share of `compose`. `secrets` are the session's
/// credentials (required when `compose.auth`): those of this host's nodes and launcher, and
/// the router's dictionary on the router's host.
pub fn up(compose: &Compose, secrets: Option<&SessionSecrets>, opts: &UpOptions) -> Result<UpDone> {
    let started = Instant::now();
    let share = Share::of(compose, opts.host.as_deref())?;
    let mut compose = compose.clone();
    if share.hosts.len() == compose.hosts().len() {
        crate::compose::resolve_free_ports(&mut compose)?;
    }
    let case = compose.case()?;
    let injected = compose.injected(&case)?;
    let sensor = compose.sensor()?;
    sensor.check(compose.modality)?;
    let sensor = run_eval::sensor::record(&sensor)?;
    if let Some(port) = opts.live {
        check_live(&compose, &share, port)?;
    }
    if compose.auth && secrets.is_none() {
        bail!(
            "session {} is authenticated but no credentials were given",
            compose.session
        );
    }
    let place = RunPlace::new(
        &compose.session,
        opts.out.as_deref(),
        opts.bin_dir.as_deref(),
    )?;
    own_log::to_file(&place.log_dir.join("launcher.log"))?;
    let observers: Vec<ObserverId> = (0..case.observers).map(ObserverId::from_index).collect();
    // Every node started here dials like a node on the router's host when this invocation
    // runs the router (one machine), else like one on its own host.
    let dial_host = if share.routing {
        compose.router.host.clone()
    } else {
        share.hosts[0].clone()
    };
    let dial = compose.dial_from(&dial_host);
    let mut bus = open_bus(&compose, &share, secrets, &dial)?;
    watch(&mut bus, &share, &observers)?;

    let spawner = Spawner {
        bin_dir: &place.bin_dir,
        log_dir: &place.log_dir,
        node: NodeArgs {
            session: compose.session.clone(),
            observers: case.observers,
            standalone: false,
            recorder: compose.records(),
            startup_timeout_s: 120.0,
            deny: Vec::new(),
            client: true,
            credentials: None,
            endpoints: Endpoints {
                connect: dial,
                listen: Vec::new(),
            },
        },
        secrets,
    };
    let mut procs: Vec<Proc> = Vec::new();
    let spawned = spawn_share(
        &compose,
        &share,
        &spawner,
        &place.out_dir,
        (opts.live, opts.ros2.as_ref()),
        &mut procs,
    );
    let stop = bus::on_stop_signal();
    let result = spawned.and_then(|()| {
        let rss = opts
            .rss_every_s
            .map(|every_s| RssSampler::create(&place.out_dir, every_s, &procs))
            .transpose()?;
        Supervisor {
            bus: &mut bus,
            procs: &mut procs,
            me: &share.me,
            case: &case,
            observers: &observers,
            injected: &injected,
            stop: &stop,
            quiet: opts.quiet,
            recorder: compose.records(),
            duty: if share.supervising {
                Duty::Supervise
            } else {
                Duty::Host
            },
            rss,
            spool_dir: &place.out_dir,
        }
        .run()
    });
    stop_all(&mut procs);
    if let Some(site) = &share.site {
        linger_for_site(&mut bus, &compose, site, &stop);
    }
    let supervised = result.map_err(|e| with_logs(e, &place.log_dir, &procs))?;
    let _ = bus.close();

    if !share.supervising {
        return host_record(&compose, &share, supervised, &procs, &place.out_dir);
    }
    let info = RunInfo {
        case: &case,
        modality: compose.modality,
        render: render_path(&compose)?,
        sensor,
        session: &compose.session,
        started,
        injected: &injected,
    };
    let out = summarise(&info, supervised, &procs);
    RunFiles::write(&place.out_dir, &out.summary, &out.observers, &out.session)?;
    Ok(UpDone::Supervised(Box::new(RunDone {
        summary: out.summary,
        out_dir: place.out_dir.clone(),
    })))
}

/// `--live PORT` needs the recorder on this host.
fn check_live(compose: &Compose, share: &Share, port: u16) -> Result<()> {
    match compose.nodes.iter().find(|n| n.role.role == Role::Recorder) {
        None => {
            bail!("--live {port}: the session records nothing (the live view is the recorder's)")
        }
        Some(r) if !share.hosts.contains(&r.host) => bail!(
            "--live {port}: the recorder runs on host {}: pass --live to `waggle up --host {}`",
            r.host,
            r.host
        ),
        Some(_) => Ok(()),
    }
}

/// Subscribes to what this launcher follows (everything it gathers when supervising, else the
/// clock and the report) and announces it.
fn watch(bus: &mut Bus, share: &Share, observers: &[ObserverId]) -> Result<()> {
    let keys = bus.keys().clone();
    let watched: Vec<Key> = if share.supervising {
        super::gather::subscriptions(observers)
    } else {
        vec![Key::Clock, Key::SchedReport]
    };
    for key in watched {
        bus.subscribe(&keys.of(&key))?;
    }
    if share.supervising {
        bus.subscribe(&keys.rejects_any())?;
    }
    handshake::announce(bus, &share.me)?;
    Ok(())
}

/// Writes a host's `host.json`.
fn host_record(
    compose: &Compose,
    share: &Share,
    supervised: super::supervise::Supervised,
    procs: &[Proc],
    out_dir: &Path,
) -> Result<UpDone> {
    let record = HostRecord {
        session: compose.session.clone(),
        host: share.hosts.join(","),
        processes: procs
            .iter()
            .map(|p| (p.name.clone(), p.figures()))
            .collect(),
        faults: supervised.fault_log,
        report_seen: supervised.gathered.report.is_some(),
        interrupted: supervised.interrupted,
        router_refusals: super::refusals::counted(),
    };
    let file = out_dir.join(HOST_FILE);
    std::fs::write(&file, serde_json::to_string_pretty(&record)?)
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(UpDone::Host {
        record,
        out_dir: out_dir.to_path_buf(),
    })
}

/// How the cameras render (their `--render` argument; the default when none says).
fn render_path(compose: &Compose) -> Result<RenderPath> {
    for n in &compose.nodes {
        if let NodeCommand::Camera(c) = n.line()?.command {
            return Ok(c.render);
        }
    }
    Ok(RenderPath::default())
}

/// How long a site's router waits, at most, for the processes of the hosts it serves to leave
/// once its own host is done (their last messages and the mission report cross it).
const SITE_LINGER: Duration = Duration::from_secs(30);

/// Keeps a site's router up until no process of the other hosts it serves is alive on the bus
/// (or [`SITE_LINGER`] has passed, or Ctrl-C).
fn linger_for_site(bus: &mut Bus, compose: &Compose, site: &SiteRouter, stop: &AtomicBool) {
    let keys = bus.keys().clone();
    let served: Vec<String> = site
        .serves
        .iter()
        .flat_map(|h| {
            compose
                .nodes_on(h)
                .map(|n| n.role.clone())
                .chain(std::iter::once(launcher_process(compose, h)))
        })
        .filter_map(|p| p.alive_key(&keys).ok())
        .collect();
    let until = Instant::now() + SITE_LINGER;
    while Instant::now() < until && !stop.load(Ordering::SeqCst) {
        if !served.iter().any(|k| bus.is_alive(k)) {
            return;
        }
        let _ = bus.recv(Duration::from_millis(200));
    }
}

/// The launcher process of `host` (see [`Compose::launcher_of`]).
fn launcher_process(compose: &Compose, host: &str) -> handshake::Process {
    if host == compose.supervisor_host() {
        handshake::Process::singleton(Role::Launcher)
    } else {
        handshake::Process::host_launcher(host)
    }
}

/// The launcher's own session: the router on the router's host, a site's router on a site
/// router's host, else a client of the router its host dials.
fn open_bus(
    compose: &Compose,
    share: &Share,
    secrets: Option<&SessionSecrets>,
    dial: &[String],
) -> Result<Bus> {
    let session = &compose.session;
    if share.routing {
        return super::router::open(compose, secrets);
    }
    if let Some(site) = &share.site {
        let config = super::router::site_config(compose, site, secrets)?;
        return Bus::open_config(session, config).with_context(|| {
            format!(
                "opening the site router on {} (dialling the session's router at {})",
                site.listen.join(", "),
                compose.router_dial_from(&site.host).join(", ")
            )
        });
    }
    let endpoints = Endpoints {
        connect: dial.to_vec(),
        listen: Vec::new(),
    };
    let config = match secrets {
        Some(s) => {
            let user = share.me.name();
            let file = s
                .file_of(&user)
                .with_context(|| format!("no credentials for {user}"))?;
            bus::client_config(&endpoints, &Credentials::read(file)?)?
        }
        None => bus::open_client_config(&endpoints)?,
    };
    Bus::open_config(session, config)
        .with_context(|| format!("connecting to the session's router at {}", dial.join(", ")))
}

/// Starts the nodes of `share`; `procs` holds every child started, even when one fails.
fn spawn_share(
    compose: &Compose,
    share: &Share,
    spawner: &Spawner<'_>,
    out_dir: &Path,
    views: (Option<u16>, Option<&Ros2View>),
    procs: &mut Vec<Proc>,
) -> Result<()> {
    for node in compose
        .nodes
        .iter()
        .filter(|n| share.hosts.contains(&n.host))
    {
        let mut args = node.args.clone();
        let recorder = node.role.role == Role::Recorder;
        if recorder {
            let output = recorder_output(&compose.case, out_dir, views)?;
            args.extend(output.to_args());
            if let Some(addr) = output.live {
                eprintln!(
                    "live view: ws://{addr} (Foxglove: Open connection → Foxglove WebSocket)"
                );
            }
            if let Some(domain) = output.ros2_domain {
                eprintln!(
                    "live ROS 2 view: domain {domain} via {} (ros2 topic list under \
                     RMW_IMPLEMENTATION=rmw_zenoh_cpp)",
                    output
                        .ros2_router
                        .as_deref()
                        .unwrap_or(ros2_bag::live::DEFAULT_ROUTER)
                );
            }
        }
        let mut p = spawner.spawn(&node.role.name(), &node.binary, &args)?;
        p.graceful = recorder;
        procs.push(p);
    }
    Ok(())
}

/// Where the recorder writes in the run directory, and the live view's loopback address; writes
/// the case text to `out_dir/case.toml` so the recording holds the case and its expected outcome.
fn recorder_output(
    case_text: &str,
    out_dir: &Path,
    (live, ros2): (Option<u16>, Option<&Ros2View>),
) -> Result<RecorderOutput> {
    let case_file = out_dir.join(CASE_FILE);
    std::fs::write(&case_file, case_text)
        .with_context(|| format!("writing {}", case_file.display()))?;
    Ok(RecorderOutput {
        out: out_dir.join(RECORDING_FILE),
        case_file: Some(case_file),
        live: live.map(|port| std::net::SocketAddr::from(([127, 0, 0, 1], port))),
        ros2_domain: ros2.map(|r| r.domain),
        ros2_router: ros2.and_then(|r| r.router.clone()),
    })
}
