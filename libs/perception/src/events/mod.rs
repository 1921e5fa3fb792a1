//! The event-only receiving chain (paper, "Event-only trajectories and conditional null
//! signals"): an observer's own [`proto::EventPacket`]s in — coordinates, times, polarities,
//! watermarks, sequence, validity, continuity, dimensions; no RGB, no poses, no labels — tokens
//! and released frames out.
//!
//! - [`health`]: malformed packets (counted by reason) and delivery discontinuities;
//! - [`background`]: the measured background-activity rate;
//! - [`denoise`]: the noise front end (spatio-temporal correlation filter);
//! - [`ego_motion`]: the ego-motion front end (events the airframe's own turning explains);
//! - [`support`]: unique-pixel support, spans, percentile-bound centre, polarity balance;
//! - [`tracker`]: localise near the optical centre, track locally, judge support before polarity;
//! - [`acquisition`]: the NULL gate — a closed moving path observed, a 20 s tracking lease;
//! - [`receiver`]: the chain, feeding the shared segmenter and frame parser.

pub mod acquisition;
pub mod background;
pub mod denoise;
pub mod ego_motion;
pub mod error;
pub mod health;
pub mod receiver;
pub mod support;
pub mod tracker;

pub use acquisition::{Acquisition, AcquisitionConfig, AcquisitionEvent};
pub use background::BackgroundEstimate;
pub use denoise::{Adaptive, DenoiseConfig, DenoiseCounts, NoiseFilter};
pub use error::EventReceiverError;
pub use health::{Delivery, DeliveryMonitor, Discontinuity, PacketRejection};
pub use receiver::{
    EventInterruptCause, EventReceiver, EventReceiverConfig, EventReceiverStatus,
    EventSymbolTrajectory, EventTrackStep, PacketOutcome,
};
pub use support::{Evidence, SupportScratch, Window, gather};
pub use tracker::{
    EventTrackerConfig, Judgement, Observation, SupportTracker, TrackFault, is_supported,
    support_first,
};
