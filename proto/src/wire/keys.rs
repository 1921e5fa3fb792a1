//! Key expressions under `waggle/<session>/…` and the validated ids that go into them.
//!
//! Every key a process publishes or subscribes to is built here, so a typo cannot create a
//! topic nobody listens to, and ids are checked once: a session or observer id is a single
//! non-empty key chunk without `/` (chunk separator) or Zenoh's reserved `*`, `$`, `?`, `#`.

use serde::{Deserialize, Serialize};

use crate::scene::observer_name;

/// Why an id cannot be used inside a key expression.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum KeyError {
    #[error("{what} id is empty")]
    Empty { what: &'static str },
    #[error("{what} id {value:?} contains the reserved character {ch:?}")]
    Reserved {
        what: &'static str,
        value: String,
        ch: char,
    },
    #[error("{what} id {value:?} contains whitespace or a control character")]
    Whitespace { what: &'static str, value: String },
}

const RESERVED: [char; 5] = ['/', '*', '$', '?', '#'];

/// Checks that `value` can be used as one key-expression chunk.
pub fn validate_chunk(what: &'static str, value: &str) -> Result<(), KeyError> {
    if value.is_empty() {
        return Err(KeyError::Empty { what });
    }
    if let Some(ch) = value.chars().find(|c| RESERVED.contains(c)) {
        return Err(KeyError::Reserved {
            what,
            value: value.to_owned(),
            ch,
        });
    }
    if value.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(KeyError::Whitespace {
            what,
            value: value.to_owned(),
        });
    }
    Ok(())
}

/// A validated observer id such as `O1`. Deserialising an invalid id fails.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct ObserverId(String);

impl ObserverId {
    pub fn new(id: impl Into<String>) -> Result<Self, KeyError> {
        let id = id.into();
        validate_chunk("observer", &id)?;
        Ok(Self(id))
    }

    /// The canonical id of 0-based observer `i` (`O1`, `O2`, …).
    pub fn from_index(i: usize) -> Self {
        Self(observer_name(i))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl TryFrom<String> for ObserverId {
    type Error = KeyError;
    fn try_from(s: String) -> Result<Self, KeyError> {
        Self::new(s)
    }
}

impl From<ObserverId> for String {
    fn from(id: ObserverId) -> String {
        id.0
    }
}

impl std::str::FromStr for ObserverId {
    type Err = KeyError;
    fn from_str(s: &str) -> Result<Self, KeyError> {
        Self::new(s)
    }
}

impl std::fmt::Display for ObserverId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// The role part of a liveliness token.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Role {
    Sim,
    Camera,
    Observer,
    Performer,
    Scheduler,
    Recorder,
    Launcher,
}

impl Role {
    pub const ALL: [Role; 7] = [
        Role::Sim,
        Role::Camera,
        Role::Observer,
        Role::Performer,
        Role::Scheduler,
        Role::Recorder,
        Role::Launcher,
    ];

    /// The role named `s` in a key (`sim`, `camera`, …).
    pub fn parse(s: &str) -> Option<Role> {
        Role::ALL.into_iter().find(|r| r.as_str() == s)
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Role::Sim => "sim",
            Role::Camera => "camera",
            Role::Observer => "observer",
            Role::Performer => "performer",
            Role::Scheduler => "scheduler",
            Role::Recorder => "recorder",
            Role::Launcher => "launcher",
        }
    }
}

/// One key of a session, parsed: together with [`Key::rest`] the one grammar of
/// `waggle/<session>/<rest>` (every builder of [`Keys`] and every parser of a key goes through
/// it, so the two cannot disagree).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Key {
    Clock,
    SimState,
    SimContacts,
    SensorEvents(ObserverId),
    SensorRgb(ObserverId),
    /// A camera's notices of packets it dropped (`sensor/<o>/dropped`).
    SensorDropped(ObserverId),
    /// What an event camera's sensor was fed (`camera/<o>/input`): its renders as RGB updates,
    /// published only for a recording that regenerates the events from them.
    CameraInput(ObserverId),
    ObserverTokens(ObserverId),
    ObserverFrames(ObserverId),
    ObserverDecision(ObserverId),
    ObserverStatus(ObserverId),
    ObserverTrack(ObserverId),
    PerformerSetpoint,
    TruthPerformer,
    SchedCmd,
    SchedBroadcast,
    SchedSession,
    SchedReport,
    Fault(ObserverId),
    /// One camera's account of its run (`camera/<o>/report`), published as it ends.
    CameraReport(ObserverId),
    /// Liveliness token of one process (`alive/<role>/<id>`).
    Alive(Role, String),
    /// Readiness token of one process (`ready/<role>/<id>`).
    Ready(Role, String),
    /// What one process dropped (`rejects/<role>/<id>`), published as it ends.
    Rejects(Role, String),
}

impl Key {
    /// Parses the part of a key after `waggle/<session>/`; `None` for anything that is not
    /// exactly one key of the grammar (wildcards, unknown paths, invalid ids).
    pub fn parse_rest(rest: &str) -> Option<Key> {
        let parts: Vec<&str> = rest.split('/').collect();
        let obs = |o: &str| ObserverId::new(o).ok();
        let process = |role: &str, id: &str| {
            let role = Role::parse(role)?;
            validate_chunk("process", id).ok()?;
            Some((role, id.to_owned()))
        };
        Some(match parts.as_slice() {
            ["clock"] => Key::Clock,
            ["sim", "state"] => Key::SimState,
            ["sim", "contacts"] => Key::SimContacts,
            ["sensor", o, "events"] => Key::SensorEvents(obs(o)?),
            ["sensor", o, "rgb"] => Key::SensorRgb(obs(o)?),
            ["sensor", o, "dropped"] => Key::SensorDropped(obs(o)?),
            ["camera", o, "input"] => Key::CameraInput(obs(o)?),
            ["observer", o, "tokens"] => Key::ObserverTokens(obs(o)?),
            ["observer", o, "frames"] => Key::ObserverFrames(obs(o)?),
            ["observer", o, "decision"] => Key::ObserverDecision(obs(o)?),
            ["observer", o, "status"] => Key::ObserverStatus(obs(o)?),
            ["observer", o, "track"] => Key::ObserverTrack(obs(o)?),
            ["performer", "setpoint"] => Key::PerformerSetpoint,
            ["truth", "performer"] => Key::TruthPerformer,
            ["sched", "cmd"] => Key::SchedCmd,
            ["sched", "broadcast"] => Key::SchedBroadcast,
            ["sched", "session"] => Key::SchedSession,
            ["sched", "report"] => Key::SchedReport,
            ["fault", o] => Key::Fault(obs(o)?),
            ["camera", o, "report"] => Key::CameraReport(obs(o)?),
            ["alive", role, id] => {
                let (role, id) = process(role, id)?;
                Key::Alive(role, id)
            }
            ["ready", role, id] => {
                let (role, id) = process(role, id)?;
                Key::Ready(role, id)
            }
            ["rejects", role, id] => {
                let (role, id) = process(role, id)?;
                Key::Rejects(role, id)
            }
            _ => return None,
        })
    }

    /// The part of the key after `waggle/<session>/`.
    pub fn rest(&self) -> String {
        match self {
            Key::Clock => "clock".into(),
            Key::SimState => "sim/state".into(),
            Key::SimContacts => "sim/contacts".into(),
            Key::SensorEvents(o) => format!("sensor/{o}/events"),
            Key::SensorRgb(o) => format!("sensor/{o}/rgb"),
            Key::SensorDropped(o) => format!("sensor/{o}/dropped"),
            Key::CameraInput(o) => format!("camera/{o}/input"),
            Key::ObserverTokens(o) => format!("observer/{o}/tokens"),
            Key::ObserverFrames(o) => format!("observer/{o}/frames"),
            Key::ObserverDecision(o) => format!("observer/{o}/decision"),
            Key::ObserverStatus(o) => format!("observer/{o}/status"),
            Key::ObserverTrack(o) => format!("observer/{o}/track"),
            Key::PerformerSetpoint => "performer/setpoint".into(),
            Key::TruthPerformer => "truth/performer".into(),
            Key::SchedCmd => "sched/cmd".into(),
            Key::SchedBroadcast => "sched/broadcast".into(),
            Key::SchedSession => "sched/session".into(),
            Key::SchedReport => "sched/report".into(),
            Key::Fault(o) => format!("fault/{o}"),
            Key::CameraReport(o) => format!("camera/{o}/report"),
            Key::Alive(role, id) => format!("alive/{}/{id}", role.as_str()),
            Key::Ready(role, id) => format!("ready/{}/{id}", role.as_str()),
            Key::Rejects(role, id) => format!("rejects/{}/{id}", role.as_str()),
        }
    }

    /// The observer a key belongs to (`sensor/<o>/…`, `observer/<o>/…`, `fault/<o>`).
    pub fn observer(&self) -> Option<&ObserverId> {
        match self {
            Key::SensorEvents(o)
            | Key::SensorRgb(o)
            | Key::SensorDropped(o)
            | Key::CameraInput(o)
            | Key::ObserverTokens(o)
            | Key::ObserverFrames(o)
            | Key::ObserverDecision(o)
            | Key::ObserverStatus(o)
            | Key::ObserverTrack(o)
            | Key::Fault(o)
            | Key::CameraReport(o) => Some(o),
            _ => None,
        }
    }
}

/// Key-expression builder for one session (`waggle/<session>/…`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    prefix: String,
}

impl Keys {
    pub fn new(session: &str) -> Result<Self, KeyError> {
        validate_chunk("session", session)?;
        Ok(Self {
            prefix: format!("waggle/{session}"),
        })
    }

    /// `waggle/<session>`.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    fn key(&self, rest: &str) -> String {
        format!("{}/{rest}", self.prefix)
    }

    /// The full key expression of `key` in this session.
    pub fn of(&self, key: &Key) -> String {
        self.key(&key.rest())
    }

    /// Parses a full key of this session (`waggle/<session>/<rest>`); `None` for another
    /// session's key, a wildcard or anything outside the grammar.
    pub fn parse(&self, key: &str) -> Option<Key> {
        Key::parse_rest(key.strip_prefix(&self.prefix)?.strip_prefix('/')?)
    }

    /// Everything of the session (the recorder's subscription).
    pub fn all(&self) -> String {
        self.key("**")
    }

    pub fn clock(&self) -> String {
        self.of(&Key::Clock)
    }

    pub fn sim_state(&self) -> String {
        self.of(&Key::SimState)
    }

    pub fn sim_contacts(&self) -> String {
        self.of(&Key::SimContacts)
    }

    pub fn sensor_events(&self, o: &ObserverId) -> String {
        self.of(&Key::SensorEvents(o.clone()))
    }

    pub fn sensor_rgb(&self, o: &ObserverId) -> String {
        self.of(&Key::SensorRgb(o.clone()))
    }

    pub fn sensor_dropped(&self, o: &ObserverId) -> String {
        self.of(&Key::SensorDropped(o.clone()))
    }

    pub fn camera_input(&self, o: &ObserverId) -> String {
        self.of(&Key::CameraInput(o.clone()))
    }

    /// Both sensor streams of one observer and its camera's drop notices (`sensor/<o>/*`).
    pub fn sensor_any(&self, o: &ObserverId) -> String {
        self.key(&format!("sensor/{o}/*"))
    }

    pub fn observer_tokens(&self, o: &ObserverId) -> String {
        self.of(&Key::ObserverTokens(o.clone()))
    }

    pub fn observer_frames(&self, o: &ObserverId) -> String {
        self.of(&Key::ObserverFrames(o.clone()))
    }

    pub fn observer_decision(&self, o: &ObserverId) -> String {
        self.of(&Key::ObserverDecision(o.clone()))
    }

    pub fn observer_status(&self, o: &ObserverId) -> String {
        self.of(&Key::ObserverStatus(o.clone()))
    }

    /// The observer's image-plane track, for the record (`observer/<o>/track`).
    pub fn observer_track(&self, o: &ObserverId) -> String {
        self.of(&Key::ObserverTrack(o.clone()))
    }

    /// Every observer's decisions (`observer/*/decision`).
    pub fn observer_decision_any(&self) -> String {
        self.key("observer/*/decision")
    }

    /// Every observer's status (`observer/*/status`).
    pub fn observer_status_any(&self) -> String {
        self.key("observer/*/status")
    }

    pub fn performer_setpoint(&self) -> String {
        self.of(&Key::PerformerSetpoint)
    }

    pub fn truth_performer(&self) -> String {
        self.of(&Key::TruthPerformer)
    }

    pub fn sched_cmd(&self) -> String {
        self.of(&Key::SchedCmd)
    }

    pub fn sched_broadcast(&self) -> String {
        self.of(&Key::SchedBroadcast)
    }

    pub fn sched_session(&self) -> String {
        self.of(&Key::SchedSession)
    }

    pub fn fault(&self, o: &ObserverId) -> String {
        self.of(&Key::Fault(o.clone()))
    }

    /// Every fault key (`fault/*`).
    pub fn fault_any(&self) -> String {
        self.key("fault/*")
    }

    /// Liveliness token of one process: `alive/<role>/<id>`.
    pub fn alive(&self, role: Role, id: &str) -> Result<String, KeyError> {
        validate_chunk("process", id)?;
        Ok(self.of(&Key::Alive(role, id.to_owned())))
    }

    /// Every liveliness token of one role (`alive/<role>/*`).
    pub fn alive_role(&self, role: Role) -> String {
        self.key(&format!("alive/{}/*", role.as_str()))
    }

    /// Every liveliness token of the session (`alive/**`).
    pub fn alive_any(&self) -> String {
        self.key("alive/**")
    }

    /// Readiness token of one process (`ready/<role>/<id>`): declared once the process has seen
    /// the liveliness token of every process of the session, i.e. once every peer it talks to
    /// knows its subscriptions and it knows theirs. The simulator starts the clock only when every
    /// process is ready, so no lockstep message is published before its subscriber exists.
    pub fn ready(&self, role: Role, id: &str) -> Result<String, KeyError> {
        validate_chunk("process", id)?;
        Ok(self.of(&Key::Ready(role, id.to_owned())))
    }

    /// One camera's report (`camera/<o>/report`).
    pub fn camera_report(&self, o: &ObserverId) -> String {
        self.of(&Key::CameraReport(o.clone()))
    }

    /// The reject report of one process (`rejects/<role>/<id>`).
    pub fn rejects(&self, role: Role, id: &str) -> Result<String, KeyError> {
        validate_chunk("process", id)?;
        Ok(self.of(&Key::Rejects(role, id.to_owned())))
    }

    /// Every reject report of the session (`rejects/**`).
    pub fn rejects_any(&self) -> String {
        self.key("rejects/**")
    }

    /// Every readiness token of the session (`ready/**`).
    pub fn ready_any(&self) -> String {
        self.key("ready/**")
    }

    /// Every ground-truth key of the simulator (`sim/**`).
    pub fn sim_all(&self) -> String {
        self.key("sim/**")
    }

    /// Every ground-truth label key (`truth/**`).
    pub fn truth_all(&self) -> String {
        self.key("truth/**")
    }

    /// Every key of the performer (`performer/**`).
    pub fn performer_all(&self) -> String {
        self.key("performer/**")
    }

    /// Every output key of one observer (`observer/<o>/**`).
    pub fn observer_all(&self, o: &ObserverId) -> String {
        self.key(&format!("observer/{o}/**"))
    }

    /// The scheduler's end-of-mission report (`sched/report`).
    pub fn sched_report(&self) -> String {
        self.of(&Key::SchedReport)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_follow_the_design_table() {
        let k = Keys::new("run-7").unwrap();
        let o2 = ObserverId::new("O2").unwrap();
        assert_eq!(k.all(), "waggle/run-7/**");
        assert_eq!(k.clock(), "waggle/run-7/clock");
        assert_eq!(k.sim_state(), "waggle/run-7/sim/state");
        assert_eq!(k.sim_contacts(), "waggle/run-7/sim/contacts");
        assert_eq!(k.sensor_events(&o2), "waggle/run-7/sensor/O2/events");
        assert_eq!(k.sensor_rgb(&o2), "waggle/run-7/sensor/O2/rgb");
        assert_eq!(k.sensor_any(&o2), "waggle/run-7/sensor/O2/*");
        assert_eq!(k.observer_tokens(&o2), "waggle/run-7/observer/O2/tokens");
        assert_eq!(k.observer_frames(&o2), "waggle/run-7/observer/O2/frames");
        assert_eq!(
            k.observer_decision(&o2),
            "waggle/run-7/observer/O2/decision"
        );
        assert_eq!(k.observer_status(&o2), "waggle/run-7/observer/O2/status");
        assert_eq!(k.observer_track(&o2), "waggle/run-7/observer/O2/track");
        assert_eq!(
            k.observer_decision_any(),
            "waggle/run-7/observer/*/decision"
        );
        assert_eq!(k.observer_status_any(), "waggle/run-7/observer/*/status");
        assert_eq!(k.performer_setpoint(), "waggle/run-7/performer/setpoint");
        assert_eq!(k.truth_performer(), "waggle/run-7/truth/performer");
        assert_eq!(k.sched_cmd(), "waggle/run-7/sched/cmd");
        assert_eq!(k.sched_broadcast(), "waggle/run-7/sched/broadcast");
        assert_eq!(k.sched_session(), "waggle/run-7/sched/session");
        assert_eq!(k.fault(&o2), "waggle/run-7/fault/O2");
        assert_eq!(k.fault_any(), "waggle/run-7/fault/*");
        assert_eq!(
            k.alive(Role::Observer, "O2").unwrap(),
            "waggle/run-7/alive/observer/O2"
        );
        assert_eq!(k.alive_role(Role::Camera), "waggle/run-7/alive/camera/*");
        assert_eq!(k.alive_any(), "waggle/run-7/alive/**");
        assert_eq!(
            k.ready(Role::Camera, "O2").unwrap(),
            "waggle/run-7/ready/camera/O2"
        );
        assert_eq!(k.ready_any(), "waggle/run-7/ready/**");
        assert_eq!(k.sched_report(), "waggle/run-7/sched/report");
        assert_eq!(k.sim_all(), "waggle/run-7/sim/**");
        assert_eq!(k.truth_all(), "waggle/run-7/truth/**");
        assert_eq!(k.performer_all(), "waggle/run-7/performer/**");
        assert_eq!(k.observer_all(&o2), "waggle/run-7/observer/O2/**");
    }

    #[test]
    fn every_key_parses_back_to_itself_and_nothing_else_parses() {
        let k = Keys::new("run-7").unwrap();
        let o2 = ObserverId::new("O2").unwrap();
        let all = [
            Key::Clock,
            Key::SimState,
            Key::SimContacts,
            Key::SensorEvents(o2.clone()),
            Key::SensorRgb(o2.clone()),
            Key::SensorDropped(o2.clone()),
            Key::CameraInput(o2.clone()),
            Key::ObserverTokens(o2.clone()),
            Key::ObserverFrames(o2.clone()),
            Key::ObserverDecision(o2.clone()),
            Key::ObserverStatus(o2.clone()),
            Key::ObserverTrack(o2.clone()),
            Key::PerformerSetpoint,
            Key::TruthPerformer,
            Key::SchedCmd,
            Key::SchedBroadcast,
            Key::SchedSession,
            Key::SchedReport,
            Key::Fault(o2.clone()),
            Key::Alive(Role::Camera, "O2".into()),
            Key::Ready(Role::Sim, "sim".into()),
            Key::Rejects(Role::Observer, "O2".into()),
        ];
        for key in &all {
            assert_eq!(k.parse(&k.of(key)).as_ref(), Some(key), "{key:?}");
        }
        assert_eq!(k.parse(&k.fault(&o2)), Some(Key::Fault(o2.clone())));
        assert_eq!(k.parse(&k.clock()), Some(Key::Clock));
        for bad in [
            "waggle/run-7",
            "waggle/run-7/",
            "waggle/run-8/clock",
            "waggle/run-7/clock/x",
            "waggle/run-7/sensor/O*/events",
            "waggle/run-7/sensor/O1/depth",
            "waggle/run-7/alive/wizard/x",
            "waggle/run-7/**",
            "other/run-7/clock",
        ] {
            assert_eq!(k.parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn ids_that_would_break_a_key_are_rejected() {
        assert_eq!(Keys::new(""), Err(KeyError::Empty { what: "session" }));
        for bad in ["a/b", "a*", "$x", "q?", "h#", "a b", "tab\t"] {
            assert!(Keys::new(bad).is_err(), "{bad:?}");
            assert!(ObserverId::new(bad).is_err(), "{bad:?}");
        }
        assert!(matches!(
            ObserverId::new("O/1"),
            Err(KeyError::Reserved { ch: '/', .. })
        ));
        let k = Keys::new("s").unwrap();
        assert!(k.alive(Role::Sim, "").is_err());
        assert!(k.alive(Role::Sim, "x/y").is_err());
        assert_eq!(ObserverId::from_index(2).as_str(), "O3");
    }

    #[test]
    fn an_invalid_observer_id_does_not_deserialise() {
        let bytes = crate::encode(&"O*".to_string());
        let body = &bytes[2..];
        assert!(bincode::deserialize::<ObserverId>(body).is_err());
        let ok = crate::encode(&"O1".to_string());
        assert_eq!(
            bincode::deserialize::<ObserverId>(&ok[2..])
                .unwrap()
                .as_str(),
            "O1"
        );
    }
}
