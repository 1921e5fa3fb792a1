//! What the launcher gathers from the bus during a run: the clock, ground truth for the home
//! check and the session record, the scheduler's report and every observer's output. Keys are
//! classified by the one key grammar ([`proto::Keys::parse`]).

use std::collections::BTreeMap;
use std::time::Instant;

use bus::BusError;
use proto::scene::distance_m;
use proto::{
    ClockTick, Decision, FrameEvent, Key, Keys, MissionReport, ObserverId, ObserverStatus,
    ObserverTrack, PerformerTruth, SessionEvent, SessionTick, SimContacts, SimState, TokenEvent,
};

use crate::eval::summary::ns_s;
use crate::run_dir::ObserverRecord;
use crate::run_dir::session::SessionRecorder;

/// The keys the launcher subscribes to for `observers`.
pub fn subscriptions(observers: &[ObserverId]) -> Vec<Key> {
    let mut keys = vec![
        Key::Clock,
        Key::SimState,
        Key::SimContacts,
        Key::SchedSession,
        Key::SchedReport,
        Key::TruthPerformer,
    ];
    for o in observers {
        keys.extend([
            Key::ObserverTrack(o.clone()),
            Key::ObserverStatus(o.clone()),
            Key::ObserverTokens(o.clone()),
            Key::ObserverFrames(o.clone()),
            Key::ObserverDecision(o.clone()),
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
    pub records: BTreeMap<ObserverId, ObserverRecord>,
    pub missing: BTreeMap<ObserverId, u64>,
    pub phase: String,
    pub report: Option<MissionReport>,
    pub contacts: Option<SimContacts>,
    pub state: Option<SimState>,
    /// Observers' homes, and the farthest each got from it (every `sim/state` sample).
    pub homes_m: BTreeMap<String, [f64; 3]>,
    pub excursion_m: BTreeMap<String, f64>,
    /// Performer spans, controls, trips and stays for `session.json`.
    pub session: SessionRecorder,
}

impl Gathered {
    /// Starts gathering for observers whose homes are `homes_m`.
    pub fn new(homes_m: BTreeMap<String, [f64; 3]>) -> Self {
        Self {
            session: SessionRecorder::new(homes_m.clone()),
            homes_m,
            ..Self::default()
        }
    }

    /// Sim time of the latest clock tick, ns.
    pub fn now_ns(&self) -> u64 {
        self.tick * proto::TICK_NS
    }

    /// Takes one sample published on `key` of the session `keys`; keys outside the session's
    /// grammar and keys the launcher does not follow are ignored.
    pub fn take(&mut self, keys: &Keys, key: &str, payload: &[u8]) -> Result<(), BusError> {
        let Some(parsed) = keys.parse(key) else {
            return Ok(());
        };
        match parsed {
            Key::Clock => self.clock(bus::decode(key, payload)?),
            Key::SimState => self.state(bus::decode(key, payload)?),
            Key::SimContacts => self.contacts = Some(bus::decode(key, payload)?),
            Key::SchedReport => {
                let r: MissionReport = bus::decode(key, payload)?;
                self.session.report(&r);
                self.report = Some(r);
            }
            Key::TruthPerformer => {
                let t: PerformerTruth = bus::decode(key, payload)?;
                self.session.truth(&t);
            }
            Key::SchedSession => self.session_tick(bus::decode(key, payload)?),
            Key::ObserverTrack(_) => {
                let t: ObserverTrack = bus::decode(key, payload)?;
                self.record(&t.observer).track.extend(t.samples);
            }
            Key::ObserverStatus(_) => {
                let s: ObserverStatus = bus::decode(key, payload)?;
                if s.input == proto::InputState::Missing {
                    *self.missing.entry(s.observer).or_default() += 1;
                }
            }
            Key::ObserverTokens(_) => {
                let t: TokenEvent = bus::decode(key, payload)?;
                self.record(&t.observer.clone()).tokens.push(t);
            }
            Key::ObserverFrames(_) => {
                let f: FrameEvent = bus::decode(key, payload)?;
                self.record(&f.observer.clone()).frames.push(f);
            }
            Key::ObserverDecision(_) => {
                let d: Decision = bus::decode(key, payload)?;
                self.record(&d.observer.clone()).decisions.push(d);
            }
            _ => {}
        }
        Ok(())
    }

    fn record(&mut self, o: &ObserverId) -> &mut ObserverRecord {
        self.records.entry(o.clone()).or_default()
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
