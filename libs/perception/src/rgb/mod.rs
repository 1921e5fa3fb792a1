//! The RGB receiver (paper, "RGB trajectory extraction"): 640×480 frames at 25 Hz in, tokens
//! and released frames out.
//!
//! - [`luma`]: RGB → 8-bit grey, bit-exact with OpenCV's conversion;
//! - [`features`]: Shi–Tomasi good features to track inside a region;
//! - [`klt`]: pyramidal Lucas–Kanade with a forward–backward check (`optical-flow-lk`);
//! - [`tracker`]: central acquisition, robust median displacement, re-detection, loss;
//! - [`receiver`]: continuity checks and the shared segmenter / frame parser.

pub mod error;
pub mod features;
pub mod klt;
pub mod luma;
pub mod receiver;
pub mod tracker;

pub use error::RgbReceiverError;
pub use receiver::{
    FrameRejection, RgbFrameOutcome, RgbInterruptCause, RgbReceiver, RgbReceiverConfig,
    RgbReceiverStatus, RgbSymbolTrajectory, RgbTrackStep,
};
pub use tracker::{LossReason, RgbTrackerConfig, TargetTracker, TrackEvent, TrackStep};
