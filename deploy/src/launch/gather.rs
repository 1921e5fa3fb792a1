//! What the launcher gathers from the bus during a run: the clock, ground truth for the home
//! check and the session record, the scheduler's report and every observer's output. Keys are
//! classified by the one key grammar ([`proto::Keys::parse`]).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use bus::Rejects;
use proto::scene::distance_m;
use proto::{
    Broadcast, BroadcastTick, CameraReport, ClockTick, Decision, Fault, FrameEvent, Key, Keys,
    MissionReport, ObserverId, ObserverStatus, ObserverTrack, PerformerTruth, RejectReason,
    RejectReport, Role, SessionEvent, SessionTick, SimContacts, SimState, TokenEvent,
};

use crate::run_dir::session::SessionRecorder;
use crate::run_dir::track_spool::SpooledRecord;
use run_eval::summary::ns_s;

/// The keys the launcher subscribes to for `observers`.
pub fn subscriptions(observers: &[ObserverId]) -> Vec<Key> {
    let mut keys = vec![
        Key::Clock,
        Key::SimState,
        Key::SimContacts,
        Key::SchedSession,
        Key::SchedReport,
        Key::SchedBroadcast,
        Key::TruthPerformer,
    ];
    for o in observers {
        keys.extend([
            Key::Fault(o.clone()),
            Key::ObserverTrack(o.clone()),
            Key::ObserverStatus(o.clone()),
            Key::ObserverTokens(o.clone()),
            Key::ObserverFrames(o.clone()),
            Key::ObserverDecision(o.clone()),
            Key::CameraReport(o.clone()),
        ]);
    }
    keys
}

/// What the launcher gathered from the bus.
#[derive(Default)]
pub struct Gathered {
    pub tick: u64,
    pub clock_started: Option<Instant>,
    pub last_tick_at: Option<Instant>,
    /// Each observer's output; track samples wait on disk in `spool_dir` (track_spool).
    pub records: BTreeMap<ObserverId, SpooledRecord>,
    pub spool_dir: PathBuf,
    pub missing: BTreeMap<ObserverId, u64>,
    pub phase: String,
    pub report: Option<MissionReport>,
    /// What the scheduler told the performer to fly, round by round (false releases).
    pub broadcasts: Vec<Broadcast>,
    pub contacts: Option<SimContacts>,
    pub state: Option<SimState>,
    /// Observers' homes, and the farthest each got from it (every `sim/state` sample).
    pub homes_m: BTreeMap<String, [f64; 3]>,
    pub excursion_m: BTreeMap<String, f64>,
    /// Performer spans, controls, trips and stays for `session.json`.
    pub session: SessionRecorder,
    /// What the launcher itself dropped (created with the first sample).
    pub rejects: Option<Rejects>,
    /// The reject report of each process that sent one.
    pub reports: BTreeMap<String, RejectReport>,
    /// Every fault message that reached the bus.
    pub faults_seen: Vec<SeenFault>,
    /// Each camera's closing report (a camera killed by a fault sends none).
    pub cameras: BTreeMap<ObserverId, CameraReport>,
}

/// A fault message seen on the bus.
#[derive(Debug, Clone, PartialEq)]
pub struct SeenFault {
    /// Its key after `waggle/<session>/`.
    pub key: String,
    pub fault: Fault,
    /// The clock tick when it arrived (`None`: before the clock started).
    pub at_tick: Option<u64>,
}

impl Gathered {
    /// Starts gathering for observers whose homes are `homes_m`, spooling their tracks into
    /// `spool_dir` (the run directory: unnamed files, gone when the launcher ends).
    pub fn new(homes_m: BTreeMap<String, [f64; 3]>, spool_dir: PathBuf) -> Self {
        Self {
            session: SessionRecorder::new(homes_m.clone()),
            spool_dir,
            homes_m,
            ..Self::default()
        }
    }

    /// Sim time of the latest clock tick, ns.
    pub fn now_ns(&self) -> u64 {
        self.tick * proto::TICK_NS
    }

    /// Takes one sample published on `key` of the session `keys`. Keys outside the session's
    /// grammar, undecodable bytes and messages that break the protocol (a clock out of
    /// sequence, a body naming another observer than its key, a second report) are counted in
    /// the launcher's own [`Rejects`] and dropped: nothing on the bus can abort the launcher.
    pub fn take(&mut self, keys: &Keys, key: &str, payload: &[u8]) {
        let mut rejects = self
            .rejects
            .take()
            .unwrap_or_else(|| Rejects::new(Role::Launcher.as_str(), keys));
        match keys.parse(key) {
            None => rejects.reject(key, RejectReason::UnexpectedKey, &"outside the key grammar"),
            Some(parsed) if parsed.observer().is_some() => {
                self.observer_output(keys, &parsed, key, payload, &mut rejects);
            }
            Some(parsed) => self.session_message(parsed, key, payload, &mut rejects),
        }
        self.rejects = Some(rejects);
    }

    /// A message on a key of no observer: the clock, ground truth, the scheduler's, reports.
    fn session_message(&mut self, parsed: Key, key: &str, payload: &[u8], rejects: &mut Rejects) {
        match parsed {
            Key::Clock => {
                let Some(c) = rejects.decode::<ClockTick>(key, payload) else {
                    return;
                };
                let due = self.clock_started.map_or(0, |_| self.tick + 1);
                if c.tick != due {
                    let why = format!("clock tick {} while tick {due} is due", c.tick);
                    rejects.reject(key, RejectReason::OutOfContract, &why);
                    return;
                }
                self.clock(c);
            }
            Key::SimState => {
                let Some(st) = rejects.decode::<SimState>(key, payload) else {
                    return;
                };
                if self
                    .state
                    .as_ref()
                    .is_some_and(|p| st.stamp_ns <= p.stamp_ns)
                {
                    let why = format!("state at {} ns is not after the last", st.stamp_ns);
                    rejects.reject(key, RejectReason::OutOfContract, &why);
                    return;
                }
                self.state(st);
            }
            Key::SimContacts => {
                let Some(c) = rejects.decode::<SimContacts>(key, payload) else {
                    return;
                };
                if self.contacts.as_ref().is_some_and(|p| c.tick <= p.tick) {
                    let why = format!("contacts of tick {} are not after the last", c.tick);
                    rejects.reject(key, RejectReason::OutOfContract, &why);
                    return;
                }
                self.contacts = Some(c);
            }
            Key::SchedReport => {
                let Some(r) = rejects.decode::<MissionReport>(key, payload) else {
                    return;
                };
                if self.report.is_some() {
                    rejects.reject(key, RejectReason::OutOfContract, &"a second mission report");
                    return;
                }
                self.session.report(&r);
                self.report = Some(r);
            }
            Key::SchedBroadcast => {
                if let Some(b) = rejects.decode::<BroadcastTick>(key, payload) {
                    self.broadcasts.extend(b.broadcast);
                }
            }
            Key::TruthPerformer => {
                if let Some(t) = rejects.decode::<PerformerTruth>(key, payload) {
                    self.session.truth(&t);
                }
            }
            Key::SchedSession => {
                if let Some(t) = rejects.decode::<SessionTick>(key, payload) {
                    self.session_tick(t);
                }
            }
            Key::Rejects(role, id) => {
                let Some(r) = rejects.decode::<RejectReport>(key, payload) else {
                    return;
                };
                if r.process != bus::Process::new(role, id).name() {
                    rejects.reject(
                        key,
                        RejectReason::OutOfContract,
                        &"report of another process",
                    );
                    return;
                }
                self.reports.insert(r.process.clone(), r);
            }
            _ => rejects.reject(
                key,
                RejectReason::UnexpectedKey,
                &"not followed by the launcher",
            ),
        }
    }

    /// A message on an observer's key: its outputs, or a fault for its camera. The body must
    /// name the observer of its key.
    fn observer_output(
        &mut self,
        keys: &Keys,
        parsed: &Key,
        key: &str,
        payload: &[u8],
        rejects: &mut Rejects,
    ) {
        let owner = parsed.observer().cloned();
        let mismatch = |body: &ObserverId, rejects: &mut Rejects| {
            let wrong = owner.as_ref().is_some_and(|o| o != body);
            if wrong {
                rejects.reject(
                    key,
                    RejectReason::OutOfContract,
                    &format_args!("body names {body}"),
                );
            }
            wrong
        };
        match parsed {
            Key::ObserverTrack(_) => {
                if let Some(t) = rejects.decode::<ObserverTrack>(key, payload)
                    && !mismatch(&t.observer, rejects)
                {
                    self.record(&t.observer).extend_track(t.samples);
                }
            }
            Key::ObserverStatus(_) => {
                if let Some(st) = rejects.decode::<ObserverStatus>(key, payload)
                    && !mismatch(&st.observer, rejects)
                    && st.input == proto::InputState::Missing
                {
                    *self.missing.entry(st.observer).or_default() += 1;
                }
            }
            Key::ObserverTokens(_) => {
                if let Some(t) = rejects.decode::<TokenEvent>(key, payload)
                    && !mismatch(&t.observer, rejects)
                {
                    self.record(&t.observer.clone()).tokens.push(t);
                }
            }
            Key::ObserverFrames(_) => {
                if let Some(f) = rejects.decode::<FrameEvent>(key, payload)
                    && !mismatch(&f.observer, rejects)
                {
                    self.record(&f.observer.clone()).frames.push(f);
                }
            }
            Key::ObserverDecision(_) => {
                if let Some(d) = rejects.decode::<Decision>(key, payload)
                    && !mismatch(&d.observer, rejects)
                {
                    self.record(&d.observer.clone()).decisions.push(d);
                }
            }
            Key::CameraReport(_) => {
                let Some(r) = rejects.decode::<CameraReport>(key, payload) else {
                    return;
                };
                if mismatch(&r.observer, rejects) {
                    return;
                }
                if self.cameras.contains_key(&r.observer) {
                    rejects.reject(key, RejectReason::OutOfContract, &"a second camera report");
                    return;
                }
                self.cameras.insert(r.observer.clone(), r);
            }
            Key::Fault(_) => {
                let Some(f) = rejects.decode::<Fault>(key, payload) else {
                    return;
                };
                mismatch(&f.observer, rejects);
                // Every fault that reached the bus is listed, obeyed or not.
                self.faults_seen.push(SeenFault {
                    key: key
                        .strip_prefix(keys.prefix())
                        .unwrap_or(key)
                        .trim_start_matches('/')
                        .to_string(),
                    fault: f,
                    at_tick: self.clock_started.map(|_| self.tick),
                });
            }
            _ => rejects.reject(
                key,
                RejectReason::UnexpectedKey,
                &"not followed by the launcher",
            ),
        }
    }

    /// Every process's reject report, the launcher's own included.
    pub fn reject_reports(&self) -> BTreeMap<String, RejectReport> {
        let mut out = self.reports.clone();
        if let Some(mine) = &self.rejects {
            out.insert(Role::Launcher.as_str().to_string(), mine.report());
        }
        out
    }

    fn record(&mut self, o: &ObserverId) -> &mut SpooledRecord {
        let dir = &self.spool_dir;
        self.records
            .entry(o.clone())
            .or_insert_with(|| SpooledRecord::new_in(dir))
    }

    fn clock(&mut self, c: ClockTick) {
        self.tick = c.tick;
        let now = Instant::now();
        self.clock_started.get_or_insert(now);
        self.last_tick_at = Some(now);
    }

    fn state(&mut self, s: SimState) {
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

    fn session_tick(&mut self, s: SessionTick) {
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

    /// The progress line.
    pub fn message(&self, observers: &[ObserverId]) -> String {
        let sim_s = ns_s(self.now_ns());
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
