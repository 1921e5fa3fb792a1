//! Performer: gesture generation for the motion alphabet.
//!
//! - [`gesture`]: sizes and durations of the symbols and NULL holds (the timing table lives
//!   there), and the stroke decomposition of a keypoint polyline;
//! - [`schedule`]: a flight [`Schedule`] — smooth minimum-jerk setpoints as an exact function of
//!   integer sim time — with its ground-truth symbol timeline, and [`broadcast`] for whole
//!   broadcasts of one or more offers;
//! - [`ideal_receiver`]: the evaluation-only ideal-message baseline, which projects ground-truth
//!   performer positions into every observer's camera. It lives here, not in `observer-node`, so
//!   that no observer process can ever link it.

pub mod gesture;
pub mod ideal_receiver;
pub mod min_jerk;
pub mod schedule;

pub use gesture::{GestureConfig, MotionProfile, NS_PER_MS, NS_PER_S};
pub use ideal_receiver::{IdealReceiver, IdealReceiverError, ObserverOutput};
pub use schedule::{
    FrameSlot, Schedule, ScheduleBuilder, ScheduledOffer, Setpoint, TruthSpan, TruthSymbol,
    broadcast,
};

/// Why a schedule could not be built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    #[error("a hold or motion has zero duration")]
    ZeroDuration,
    #[error("amplitudes must be finite and positive, got u {amplitude_u_m} m, v {amplitude_v_m} m")]
    BadAmplitude {
        amplitude_u_m: f64,
        amplitude_v_m: f64,
    },
    #[error("origin {origin_m:?} is not finite")]
    BadOrigin { origin_m: [f64; 3] },
    #[error("payload {payload} does not fit in 6 bits")]
    PayloadTooWide { payload: u8 },
    #[error("schedule runs past the end of representable sim time")]
    TimeOverflow,
}
