//! Waggle wire contracts.
//!
//! One crate owns every message exchanged between Waggle processes, the key expressions they are
//! published under, and the single [`encode`]/[`decode`] pair (serde + bincode with a format
//! version). Decoding is strict: unknown versions, trailing bytes and internally inconsistent
//! messages are rejected with a typed [`DecodeError`].

pub mod allocation;
pub mod alphabet;
pub mod clock;
pub mod codec;
pub mod fault;
pub mod frame;
pub mod keys;
pub mod observer;
pub mod payload;
pub mod provenance;
pub mod scene;
pub mod sched;
pub mod sensor;
pub mod task;
pub mod token;
pub mod track;
pub mod world;

pub use allocation::{Allocation, CachedOffer, OfferCache, Roster, RosterEntry, allocate};
pub use alphabet::{Classification, MatchSettings, Rejection, classify};
pub use clock::{ClockTick, TICK_NS};
pub use codec::{DecodeError, FORMAT_VERSION, Validate, decode, encode};
pub use fault::{Fault, FaultKind};
pub use frame::{FrameParser, ReleasedFrame};
pub use keys::{KeyError, Keys, ObserverId, Role};
pub use observer::{
    Decision, FrameEvent, InputState, ObserverPhase, ObserverStatus, SourceFrame, TokenEvent,
};
pub use payload::{Offer, PayloadError, Site};
pub use provenance::{AuditViolation, audit_assignment, decide};
pub use sched::{
    Broadcast, BroadcastTick, Departure, MissionReport, ObserverSetpoint, SchedCommand,
    SessionControl, SessionEvent, SessionTick,
};
pub use sensor::{EventPacket, Polarity, RgbFrame};
pub use task::{TaskError, TaskState};
pub use token::{Action, Token};
pub use track::{ObserverTrack, TrackSample};
pub use world::{
    Contact, DronePose, PerformerActivity, PerformerSetpoint, PerformerTruth, SimContacts, SimState,
};
