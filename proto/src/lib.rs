//! Waggle's lowest layer: wire contracts and the pure protocol core.
//!
//! - [`wire`]: every message exchanged between Waggle processes, the key expressions they are
//!   published under ([`Keys`], whose [`Keys::parse`] is the one key grammar), and the single
//!   [`encode`]/[`decode`] pair (serde + bincode with a format version). Decoding is strict:
//!   unknown versions, trailing bytes and internally inconsistent messages are rejected with a
//!   typed [`DecodeError`].
//! - [`logic`]: the pure protocol core that performer, observers and scheduler share — alphabet,
//!   frame parser, payload, gesture timing, min-jerk strokes, broadcast schedule, segmenter,
//!   decoder, task state, allocation, provenance, scene geometry and camera model.
//!
//! No I/O anywhere in this crate. The modules of both layers are re-exported at the root so a
//! caller writes `proto::alphabet` or `proto::Keys` without naming the layer.

pub mod logic;
pub mod wire;

pub use logic::{
    allocation, alphabet, decoder, frame, gesture, min_jerk, payload, provenance, rectify, scene,
    schedule, segmenter, stabilise, task,
};
pub use wire::{
    camera, clock, codec, end_reason, fault, keys, modality, observer, rejects, sched, sensor,
    token, track, world,
};

pub use allocation::{Allocation, CachedOffer, OfferCache, Roster, RosterEntry, allocate};
pub use alphabet::{Classification, MatchSettings, Rejection, classify};
pub use camera::CameraReport;
pub use clock::{ClockTick, TICK_NS};
pub use codec::{DecodeError, FORMAT_VERSION, Validate, decode, encode};
pub use decoder::{DecodeStep, Decoder};
pub use end_reason::EndReason;
pub use fault::{Fault, FaultKind};
pub use frame::{FrameCheck, FrameParser, ReleasedFrame};
pub use gesture::{GestureConfig, MotionProfile, NS_PER_MS, NS_PER_S};
pub use keys::{Key, KeyError, Keys, ObserverId, Role};
pub use modality::{FlightMode, Modality, Receiver, RenderPath, UnknownName};
pub use observer::{
    Decision, FrameEvent, InputState, ObserverPhase, ObserverStatus, SourceFrame, TokenEvent,
};
pub use payload::{Offer, PayloadError, Site};
pub use provenance::{AuditViolation, audit_assignment, decide};
pub use rectify::{Rectification, Rectifier};
pub use rejects::{RejectCount, RejectReason, RejectReport};
pub use sched::{
    Broadcast, BroadcastTick, Departure, MissionReport, ObserverSetpoint, SchedCommand,
    SessionControl, SessionEvent, SessionTick,
};
pub use schedule::{
    FrameSlot, Schedule, ScheduleBuilder, ScheduleError, ScheduledOffer, TruthSpan, TruthSymbol,
    broadcast, paper_broadcast, performer_setpoint,
};
pub use segmenter::{
    Interruption, Sample, SegmentToken, Segmenter, SegmenterConfig, SegmenterError, TokenCause,
};
pub use sensor::{
    EventPacket, FrameChange, PacketDropped, PixelRect, Polarity, RgbFrame, RgbReassembler,
    RgbUpdate, Unassembled,
};
pub use stabilise::EgoRotation;
pub use task::{TaskError, TaskState};
pub use token::{Action, Token};
pub use track::{ObserverTrack, TrackSample};
pub use world::{
    Contact, DronePose, Kinematics, PerformerActivity, PerformerSetpoint, PerformerTruth,
    SimContacts, SimState,
};
