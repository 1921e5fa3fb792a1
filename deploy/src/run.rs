//! `waggle run CASE`: a whole case as separate OS processes talking over Zenoh only
//! (DESIGN.md §2–§3) — the simulator, one camera and one observer process per observer, the
//! performer and the scheduler — started, supervised and summarised by this launcher.
//!
//! The launcher is a Zenoh peer listening on loopback (multicast scouting off); every child
//! connects to it and finds the others by gossip. It takes part in the start-up handshake (so
//! it sees every message it subscribes to from tick 0), injects faults — black input and
//! throttling on `fault/Oi` before the clock starts, and the dropout as a real SIGKILL of the
//! camera process once the clock passes its sim time — and shows a progress bar. When the
//! scheduler's report is in and every child has exited, it writes `DIR/summary.json` (and
//! `DIR/observers.json`, every token, frame and decision) and prints the same table as
//! `waggle mission`. Ctrl-C stops every child and still writes what was gathered.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bus::{Bus, BusError, Endpoints, Inbound, NodeArgs, handshake};
use proto::Modality;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use proto::scene::{observer_home_m, observer_name};
use proto::{
    ClockTick, Decision, Fault, FaultKind, FrameEvent, MissionReport, ObserverId, ObserverStatus,
    ObserverTrack, PerformerTruth, Role, SessionEvent, SessionTick, SimContacts, SimState,
    TokenEvent, TrackSample,
};
use serde::{Deserialize, Serialize};

use crate::case::{Case, Receiver, FaultKind as CaseFault};
use crate::summary::{MissionSummary, ObserverSummary, audit, check_expected, ns_s, print_summary};

#[derive(Debug, Args)]
pub struct RunArgs {
    /// Built-in case name (one-observer, two-observers, nominal-3, black-o2, no-broadcast,
    /// only-a, dropout-o2) or a path to a case TOML file.
    case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    modality: Option<Modality>,
    /// Write DIR/summary.json, DIR/observers.json and the process logs (DIR/logs) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
    /// Session id (default: `run-<pid>-<unix ms>`); every key lives under `waggle/<session>/`.
    #[arg(long)]
    session: Option<String>,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    bin_dir: Option<PathBuf>,
    /// Wall-clock time after which an observer judges a late packet missing, ms.
    #[arg(long, default_value_t = 10_000)]
    grace_ms: u64,
    /// Extra fault: black input of this observer from start-up (e.g. `O2`); repeatable.
    #[arg(long)]
    black: Vec<String>,
    /// Extra fault: SIGKILL this observer's camera at a sim time, `O2@35`; repeatable.
    #[arg(long)]
    kill: Vec<String>,
    /// Extra fault: throttle a camera, `O1@0:250:0` = observer@from_s:drop per mille:delay ms.
    #[arg(long)]
    throttle: Vec<String>,
    /// Run every observer behind a Zenoh access-control list that denies it ground truth
    /// (`sim/**`, `truth/**`), the performer's and scheduler's commands, faults and every other
    /// observer's keys (DESIGN.md §2: the run must still pass).
    #[arg(long)]
    observer_acl: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Do not record the session (by default `recorder-node` writes DIR/session.mcap, with the
    /// case in its metadata; see `waggle audit` and `waggle replay`).
    #[arg(long)]
    no_record: bool,
    /// Record every RGB frame (by default one in 25, i.e. 1 Hz).
    #[arg(long)]
    record_all_rgb: bool,
    /// The launcher's own endpoints (default: listen on a free loopback port). Children
    /// connect to every listen endpoint given here, plus every connect endpoint.
    #[command(flatten)]
    endpoints: Endpoints,
}

/// A fault the launcher injects.
#[derive(Debug, Clone, PartialEq)]
enum Injected {
    /// Published on `fault/Oi` before the clock starts.
    Message(Fault),
    /// SIGKILL of the camera process once the clock reaches `at_ns`.
    KillCamera { observer: ObserverId, at_ns: u64 },
}

fn secs_ns(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

fn faults(case: &Case, args: &RunArgs) -> Result<Vec<Injected>> {
    let mut out = Vec::new();
    for f in &case.faults {
        let observer = ObserverId::new(f.observer.as_str())?;
        out.push(match f.kind {
            CaseFault::Black => Injected::Message(Fault {
                observer,
                kind: FaultKind::BlackInput,
                from_ns: 0,
                until_ns: None,
            }),
            CaseFault::Dropout => Injected::KillCamera {
                observer,
                at_ns: secs_ns(f.at_s),
            },
            CaseFault::Throttle => Injected::Message(Fault {
                observer,
                kind: FaultKind::Throttle {
                    drop_per_mille: f.drop_per_mille,
                    delay_ms: f.delay_ms,
                },
                from_ns: secs_ns(f.at_s),
                until_ns: None,
            }),
        });
    }
    for o in &args.black {
        out.push(Injected::Message(Fault {
            observer: ObserverId::new(o.as_str())?,
            kind: FaultKind::BlackInput,
            from_ns: 0,
            until_ns: None,
        }));
    }
    for k in &args.kill {
        let (o, at) = k
            .split_once('@')
            .with_context(|| format!("--kill {k:?}: want OBSERVER@SECONDS"))?;
        let at_s: f64 = at.parse().with_context(|| format!("--kill {k:?}"))?;
        if !(at_s.is_finite() && at_s >= 0.0) {
            bail!("--kill {k:?}: the time must be a non-negative number");
        }
        out.push(Injected::KillCamera {
            observer: ObserverId::new(o)?,
            at_ns: secs_ns(at_s),
        });
    }
    for t in &args.throttle {
        let bad = || format!("--throttle {t:?}: want OBSERVER@FROM_S:DROP_PER_MILLE:DELAY_MS");
        let (o, rest) = t.split_once('@').with_context(bad)?;
        let parts: Vec<&str> = rest.split(':').collect();
        let [from, drop, delay] = parts[..] else {
            bail!(bad());
        };
        let from_s: f64 = from.parse().with_context(bad)?;
        let drop_per_mille: u16 = drop.parse().with_context(bad)?;
        if drop_per_mille > 1000 || !(from_s.is_finite() && from_s >= 0.0) {
            bail!(bad());
        }
        out.push(Injected::Message(Fault {
            observer: ObserverId::new(o)?,
            kind: FaultKind::Throttle {
                drop_per_mille,
                delay_ms: delay.parse().with_context(bad)?,
            },
            from_ns: secs_ns(from_s),
            until_ns: None,
        }));
    }
    let names: Vec<String> = (0..case.observers).map(observer_name).collect();
    for f in &out {
        let o = match f {
            Injected::Message(m) => &m.observer,
            Injected::KillCamera { observer, .. } => observer,
        };
        if !names.iter().any(|n| n == o.as_str()) {
            bail!("fault names {o}, but the case has {}", names.join(", "));
        }
    }
    Ok(out)
}

/// One supervised child process.
struct Proc {
    name: String,
    child: Child,
    /// CPU time (user + system) last read from /proc, seconds.
    cpu_s: f64,
    exit: Option<String>,
    success: bool,
    killed_by_fault: bool,
    /// Stopped by the launcher (end of run, failure elsewhere or Ctrl-C).
    stopped: bool,
    /// Stopped with SIGTERM and given time to finish (the recorder closes its file).
    graceful: bool,
    stdout_path: PathBuf,
    stderr_path: PathBuf,
}

/// Linux reports process times in USER_HZ, which is 100 on every mainstream ABI.
const USER_HZ: f64 = 100.0;

/// (state, user + system CPU seconds) of a live or zombie process.
fn proc_stat(pid: u32) -> Option<(char, f64)> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let rest = &text[text.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let state = fields.first()?.chars().next()?;
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    Some((state, (utime + stime) / USER_HZ))
}

impl Proc {
    /// Reads the CPU time (the final one once the process is a zombie) and reaps it if done.
    fn poll(&mut self) -> Result<()> {
        if self.exit.is_some() {
            return Ok(());
        }
        if let Some((_, cpu_s)) = proc_stat(self.child.id()) {
            self.cpu_s = cpu_s;
        }
        if let Some(status) = self.child.try_wait()? {
            self.success = status.success();
            self.exit = Some(match status.code() {
                Some(c) => format!("exit {c}"),
                None => {
                    use std::os::unix::process::ExitStatusExt;
                    format!("signal {}", status.signal().unwrap_or(0))
                }
            });
        }
        Ok(())
    }

    fn running(&self) -> bool {
        self.exit.is_none()
    }

    fn kill(&mut self) {
        if self.running() {
            self.stopped = true;
            if self.graceful
                && crate::recording::terminate(&mut self.child, Duration::from_secs(15))
            {
                return;
            }
            let _ = self.child.kill();
        }
    }

    fn tail(&self) -> String {
        let text = std::fs::read_to_string(&self.stderr_path).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(5)..].join("\n")
    }
}

struct Launch<'a> {
    bin_dir: &'a Path,
    log_dir: &'a Path,
    node: NodeArgs,
}

impl Launch<'_> {
    fn spawn(&self, name: &str, binary: &str, args: &[String]) -> Result<Proc> {
        let bin = self.bin_dir.join(binary);
        if !bin.exists() {
            bail!(
                "{} not found: build the node binaries first (cargo build --release -p deploy \
                 -p sim-node -p observer-node -p performer-node -p scheduler-node -p recorder-node) \
                 or pass --bin-dir",
                bin.display()
            );
        }
        let stdout_path = self.log_dir.join(format!("{name}.out"));
        let stderr_path = self.log_dir.join(format!("{name}.log"));
        let mut cmd = Command::new(&bin);
        cmd.args(args)
            .args(self.node.to_args())
            .stdin(Stdio::null())
            .stdout(File::create(&stdout_path)?)
            .stderr(File::create(&stderr_path)?);
        if std::env::var_os("RUST_LOG").is_none() {
            cmd.env("RUST_LOG", "info,zenoh=warn");
        }
        // Backup for binaries built without the rpath to MuJoCo.
        let mujoco = Path::new(env!("CARGO_MANIFEST_DIR")).join("../third_party/mujoco/lib");
        let mut paths = vec![mujoco];
        if let Some(old) = std::env::var_os("LD_LIBRARY_PATH") {
            paths.extend(std::env::split_paths(&old));
        }
        cmd.env("LD_LIBRARY_PATH", std::env::join_paths(paths)?);
        let child = cmd
            .spawn()
            .with_context(|| format!("starting {}", bin.display()))?;
        Ok(Proc {
            name: name.to_string(),
            child,
            cpu_s: 0.0,
            exit: None,
            success: false,
            killed_by_fault: false,
            stopped: false,
            graceful: false,
            stdout_path,
            stderr_path,
        })
    }
}

/// Per-process figures in the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessFigures {
    pub cpu_s: f64,
    pub exit: String,
    pub killed_by_fault: bool,
}

/// `summary.json` of a distributed run: the shared mission summary plus run figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    #[serde(flatten)]
    pub mission: MissionSummary,
    pub session: String,
    /// Wall time from the first to the last tick divided by the simulated time.
    pub wall_over_sim: f64,
    /// Wall time from launch until the clock started, s.
    pub startup_s: f64,
    /// Sensor packets each observer judged missing.
    pub missing_packets: BTreeMap<String, u64>,
    /// Distance of each observer from its home at the end, m.
    pub home_error_m: BTreeMap<String, f64>,
    /// The farthest each observer got from its home during the mission, m.
    pub max_excursion_m: BTreeMap<String, f64>,
    /// Each camera's digest of every payload it published (equal across fault-free runs).
    pub sensor_digests: BTreeMap<String, String>,
    pub processes: BTreeMap<String, ProcessFigures>,
    /// Injected faults with the sim time they took effect.
    pub faults: Vec<String>,
    pub interrupted: bool,
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

/// What the launcher gathered from the bus.
#[derive(Default)]
struct Gathered {
    tick: u64,
    clock_started: Option<Instant>,
    last_tick_at: Option<Instant>,
    records: BTreeMap<ObserverId, ObserverRecord>,
    missing: BTreeMap<ObserverId, u64>,
    phase: String,
    report: Option<MissionReport>,
    contacts: Option<SimContacts>,
    state: Option<SimState>,
    /// Observers' homes, and the farthest each got from it (every `sim/state` sample).
    homes_m: BTreeMap<String, [f64; 3]>,
    excursion_m: BTreeMap<String, f64>,
    /// Performer spans, controls, trips and stays for `session.json`.
    session: crate::report::record::SessionRecorder,
}

enum Topic {
    Clock,
    State,
    Contacts,
    Session,
    Report,
    Status,
    Tokens,
    Frames,
    Decision,
    Truth,
    Track,
}

impl Gathered {
    fn take(&mut self, topic: &Topic, key: &str, payload: &[u8]) -> Result<(), BusError> {
        match topic {
            Topic::Clock => {
                let c: ClockTick = bus::decode(key, payload)?;
                self.tick = c.tick;
                let now = Instant::now();
                self.clock_started.get_or_insert(now);
                self.last_tick_at = Some(now);
            }
            Topic::State => {
                let s: SimState = bus::decode(key, payload)?;
                self.session.state(&s);
                for d in &s.drones {
                    if let Some(h) = self.homes_m.get(&d.name) {
                        let e = distance_m(d.pos_m, *h);
                        let m = self.excursion_m.entry(d.name.clone()).or_insert(0.0);
                        *m = m.max(e);
                    }
                }
                self.state = Some(s);
            }
            Topic::Contacts => self.contacts = Some(bus::decode(key, payload)?),
            Topic::Report => {
                let r: MissionReport = bus::decode(key, payload)?;
                self.session.report(&r);
                self.report = Some(r);
            }
            Topic::Truth => {
                let t: PerformerTruth = bus::decode(key, payload)?;
                self.session.truth(&t);
            }
            Topic::Track => {
                let t: ObserverTrack = bus::decode(key, payload)?;
                self.records
                    .entry(t.observer.clone())
                    .or_default()
                    .track
                    .extend(t.samples);
            }
            Topic::Session => {
                let s: SessionTick = bus::decode(key, payload)?;
                self.session.session(&s);
                for c in s.controls {
                    self.phase = match c.event {
                        SessionEvent::RoundReset { round } => format!("round {round}"),
                        SessionEvent::WindowOpen { round } => format!("round {round}: receiving"),
                        SessionEvent::WindowClose { round } => format!("round {round}: flying"),
                        SessionEvent::MissionEnd => "mission end".into(),
                    };
                }
            }
            Topic::Status => {
                let s: ObserverStatus = bus::decode(key, payload)?;
                if s.input == proto::InputState::Missing {
                    *self.missing.entry(s.observer).or_default() += 1;
                }
            }
            Topic::Tokens => {
                let t: TokenEvent = bus::decode(key, payload)?;
                self.records
                    .entry(t.observer.clone())
                    .or_default()
                    .tokens
                    .push(t);
            }
            Topic::Frames => {
                let f: FrameEvent = bus::decode(key, payload)?;
                self.records
                    .entry(f.observer.clone())
                    .or_default()
                    .frames
                    .push(f);
            }
            Topic::Decision => {
                let d: Decision = bus::decode(key, payload)?;
                self.records
                    .entry(d.observer.clone())
                    .or_default()
                    .decisions
                    .push(d);
            }
        }
        Ok(())
    }

    fn message(&self, observers: &[ObserverId]) -> String {
        let sim_s = ns_s(self.tick * proto::TICK_NS);
        let rtf = match (self.clock_started, self.last_tick_at) {
            (Some(a), Some(b)) if b > a => sim_s / (b - a).as_secs_f64(),
            _ => 0.0,
        };
        let tokens: Vec<String> = observers
            .iter()
            .map(|o| {
                let n = self.records.get(o).map_or(0, |r| r.tokens.len());
                format!("{o} {n}")
            })
            .collect();
        format!(
            "sim {sim_s:7.2} s · {rtf:4.1}× real time · tokens {} · {}",
            tokens.join(" "),
            if self.phase.is_empty() {
                "starting"
            } else {
                &self.phase
            }
        )
    }
}

fn distance_m(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn free_loopback_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").context("finding a free port")?;
    Ok(l.local_addr()?.port())
}

pub fn run(args: RunArgs) -> Result<()> {
    let case = Case::load(&args.case)?;
    let modality = match args.modality {
        Some(m) => m,
        None if case.modalities.contains(&Receiver::Events) => Modality::Events,
        None => Modality::Rgb,
    };
    let case_modality = Receiver::from(modality);
    if !case.modalities.contains(&case_modality) {
        bail!(
            "case {} does not apply to the {} modality (it lists {:?})",
            case.name,
            modality.as_str(),
            case.modalities
        );
    }
    let summary = fly(&case, modality, &args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary.mission);
        print_run_figures(&summary);
    }
    if summary.interrupted {
        bail!("interrupted");
    }
    if !summary.mission.pass {
        bail!(
            "case {} did not meet its expected outcome: {}",
            summary.mission.case,
            summary.mission.reasons.join("; ")
        );
    }
    Ok(())
}

fn print_run_figures(s: &RunSummary) {
    println!(
        "session {} · wall/sim {:.3} · start-up {:.1} s · missing packets {:?}",
        s.session, s.wall_over_sim, s.startup_s, s.missing_packets
    );
    let cpu: Vec<String> = s
        .processes
        .iter()
        .map(|(n, p)| format!("{n} {:.1}", p.cpu_s))
        .collect();
    println!("CPU s per process: {}", cpu.join(" · "));
    for f in &s.faults {
        println!("  fault: {f}");
    }
}

fn fly(case: &Case, modality: Modality, args: &RunArgs) -> Result<RunSummary> {
    let started = Instant::now();
    let injected = faults(case, args)?;
    let n = case.observers;
    let observers: Vec<ObserverId> = (0..n).map(ObserverId::from_index).collect();
    let session = match &args.session {
        Some(s) => s.clone(),
        None => format!(
            "run-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_millis())
        ),
    };
    let out_dir = match &args.out {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("waggle-{session}")),
    };
    let log_dir = out_dir.join("logs");
    std::fs::create_dir_all(&log_dir).with_context(|| format!("creating {}", log_dir.display()))?;
    let bin_dir = match &args.bin_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()?
            .parent()
            .context("locating the directory of waggle")?
            .to_path_buf(),
    };

    // The launcher's own session: a listening loopback peer the children connect to.
    let mut mine = args.endpoints.clone();
    if mine.listen.is_empty() {
        mine.listen
            .push(format!("tcp/127.0.0.1:{}", free_loopback_port()?));
    }
    let mut bus = Bus::open(&session, &mine).context("opening the launcher's Zenoh session")?;
    let keys = bus.keys().clone();
    let mut topics: BTreeMap<String, Topic> = BTreeMap::new();
    topics.insert(keys.clock(), Topic::Clock);
    topics.insert(keys.sim_state(), Topic::State);
    topics.insert(keys.sim_contacts(), Topic::Contacts);
    topics.insert(keys.sched_session(), Topic::Session);
    topics.insert(keys.sched_report(), Topic::Report);
    topics.insert(keys.truth_performer(), Topic::Truth);
    for o in &observers {
        topics.insert(keys.observer_track(o), Topic::Track);
        topics.insert(keys.observer_status(o), Topic::Status);
        topics.insert(keys.observer_tokens(o), Topic::Tokens);
        topics.insert(keys.observer_frames(o), Topic::Frames);
        topics.insert(keys.observer_decision(o), Topic::Decision);
    }
    for key in topics.keys() {
        bus.subscribe(key)?;
    }
    let me = handshake::Process::singleton(Role::Launcher);
    handshake::announce(&mut bus, &me)?;

    let children_connect: Vec<String> = mine
        .listen
        .iter()
        .map(|l| {
            l.replace("0.0.0.0", "127.0.0.1")
                .replace("[::]", "127.0.0.1")
        })
        .chain(mine.connect.iter().cloned())
        .collect();
    let launch = Launch {
        bin_dir: &bin_dir,
        log_dir: &log_dir,
        node: NodeArgs {
            session: session.clone(),
            observers: n,
            standalone: false,
            recorder: !args.no_record,
            startup_timeout_s: 120.0,
            deny: Vec::new(),
            endpoints: Endpoints {
                connect: children_connect,
                listen: Vec::new(),
            },
        },
    };
    let m = modality.as_str().to_string();
    let mut procs: Vec<Proc> = Vec::new();
    let spawned = (|| -> Result<()> {
        procs.push(launch.spawn("sim", "sim-node", &["run".into()])?);
        procs.push(launch.spawn("scheduler", "scheduler-node", &scheduler_args(case, &m))?);
        procs.push(launch.spawn("performer", "performer-node", &[])?);
        for o in &observers {
            let mut camera_args = vec![
                "camera".into(),
                "--observer".into(),
                o.to_string(),
                "--modality".into(),
                m.clone(),
            ];
            let black_from_start = injected.iter().any(|f| {
                matches!(f, Injected::Message(Fault { observer, kind: FaultKind::BlackInput, from_ns: 0, .. }) if observer == o)
            });
            if black_from_start {
                camera_args.push("--black".into());
            }
            procs.push(launch.spawn(&format!("camera-{o}"), "sim-node", &camera_args)?);
            let mut observer_args = vec![
                "--id".into(),
                o.to_string(),
                "--modality".into(),
                m.clone(),
                "--grace-ms".into(),
                args.grace_ms.to_string(),
            ];
            if args.observer_acl {
                for key in observer_denied_keys(&keys, o, &observers) {
                    observer_args.push("--deny".into());
                    observer_args.push(key);
                }
            }
            procs.push(launch.spawn(&format!("observer-{o}"), "observer-node", &observer_args)?);
        }
        if !args.no_record {
            let mut recorder_args =
                crate::recording::recorder_args(&args.case, case, &m, &out_dir)?;
            if args.record_all_rgb {
                recorder_args.push("--all-rgb".into());
            }
            let mut recorder = launch.spawn("recorder", "recorder-node", &recorder_args)?;
            recorder.graceful = true;
            procs.push(recorder);
        }
        Ok(())
    })();
    let stop = bus::on_stop_signal();
    let result = spawned.and_then(|()| {
        supervise(
            &mut bus, &mut procs, &me, case, &observers, &injected, &topics, &stop, args.quiet,
        )
    });
    for p in &mut procs {
        p.kill();
    }
    for p in &mut procs {
        let _ = p.child.wait();
        let _ = p.poll();
    }
    let (gathered, fault_log, interrupted) = match result {
        Ok(x) => x,
        Err(e) => {
            let logs: Vec<String> = procs
                .iter()
                .filter(|p| !p.success && !p.killed_by_fault && !p.stopped)
                .map(|p| {
                    format!(
                        "--- {} ({}):\n{}",
                        p.name,
                        p.exit.as_deref().unwrap_or("?"),
                        p.tail()
                    )
                })
                .collect();
            return Err(e.context(format!(
                "logs in {}\n{}",
                log_dir.display(),
                logs.join("\n")
            )));
        }
    };
    let _ = bus.close();

    let summary = summarise(
        case,
        modality,
        &session,
        gathered,
        &procs,
        fault_log,
        interrupted,
        started,
    )?;
    std::fs::write(
        out_dir.join("summary.json"),
        serde_json::to_string_pretty(&summary.0)?,
    )?;
    std::fs::write(
        out_dir.join("observers.json"),
        serde_json::to_string_pretty(&summary.1)?,
    )?;
    std::fs::write(
        out_dir.join("session.json"),
        serde_json::to_string_pretty(&summary.2)?,
    )?;
    if args.out.is_none() && !args.json {
        println!("summary and logs in {}", out_dir.display());
    }
    Ok(summary.0)
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

fn scheduler_args(case: &Case, modality: &str) -> Vec<String> {
    let mut a = vec![
        "--modality".into(),
        modality.to_string(),
        "--offers".into(),
        case.offer_sites.join(","),
        "--rounds".into(),
        case.rounds.to_string(),
    ];
    if let Some(limit) = case.time_limit_s {
        a.push("--time-limit-s".into());
        a.push(limit.to_string());
    }
    a
}

/// Runs until the scheduler's report is in and every child has exited (or a child fails, or
/// Ctrl-C). Returns what was gathered, the fault log and whether it was interrupted.
#[allow(clippy::too_many_arguments)]
fn supervise(
    bus: &mut Bus,
    procs: &mut [Proc],
    me: &handshake::Process,
    case: &Case,
    observers: &[ObserverId],
    injected: &[Injected],
    topics: &BTreeMap<String, Topic>,
    stop: &AtomicBool,
    quiet: bool,
) -> Result<(Gathered, Vec<String>, bool)> {
    let mut everyone = handshake::mission_processes(case.observers, true);
    if procs.iter().any(|p| p.name == "recorder") {
        everyone.push(handshake::Process::singleton(Role::Recorder));
    }
    let startup_deadline = Instant::now() + Duration::from_secs(180);
    // Start-up: wait for every process, checking the children meanwhile.
    loop {
        if stop.load(Ordering::SeqCst) {
            return Ok((Gathered::default(), Vec::new(), true));
        }
        for p in procs.iter_mut() {
            p.poll()?;
            if !p.running() {
                bail!(
                    "{} exited during start-up ({})",
                    p.name,
                    p.exit.as_deref().unwrap_or("?")
                );
            }
        }
        match handshake::await_everyone(bus, &everyone, Duration::from_millis(200)) {
            Ok(()) => break,
            Err(BusError::Timeout { what, .. }) if Instant::now() >= startup_deadline => {
                bail!("start-up timed out: {what}")
            }
            Err(BusError::Timeout { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let keys = bus.keys().clone();
    let mut fault_log = Vec::new();
    for f in injected {
        if let Injected::Message(fault) = f {
            bus.put(&keys.fault(&fault.observer), fault)?;
            fault_log.push(format!(
                "{:?} on {} from {:.2} s (fault/{} published before the clock started)",
                fault.kind,
                fault.observer,
                ns_s(fault.from_ns),
                fault.observer
            ));
        }
    }
    handshake::declare_ready(bus, me)?;

    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new_spinner();
        b.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        b
    };
    let homes_m: BTreeMap<String, [f64; 3]> = (0..case.observers)
        .map(|i| (observer_name(i), observer_home_m(i, case.observers)))
        .collect();
    let mut g = Gathered {
        session: crate::report::record::SessionRecorder::new(homes_m.clone()),
        homes_m,
        ..Gathered::default()
    };
    let mut kills: Vec<(ObserverId, u64, bool)> = injected
        .iter()
        .filter_map(|f| match f {
            Injected::KillCamera { observer, at_ns } => Some((observer.clone(), *at_ns, false)),
            _ => None,
        })
        .collect();
    let mut report_at: Option<Instant> = None;
    let mut last_draw = Instant::now();
    let mut interrupted = false;
    loop {
        if stop.load(Ordering::SeqCst) {
            interrupted = true;
            for p in procs.iter_mut() {
                p.kill();
            }
            fault_log.push(format!(
                "interrupted (Ctrl-C) at sim {:.2} s: every child stopped",
                ns_s(g.tick * proto::TICK_NS)
            ));
            break;
        }
        // Drain what arrived.
        let mut budget = 256;
        while let Some(item) = bus.recv(Duration::from_millis(if budget == 256 { 20 } else { 0 })) {
            if let Inbound::Data { key, payload } = item
                && let Some(topic) = topics.get(&key)
            {
                g.take(topic, &key, &payload)?;
            }
            budget -= 1;
            if budget == 0 {
                break;
            }
        }
        let now_ns = g.tick * proto::TICK_NS;
        for (observer, at_ns, done) in &mut kills {
            if !*done && g.clock_started.is_some() && now_ns >= *at_ns {
                let name = format!("camera-{observer}");
                if let Some(p) = procs.iter_mut().find(|p| p.name == name) {
                    p.killed_by_fault = true;
                    p.kill();
                    fault_log.push(format!(
                        "SIGKILL {name} at sim {:.2} s (asked {:.2} s)",
                        ns_s(now_ns),
                        ns_s(*at_ns)
                    ));
                }
                *done = true;
            }
        }
        for p in procs.iter_mut() {
            p.poll()?;
            if !p.running() && !p.success && !p.killed_by_fault && g.report.is_none() {
                bar.finish_and_clear();
                bail!(
                    "{} failed ({}) at sim {:.2} s",
                    p.name,
                    p.exit.as_deref().unwrap_or("?"),
                    ns_s(now_ns)
                );
            }
        }
        if g.report.is_some() {
            let at = *report_at.get_or_insert_with(Instant::now);
            if procs.iter().all(|p| !p.running()) {
                break;
            }
            if at.elapsed() > Duration::from_secs(20) {
                for p in procs.iter_mut().filter(|p| p.running()) {
                    fault_log.push(format!("{} did not exit after the mission: killed", p.name));
                    p.kill();
                }
            }
        } else if procs.iter().all(|p| !p.running()) {
            bar.finish_and_clear();
            bail!("every process exited without a mission report");
        }
        if last_draw.elapsed() > Duration::from_millis(100) {
            bar.set_message(g.message(observers));
            bar.tick();
            last_draw = Instant::now();
        }
    }
    // Messages published just before the publishers exited may still be queued.
    let drain_until = Instant::now() + Duration::from_secs(2);
    while Instant::now() < drain_until
        && let Some(item) = bus.recv(Duration::from_millis(200))
    {
        if let Inbound::Data { key, payload } = item
            && let Some(topic) = topics.get(&key)
        {
            g.take(topic, &key, &payload)?;
        }
    }
    bar.finish_and_clear();
    Ok((g, fault_log, interrupted))
}

#[allow(clippy::too_many_arguments)]
fn summarise(
    case: &Case,
    modality: Modality,
    session: &str,
    mut g: Gathered,
    procs: &[Proc],
    fault_log: Vec<String>,
    interrupted: bool,
    started: Instant,
) -> Result<(
    RunSummary,
    BTreeMap<String, ObserverRecord>,
    crate::report::record::SessionRecord,
)> {
    let n = case.observers;
    let report = g.report.clone();
    let departures: BTreeMap<(ObserverId, u32), u64> = report
        .iter()
        .flat_map(|r| r.departures.iter())
        .map(|d| ((d.observer.clone(), d.round), d.t_ns))
        .collect();
    let mut records = BTreeMap::new();
    let mut observer_summaries = BTreeMap::new();
    let mut violations = Vec::new();
    for i in 0..n {
        let id = ObserverId::from_index(i);
        let mut rec = g.records.remove(&id).unwrap_or_default();
        rec.tokens.sort_by_key(|t| t.seq);
        rec.frames.sort_by_key(|f| f.seq);
        rec.track.sort_by_key(|t| t.stamp_ns);
        rec.track.dedup_by_key(|t| t.stamp_ns);
        let frames: Vec<_> = rec.frames.iter().map(|f| f.frame.clone()).collect();
        let services = report
            .as_ref()
            .and_then(|r| r.services.get(&id).cloned())
            .unwrap_or_default();
        observer_summaries.insert(
            id.to_string(),
            ObserverSummary::from_record(&frames, &rec.decisions, &services, rec.tokens.len()),
        );
        violations.extend(audit(&rec.decisions, &departures));
        records.insert(id.to_string(), rec);
    }
    let contacts = g.contacts.clone();
    let mut mission = MissionSummary {
        case: case.name.clone(),
        modality: modality.as_str().to_string(),
        observers: observer_summaries,
        work_units: report.as_ref().map_or(0, |r| r.work_units),
        mission_time_s: report
            .as_ref()
            .map_or(ns_s(g.tick * proto::TICK_NS), |r| ns_s(r.end_ns)),
        end_reason: report
            .as_ref()
            .map_or("none (no mission report)".to_string(), |r| {
                r.end_reason.clone()
            }),
        contact_steps: contacts.as_ref().map_or(0, |c| c.contact_steps),
        min_separation_m: contacts.as_ref().map_or(f64::NAN, |c| c.min_separation_m),
        provenance_violations: violations,
        pass: false,
        reasons: Vec::new(),
        wall_seconds: started.elapsed().as_secs_f64(),
    };
    mission.reasons = check_expected(case, &mission);
    if report.is_none() {
        mission
            .reasons
            .push("no mission report from the scheduler".into());
    }
    let mut home_error_m = BTreeMap::new();
    if let Some(state) = &g.state {
        for i in 0..n {
            let name = observer_name(i);
            if let Some(d) = state.drone(&name) {
                let e = distance_m(d.pos_m, observer_home_m(i, n));
                if e > 0.05 {
                    mission
                        .reasons
                        .push(format!("{name} ends {e:.3} m from its home"));
                }
                home_error_m.insert(name, e);
            }
        }
    }
    let mut processes = BTreeMap::new();
    let mut sensor_digests = BTreeMap::new();
    for p in procs {
        if !p.success && !p.killed_by_fault && !interrupted {
            mission.reasons.push(format!(
                "{} ended with {}",
                p.name,
                p.exit.as_deref().unwrap_or("?")
            ));
        }
        processes.insert(
            p.name.clone(),
            ProcessFigures {
                cpu_s: p.cpu_s,
                exit: p.exit.clone().unwrap_or_else(|| "running".into()),
                killed_by_fault: p.killed_by_fault,
            },
        );
        let out = std::fs::read_to_string(&p.stdout_path).unwrap_or_default();
        for line in out.lines() {
            if let Some(rest) = line.strip_prefix("sensor-digest ") {
                let mut parts = rest.split_whitespace();
                if let Some(o) = parts.next() {
                    sensor_digests.insert(o.to_string(), parts.collect::<Vec<_>>().join(" "));
                }
            }
        }
    }
    mission.pass = mission.reasons.is_empty() && !interrupted;
    let sim_s = ns_s(g.tick * proto::TICK_NS);
    let wall_over_sim = match (g.clock_started, g.last_tick_at) {
        (Some(a), Some(b)) if sim_s > 0.0 => (b - a).as_secs_f64() / sim_s,
        _ => f64::NAN,
    };
    let startup_s = g
        .clock_started
        .map_or(f64::NAN, |c| (c - started).as_secs_f64());
    let end_ns = g.tick * proto::TICK_NS;
    let session_record = std::mem::take(&mut g.session).finish(end_ns);
    Ok((
        RunSummary {
            mission,
            session: session.to_string(),
            wall_over_sim,
            startup_s,
            missing_packets: g.missing.iter().map(|(o, m)| (o.to_string(), *m)).collect(),
            home_error_m,
            max_excursion_m: g.excursion_m.clone(),
            sensor_digests,
            processes,
            faults: fault_log,
            interrupted,
        },
        records,
        session_record,
    ))
}
