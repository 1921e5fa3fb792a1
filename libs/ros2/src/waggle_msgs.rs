//! Waggle's own messages (`waggle_msgs`, defined in `libs/ros2/msg/waggle_msgs/msg/`), built
//! from the wire types of `proto` and encoded in CDR.

use proto::{Broadcast, Decision, Fault, FaultKind, FrameEvent, Offer, Token, TokenEvent};

use crate::cdr::{CdrEncode, CdrWriter, RosMessage};
use crate::error::Ros2Error;
use crate::messages::{HeaderMsg, TimeMsg};

/// The optical frame of observer `o`'s camera.
pub fn optical_frame(observer: &str) -> String {
    format!("{observer}/camera_optical")
}

/// `waggle_msgs/msg/Token`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TokenMsg {
    pub header: HeaderMsg,
    pub observer: String,
    pub seq: u64,
    pub token: u8,
    pub label: String,
}

/// The `TOKEN_` constant of a token.
fn token_code(t: Token) -> u8 {
    match t {
        Token::Null => 0,
        Token::Start => 1,
        Token::Bit0 => 2,
        Token::Bit1 => 3,
        Token::End => 4,
        Token::Unknown => 5,
    }
}

impl TokenMsg {
    pub fn from_wire(t: &TokenEvent) -> Result<Self, Ros2Error> {
        Ok(Self {
            header: HeaderMsg::at(t.confirmed_ns, optical_frame(t.observer.as_str()))?,
            observer: t.observer.to_string(),
            seq: t.seq,
            token: token_code(t.token),
            label: t.token.label().to_string(),
        })
    }
}

impl CdrEncode for TokenMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.observer);
        w.u64(self.seq);
        w.u8(self.token);
        w.string(&self.label);
    }
}

impl RosMessage for TokenMsg {
    const TYPE_NAME: &'static str = "waggle_msgs/msg/Token";
}

/// `waggle_msgs/msg/Offer`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct OfferMsg {
    pub site: String,
    pub quality: u8,
    pub capacity: u8,
    pub withdrawn: bool,
}

impl From<&Offer> for OfferMsg {
    fn from(o: &Offer) -> Self {
        Self {
            site: o.site.name().to_string(),
            quality: o.quality,
            capacity: o.capacity,
            withdrawn: o.withdrawn(),
        }
    }
}

impl CdrEncode for OfferMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.string(&self.site);
        w.u8(self.quality);
        w.u8(self.capacity);
        w.bool(self.withdrawn);
    }
}

/// `waggle_msgs/msg/Frame`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameMsg {
    pub header: HeaderMsg,
    pub observer: String,
    pub seq: u64,
    pub round: u32,
    pub payload: u8,
    pub bits: String,
    pub offer_valid: bool,
    pub offer: OfferMsg,
    pub token_stamps: [TimeMsg; 17],
}

impl FrameMsg {
    pub fn from_wire(f: &FrameEvent) -> Result<Self, Ros2Error> {
        let payload = f.frame.payload;
        let offer = Offer::from_payload(payload).ok();
        // A checked frame (19 or 23 tokens) keeps the message's 17 slots: its tokens up to b6's
        // NULL and its closing END NULL; the check bits follow from the payload and the
        // session's check, which the recorded case holds.
        let stamps = &f.frame.token_stamps_ns;
        let (head, tail) = stamps.split_at(stamps.len().min(15));
        let tail = &tail[tail.len().saturating_sub(2)..];
        let mut token_stamps = [TimeMsg::default(); 17];
        for (slot, &t) in token_stamps.iter_mut().zip(head.iter().chain(tail)) {
            *slot = TimeMsg::from_ns(t)?;
        }
        Ok(Self {
            header: HeaderMsg::at(f.frame.final_null_ns(), optical_frame(f.observer.as_str()))?,
            observer: f.observer.to_string(),
            seq: f.seq,
            round: f.round,
            payload,
            bits: f
                .frame
                .bits()
                .iter()
                .map(|&b| if b { '1' } else { '0' })
                .collect(),
            offer_valid: offer.is_some(),
            offer: offer.as_ref().map(OfferMsg::from).unwrap_or_default(),
            token_stamps,
        })
    }
}

impl CdrEncode for FrameMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.observer);
        w.u64(self.seq);
        w.u32(self.round);
        w.u8(self.payload);
        w.string(&self.bits);
        w.bool(self.offer_valid);
        self.offer.encode(w);
        for t in &self.token_stamps {
            t.encode(w);
        }
    }
}

impl RosMessage for FrameMsg {
    const TYPE_NAME: &'static str = "waggle_msgs/msg/Frame";
}

/// `waggle_msgs/msg/SourceFrame`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceFrameMsg {
    pub observer: String,
    pub frame_seq: u64,
    pub offer: OfferMsg,
    pub final_null: TimeMsg,
}

impl CdrEncode for SourceFrameMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.string(&self.observer);
        w.u64(self.frame_seq);
        self.offer.encode(w);
        self.final_null.encode(w);
    }
}

/// `waggle_msgs/msg/Assignment`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AssignmentMsg {
    pub observer: String,
    /// `A`, `B`, or empty for staying home.
    pub site: String,
}

impl CdrEncode for AssignmentMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.string(&self.observer);
        w.string(&self.site);
    }
}

/// `waggle_msgs/msg/Decision`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecisionMsg {
    pub header: HeaderMsg,
    pub observer: String,
    pub round: u32,
    pub assignment: String,
    pub sources: Vec<SourceFrameMsg>,
    pub allocation: Vec<AssignmentMsg>,
}

impl DecisionMsg {
    pub fn from_wire(d: &Decision) -> Result<Self, Ros2Error> {
        let site = |s: &Option<proto::Site>| s.map(|s| s.name().to_string()).unwrap_or_default();
        let sources = d
            .sources
            .iter()
            .map(|s| {
                Ok(SourceFrameMsg {
                    observer: s.observer.to_string(),
                    frame_seq: s.frame_seq,
                    offer: OfferMsg::from(&s.offer),
                    final_null: TimeMsg::from_ns(s.final_null_ns)?,
                })
            })
            .collect::<Result<_, Ros2Error>>()?;
        Ok(Self {
            header: HeaderMsg::at(d.decided_ns, d.observer.to_string())?,
            observer: d.observer.to_string(),
            round: d.round,
            assignment: site(&d.assignment),
            sources,
            allocation: d
                .allocation
                .iter()
                .map(|(o, s)| AssignmentMsg {
                    observer: o.to_string(),
                    site: site(s),
                })
                .collect(),
        })
    }
}

impl CdrEncode for DecisionMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.observer);
        w.u32(self.round);
        w.string(&self.assignment);
        self.sources.encode(w);
        self.allocation.encode(w);
    }
}

impl RosMessage for DecisionMsg {
    const TYPE_NAME: &'static str = "waggle_msgs/msg/Decision";
}

/// `waggle_msgs/msg/Fault`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultMsg {
    pub header: HeaderMsg,
    pub observer: String,
    pub kind: u8,
    pub drop_per_mille: u16,
    pub delay_ms: u32,
    pub active_from: TimeMsg,
    pub has_until: bool,
    pub active_until: TimeMsg,
}

impl FaultMsg {
    pub fn from_wire(f: &Fault) -> Result<Self, Ros2Error> {
        let (kind, drop_per_mille, delay_ms) = match f.kind {
            FaultKind::BlackInput => (0, 0, 0),
            FaultKind::StreamDropout => (1, 0, 0),
            FaultKind::Throttle {
                drop_per_mille,
                delay_ms,
            } => (2, drop_per_mille, delay_ms),
        };
        Ok(Self {
            header: HeaderMsg::at(f.from_ns, f.observer.to_string())?,
            observer: f.observer.to_string(),
            kind,
            drop_per_mille,
            delay_ms,
            active_from: TimeMsg::from_ns(f.from_ns)?,
            has_until: f.until_ns.is_some(),
            active_until: f
                .until_ns
                .map(TimeMsg::from_ns)
                .transpose()?
                .unwrap_or_default(),
        })
    }
}

impl CdrEncode for FaultMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.observer);
        w.u8(self.kind);
        w.u16(self.drop_per_mille);
        w.u32(self.delay_ms);
        self.active_from.encode(w);
        w.bool(self.has_until);
        self.active_until.encode(w);
    }
}

impl RosMessage for FaultMsg {
    const TYPE_NAME: &'static str = "waggle_msgs/msg/Fault";
}

/// The performer's body frame, as `/tf` names it.
pub const PERFORMER_FRAME: &str = "performer";

/// `waggle_msgs/msg/Broadcast`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BroadcastMsg {
    pub header: HeaderMsg,
    pub round: u32,
    pub acquisition: bool,
    pub offers: Vec<OfferMsg>,
}

impl BroadcastMsg {
    pub fn from_wire(b: &Broadcast) -> Result<Self, Ros2Error> {
        Ok(Self {
            header: HeaderMsg::at(b.start_ns, PERFORMER_FRAME)?,
            round: b.round,
            acquisition: b.acquisition,
            offers: b.offers.iter().map(OfferMsg::from).collect(),
        })
    }
}

impl CdrEncode for BroadcastMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.u32(self.round);
        w.bool(self.acquisition);
        self.offers.encode(w);
    }
}

impl RosMessage for BroadcastMsg {
    const TYPE_NAME: &'static str = "waggle_msgs/msg/Broadcast";
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::ObserverId;

    #[test]
    fn a_checked_frame_keeps_its_payload_tokens_and_its_closing_end_null() {
        // 23 tokens (CRC-3): stamps 1 s apart, so slot k of the message says which was kept.
        let frame = |n: u64| FrameEvent {
            observer: ObserverId::new("O1").unwrap(),
            seq: 0,
            round: 1,
            frame: proto::ReleasedFrame {
                payload: 0b011010,
                token_stamps_ns: (1..=n).map(|k| k * 1_000_000_000).collect(),
            },
        };
        let secs = |m: &FrameMsg| m.token_stamps.iter().map(|t| t.sec).collect::<Vec<_>>();
        let checked = FrameMsg::from_wire(&frame(23)).unwrap();
        let want: Vec<i32> = (1..=15).chain([22, 23]).collect();
        assert_eq!(secs(&checked), want);
        assert_eq!(checked.header.stamp.sec, 23);
        let paper = FrameMsg::from_wire(&frame(17)).unwrap();
        assert_eq!(secs(&paper), (1..=17).collect::<Vec<i32>>());
    }

    #[test]
    fn a_throttle_fault_encodes_as_hand_computed() {
        let f = Fault {
            observer: ObserverId::new("O2").unwrap(),
            kind: FaultKind::Throttle {
                drop_per_mille: 250,
                delay_ms: 7,
            },
            from_ns: 3_000_000_000,
            until_ns: None,
        };
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,
            0x03, 0, 0, 0, 0, 0, 0, 0,          // stamp 3 s                    0
            0x03, 0, 0, 0, b'O', b'2', 0,       // frame_id "O2"                8
            0x00,                               // pad                          15
            0x03, 0, 0, 0, b'O', b'2', 0,       // observer "O2"                16
            0x02,                               // kind THROTTLE                23
            0xFA, 0x00,                         // drop_per_mille 250           24
            0x00, 0x00,                         // pad                          26
            0x07, 0, 0, 0,                      // delay_ms                     28
            0x03, 0, 0, 0, 0, 0, 0, 0,          // active_from 3 s              32
            0x00,                               // has_until                    40
            0, 0, 0,                            // pad                          41
            0, 0, 0, 0, 0, 0, 0, 0,             // active_until                 44
        ];
        assert_eq!(FaultMsg::from_wire(&f).unwrap().to_cdr(), want);
    }
}
