//! Which Waggle message lives on which key, and its sim time.
//!
//! Every key of a session (`waggle/<session>/<rest>`) maps to one message type; the recording
//! keeps each key's wire bytes on a channel named `/<rest>` whose schema is named after the
//! type (`waggle.EventPacket`, …) with schema encoding [`RAW_ENCODING`].

use proto::{
    BroadcastTick, CameraReport, ClockTick, Decision, DecodeError, EventPacket, Fault, FrameEvent,
    Key, MissionReport, ObserverId, ObserverStatus, ObserverTrack, PacketDropped,
    PerformerSetpoint, PerformerTruth, RejectReport, RgbFrame, RgbUpdate, SchedCommand,
    SessionTick, SimContacts, SimState, TICK_NS, TokenEvent,
};

/// Message (and schema) encoding of raw channels: the exact bytes of [`proto::encode`].
pub const RAW_ENCODING: &str = "waggle-proto";

/// The message type carried by a key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum MessageKind {
    Clock,
    SimState,
    SimContacts,
    EventPacket,
    RgbFrame,
    TokenEvent,
    FrameEvent,
    Decision,
    ObserverStatus,
    ObserverTrack,
    PerformerSetpoint,
    PerformerTruth,
    SchedCommand,
    BroadcastTick,
    SessionTick,
    MissionReport,
    Fault,
    RejectReport,
    RgbUpdate,
    CameraReport,
    PacketDropped,
}

impl MessageKind {
    pub const ALL: [MessageKind; 21] = [
        MessageKind::Clock,
        MessageKind::SimState,
        MessageKind::SimContacts,
        MessageKind::EventPacket,
        MessageKind::RgbFrame,
        MessageKind::TokenEvent,
        MessageKind::FrameEvent,
        MessageKind::Decision,
        MessageKind::ObserverStatus,
        MessageKind::ObserverTrack,
        MessageKind::PerformerSetpoint,
        MessageKind::PerformerTruth,
        MessageKind::SchedCommand,
        MessageKind::BroadcastTick,
        MessageKind::SessionTick,
        MessageKind::MissionReport,
        MessageKind::Fault,
        MessageKind::RejectReport,
        MessageKind::RgbUpdate,
        MessageKind::CameraReport,
        MessageKind::PacketDropped,
    ];

    /// Schema name of the raw channel (`waggle.<Rust type>`).
    pub fn schema_name(self) -> &'static str {
        match self {
            MessageKind::Clock => "waggle.ClockTick",
            MessageKind::SimState => "waggle.SimState",
            MessageKind::SimContacts => "waggle.SimContacts",
            MessageKind::EventPacket => "waggle.EventPacket",
            MessageKind::RgbFrame => "waggle.RgbFrame",
            MessageKind::TokenEvent => "waggle.TokenEvent",
            MessageKind::FrameEvent => "waggle.FrameEvent",
            MessageKind::Decision => "waggle.Decision",
            MessageKind::ObserverStatus => "waggle.ObserverStatus",
            MessageKind::ObserverTrack => "waggle.ObserverTrack",
            MessageKind::PerformerSetpoint => "waggle.PerformerSetpoint",
            MessageKind::PerformerTruth => "waggle.PerformerTruth",
            MessageKind::SchedCommand => "waggle.SchedCommand",
            MessageKind::BroadcastTick => "waggle.BroadcastTick",
            MessageKind::SessionTick => "waggle.SessionTick",
            MessageKind::MissionReport => "waggle.MissionReport",
            MessageKind::Fault => "waggle.Fault",
            MessageKind::RejectReport => "waggle.RejectReport",
            MessageKind::RgbUpdate => "waggle.RgbUpdate",
            MessageKind::CameraReport => "waggle.CameraReport",
            MessageKind::PacketDropped => "waggle.PacketDropped",
        }
    }

    /// The kind whose schema is named `name`.
    pub fn from_schema_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.schema_name() == name)
    }
}

/// A key of the session, classified.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// Channel topic: the key without the `waggle/<session>` prefix, with a leading `/`.
    pub topic: String,
    pub kind: MessageKind,
    /// The observer the key belongs to (`sensor/<o>/…`, `observer/<o>/…`, `fault/<o>`).
    pub observer: Option<ObserverId>,
    /// The key itself, parsed.
    pub key: Key,
}

impl MessageKind {
    /// The message type carried on `key`; `None` for liveliness and readiness tokens, which
    /// carry no message.
    pub fn of_key(key: &Key) -> Option<Self> {
        Some(match key {
            Key::Clock => MessageKind::Clock,
            Key::SimState => MessageKind::SimState,
            Key::SimContacts => MessageKind::SimContacts,
            Key::SensorEvents(_) => MessageKind::EventPacket,
            // What RGB cameras publish: key frames and changed rectangles (recordings made
            // before every update was recorded hold whole frames, `MessageKind::RgbFrame`).
            Key::SensorRgb(_) => MessageKind::RgbUpdate,
            Key::SensorDropped(_) => MessageKind::PacketDropped,
            // An event camera's renders, as the RGB camera sends its frames.
            Key::CameraInput(_) => MessageKind::RgbUpdate,
            Key::ObserverTokens(_) => MessageKind::TokenEvent,
            Key::ObserverFrames(_) => MessageKind::FrameEvent,
            Key::ObserverDecision(_) => MessageKind::Decision,
            Key::ObserverStatus(_) => MessageKind::ObserverStatus,
            Key::ObserverTrack(_) => MessageKind::ObserverTrack,
            Key::PerformerSetpoint => MessageKind::PerformerSetpoint,
            Key::TruthPerformer => MessageKind::PerformerTruth,
            Key::SchedCmd => MessageKind::SchedCommand,
            Key::SchedBroadcast => MessageKind::BroadcastTick,
            Key::SchedSession => MessageKind::SessionTick,
            Key::SchedReport => MessageKind::MissionReport,
            Key::Fault(_) => MessageKind::Fault,
            Key::Rejects(..) => MessageKind::RejectReport,
            Key::CameraReport(_) => MessageKind::CameraReport,
            Key::Alive(..) | Key::Ready(..) => return None,
        })
    }
}

/// Classifies `key` of the session whose key prefix is `prefix` (`waggle/<session>`) with the
/// one key grammar ([`Key::parse_rest`]); `None` for keys outside the session or of no known
/// message type.
pub fn classify(prefix: &str, key: &str) -> Option<Topic> {
    let rest = key.strip_prefix(prefix)?.strip_prefix('/')?;
    let parsed = Key::parse_rest(rest)?;
    Some(Topic {
        topic: format!("/{rest}"),
        kind: MessageKind::of_key(&parsed)?,
        observer: parsed.observer().cloned(),
        key: parsed,
    })
}

/// The observer named in a raw channel's topic (`/sensor/O1/events` → `O1`), if any: the topic
/// is parsed with the one key grammar ([`Key::parse_rest`]).
pub fn topic_observer(topic: &str) -> Option<&str> {
    let rest = topic.trim_start_matches('/');
    Key::parse_rest(rest)?.observer()?;
    // Every key that names an observer has it as its second chunk.
    rest.split('/').nth(1)
}

/// A decoded message of any kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Decoded {
    Clock(ClockTick),
    SimState(SimState),
    SimContacts(SimContacts),
    EventPacket(EventPacket),
    RgbFrame(RgbFrame),
    TokenEvent(TokenEvent),
    FrameEvent(FrameEvent),
    Decision(Decision),
    ObserverStatus(ObserverStatus),
    ObserverTrack(ObserverTrack),
    PerformerSetpoint(PerformerSetpoint),
    PerformerTruth(PerformerTruth),
    SchedCommand(SchedCommand),
    BroadcastTick(BroadcastTick),
    SessionTick(SessionTick),
    MissionReport(MissionReport),
    Fault(Fault),
    RejectReport(RejectReport),
    RgbUpdate(RgbUpdate),
    CameraReport(CameraReport),
    PacketDropped(PacketDropped),
}

/// Decodes `bytes` as a message of `kind` with the one [`proto::decode`].
pub fn decode(kind: MessageKind, bytes: &[u8]) -> Result<Decoded, DecodeError> {
    use proto::decode as d;
    Ok(match kind {
        MessageKind::Clock => Decoded::Clock(d(bytes)?),
        MessageKind::SimState => Decoded::SimState(d(bytes)?),
        MessageKind::SimContacts => Decoded::SimContacts(d(bytes)?),
        MessageKind::EventPacket => Decoded::EventPacket(d(bytes)?),
        MessageKind::RgbFrame => Decoded::RgbFrame(d(bytes)?),
        MessageKind::TokenEvent => Decoded::TokenEvent(d(bytes)?),
        MessageKind::FrameEvent => Decoded::FrameEvent(d(bytes)?),
        MessageKind::Decision => Decoded::Decision(d(bytes)?),
        MessageKind::ObserverStatus => Decoded::ObserverStatus(d(bytes)?),
        MessageKind::ObserverTrack => Decoded::ObserverTrack(d(bytes)?),
        MessageKind::PerformerSetpoint => Decoded::PerformerSetpoint(d(bytes)?),
        MessageKind::PerformerTruth => Decoded::PerformerTruth(d(bytes)?),
        MessageKind::SchedCommand => Decoded::SchedCommand(d(bytes)?),
        MessageKind::BroadcastTick => Decoded::BroadcastTick(d(bytes)?),
        MessageKind::SessionTick => Decoded::SessionTick(d(bytes)?),
        MessageKind::MissionReport => Decoded::MissionReport(d(bytes)?),
        MessageKind::Fault => Decoded::Fault(d(bytes)?),
        MessageKind::RejectReport => Decoded::RejectReport(d(bytes)?),
        MessageKind::RgbUpdate => Decoded::RgbUpdate(d(bytes)?),
        MessageKind::CameraReport => Decoded::CameraReport(d(bytes)?),
        MessageKind::PacketDropped => Decoded::PacketDropped(d(bytes)?),
    })
}

impl Decoded {
    /// The message's own sim time, ns (its stamp, or the end of its tick); `None` for faults,
    /// reject and camera reports, which carry no time of publication.
    pub fn sim_time_ns(&self) -> Option<u64> {
        let tick = |k: u64| k.checked_mul(TICK_NS);
        match self {
            Decoded::Clock(c) => Some(c.sim_time_ns),
            Decoded::SimState(s) => Some(s.stamp_ns),
            Decoded::SimContacts(c) => tick(c.tick),
            Decoded::EventPacket(p) => Some(p.end_ns),
            Decoded::RgbFrame(f) => Some(f.stamp_ns),
            Decoded::RgbUpdate(u) => Some(u.stamp_ns),
            Decoded::TokenEvent(t) => Some(t.confirmed_ns),
            Decoded::FrameEvent(f) => Some(f.frame.final_null_ns()),
            Decoded::Decision(d) => Some(d.decided_ns),
            Decoded::ObserverStatus(s) => tick(s.tick),
            Decoded::ObserverTrack(t) => tick(t.tick),
            Decoded::PerformerSetpoint(s) => tick(s.tick),
            Decoded::PerformerTruth(t) => Some(t.stamp_ns),
            Decoded::SchedCommand(c) => tick(c.tick),
            Decoded::BroadcastTick(b) => tick(b.tick),
            Decoded::SessionTick(s) => tick(s.tick),
            Decoded::MissionReport(r) => Some(r.end_ns),
            Decoded::PacketDropped(d) => tick(d.tick),
            Decoded::Fault(_) | Decoded::RejectReport(_) | Decoded::CameraReport(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Keys;

    #[test]
    fn every_key_of_the_session_has_a_kind_and_a_topic() {
        let k = Keys::new("s1").unwrap();
        let o2 = ObserverId::new("O2").unwrap();
        let cases = [
            (k.clock(), MessageKind::Clock, "/clock", None),
            (k.sim_state(), MessageKind::SimState, "/sim/state", None),
            (
                k.sim_contacts(),
                MessageKind::SimContacts,
                "/sim/contacts",
                None,
            ),
            (
                k.sensor_events(&o2),
                MessageKind::EventPacket,
                "/sensor/O2/events",
                Some("O2"),
            ),
            (
                k.sensor_rgb(&o2),
                MessageKind::RgbUpdate,
                "/sensor/O2/rgb",
                Some("O2"),
            ),
            (
                k.observer_tokens(&o2),
                MessageKind::TokenEvent,
                "/observer/O2/tokens",
                Some("O2"),
            ),
            (
                k.observer_frames(&o2),
                MessageKind::FrameEvent,
                "/observer/O2/frames",
                Some("O2"),
            ),
            (
                k.observer_decision(&o2),
                MessageKind::Decision,
                "/observer/O2/decision",
                Some("O2"),
            ),
            (
                k.observer_status(&o2),
                MessageKind::ObserverStatus,
                "/observer/O2/status",
                Some("O2"),
            ),
            (
                k.observer_track(&o2),
                MessageKind::ObserverTrack,
                "/observer/O2/track",
                Some("O2"),
            ),
            (
                k.performer_setpoint(),
                MessageKind::PerformerSetpoint,
                "/performer/setpoint",
                None,
            ),
            (
                k.truth_performer(),
                MessageKind::PerformerTruth,
                "/truth/performer",
                None,
            ),
            (k.sched_cmd(), MessageKind::SchedCommand, "/sched/cmd", None),
            (
                k.sched_broadcast(),
                MessageKind::BroadcastTick,
                "/sched/broadcast",
                None,
            ),
            (
                k.sched_session(),
                MessageKind::SessionTick,
                "/sched/session",
                None,
            ),
            (
                k.sched_report(),
                MessageKind::MissionReport,
                "/sched/report",
                None,
            ),
            (k.fault(&o2), MessageKind::Fault, "/fault/O2", Some("O2")),
            (
                k.camera_report(&o2),
                MessageKind::CameraReport,
                "/camera/O2/report",
                Some("O2"),
            ),
            (
                k.rejects(proto::Role::Camera, "O2").unwrap(),
                MessageKind::RejectReport,
                "/rejects/camera/O2",
                None,
            ),
        ];
        for (key, kind, topic, observer) in cases {
            let t = classify(k.prefix(), &key).unwrap_or_else(|| panic!("{key}"));
            assert_eq!(t.kind, kind, "{key}");
            assert_eq!(t.topic, topic);
            assert_eq!(t.observer.as_ref().map(|o| o.as_str()), observer);
            assert_eq!(topic_observer(topic), observer);
            assert_eq!(
                MessageKind::from_schema_name(kind.schema_name()),
                Some(kind)
            );
        }
    }

    #[test]
    fn keys_outside_the_grammar_have_no_topic() {
        let k = Keys::new("s1").unwrap();
        for bad in [
            "waggle/s1/unknown",
            "waggle/s1/sensor/O1/depth",
            "waggle/other/clock",
            "waggle/s1",
            "waggle/s1/sensor/O*/events",
            "waggle/s1/alive/sim/sim",
            "waggle/s1/ready/camera/O1",
        ] {
            assert_eq!(classify(k.prefix(), bad), None, "{bad}");
        }
        for no_observer in ["/clock", "/view/O1/events", "/sensor/O*/rgb"] {
            assert_eq!(topic_observer(no_observer), None, "{no_observer}");
        }
    }

    #[test]
    fn decoding_uses_the_wire_format_and_reports_bad_bytes() {
        let c = ClockTick::at(5).unwrap();
        let bytes = proto::encode(&c);
        let d = decode(MessageKind::Clock, &bytes).unwrap();
        assert_eq!(d, Decoded::Clock(c));
        assert_eq!(d.sim_time_ns(), Some(200_000_000));
        assert!(decode(MessageKind::Clock, &bytes[..3]).is_err());
        assert!(decode(MessageKind::SimState, &bytes).is_err());
        assert!(decode(MessageKind::EventPacket, &[]).is_err());
    }
}
