//! The bus's wire codec: a message decoded as the type its key carries, and the key grammar.
//!
//! [`wire_message`] takes a key selector byte, then a message body: the key (one of every
//! grammar production, [`KEYS`]) is classified as the recorder classifies it, the body decoded
//! with [`proto::decode`] as that key's type, and a message that decodes must re-encode to the
//! very same bytes (the codec is strict: one encoding per value). [`wire_key`] parses a key and
//! checks that printing it gives the text back.

use proto::{Keys, Validate};
use recording::MessageKind;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The session every fuzzed key belongs to.
const SESSION: &str = "fuzz";

/// One key of every production of the key grammar (after `waggle/<session>/`); a selector past
/// the end decodes the body as a whole RGB frame, the type recordings made before RGB updates
/// hold (no key carries it any more).
pub const KEYS: &[&str] = &[
    "clock",
    "sim/state",
    "sim/contacts",
    "sensor/O1/events",
    "sensor/O1/rgb",
    "sensor/O1/dropped",
    "camera/O1/input",
    "observer/O1/tokens",
    "observer/O1/frames",
    "observer/O1/decision",
    "observer/O1/status",
    "observer/O1/track",
    "performer/setpoint",
    "truth/performer",
    "sched/cmd",
    "sched/broadcast",
    "sched/session",
    "sched/report",
    "fault/O1",
    "camera/O1/report",
    "rejects/observer/O1",
    "alive/sim/sim",
    "ready/camera/O1",
];

/// Decodes `bytes` as a `T`; a message that decodes must encode to `bytes` again. True when
/// it decoded.
fn round_trip<T: Serialize + DeserializeOwned + Validate>(bytes: &[u8]) -> bool {
    let Ok(msg) = proto::decode::<T>(bytes) else {
        return false;
    };
    let again = proto::encode(&msg);
    assert!(
        again == bytes,
        "{} decoded from {} bytes re-encodes to {} different bytes",
        std::any::type_name::<T>(),
        bytes.len(),
        again.len()
    );
    true
}

/// Decodes `bytes` as a message of `kind`, checking the round trip.
fn decode_kind(kind: MessageKind, bytes: &[u8]) {
    use proto::*;
    let decoded = match kind {
        MessageKind::Clock => round_trip::<ClockTick>(bytes),
        MessageKind::SimState => round_trip::<SimState>(bytes),
        MessageKind::SimContacts => round_trip::<SimContacts>(bytes),
        MessageKind::EventPacket => round_trip::<EventPacket>(bytes),
        MessageKind::RgbFrame => round_trip::<RgbFrame>(bytes),
        MessageKind::TokenEvent => round_trip::<TokenEvent>(bytes),
        MessageKind::FrameEvent => round_trip::<FrameEvent>(bytes),
        MessageKind::Decision => round_trip::<Decision>(bytes),
        MessageKind::ObserverStatus => round_trip::<ObserverStatus>(bytes),
        MessageKind::ObserverTrack => round_trip::<ObserverTrack>(bytes),
        MessageKind::PerformerSetpoint => round_trip::<PerformerSetpoint>(bytes),
        MessageKind::PerformerTruth => round_trip::<PerformerTruth>(bytes),
        MessageKind::SchedCommand => round_trip::<SchedCommand>(bytes),
        MessageKind::BroadcastTick => round_trip::<BroadcastTick>(bytes),
        MessageKind::SessionTick => round_trip::<SessionTick>(bytes),
        MessageKind::MissionReport => round_trip::<MissionReport>(bytes),
        MessageKind::Fault => round_trip::<Fault>(bytes),
        MessageKind::RejectReport => round_trip::<RejectReport>(bytes),
        MessageKind::RgbUpdate => round_trip::<RgbUpdate>(bytes),
        MessageKind::CameraReport => round_trip::<CameraReport>(bytes),
        MessageKind::PacketDropped => round_trip::<PacketDropped>(bytes),
    };
    // The recorder's decoder (replay, audit) must agree with the typed one.
    assert_eq!(recording::decode(kind, bytes).is_ok(), decoded, "{kind:?}");
}

/// Selector byte (a key of [`KEYS`]), then a message body.
pub fn wire_message(data: &[u8]) {
    let Some((&selector, body)) = data.split_first() else {
        return;
    };
    let keys = Keys::new(SESSION).expect("a valid session id");
    match KEYS.get(usize::from(selector)) {
        Some(rest) => {
            let key = format!("{}/{rest}", keys.prefix());
            let parsed = keys.parse(&key).expect("every entry of KEYS is a key");
            match recording::classify(keys.prefix(), &key) {
                Some(topic) => {
                    assert_eq!(topic.key, parsed);
                    decode_kind(topic.kind, body);
                }
                // Liveliness and readiness tokens carry no message.
                None => assert!(MessageKind::of_key(&parsed).is_none()),
            }
        }
        None => decode_kind(MessageKind::RgbFrame, body),
    }
}

/// A key (UTF-8 text after `waggle/<session>/`): a key that parses prints as the same text.
pub fn wire_key(data: &[u8]) {
    let Ok(rest) = std::str::from_utf8(data) else {
        return;
    };
    let keys = Keys::new(SESSION).expect("a valid session id");
    let full = format!("{}/{rest}", keys.prefix());
    let parsed = keys.parse(&full);
    assert_eq!(parsed, proto::Key::parse_rest(rest));
    if let Some(key) = parsed {
        assert_eq!(key.rest(), rest, "key {key:?} prints differently");
        assert_eq!(keys.of(&key), full);
        if let Some(o) = key.observer() {
            assert_eq!(proto::ObserverId::new(o.as_str()).as_ref(), Ok(o));
        }
    }
}
