//! Observer: perception state (RGB and event receivers), frame parser, offer cache and allocation.
//!
//! - [`segmenter`]: the NULL / motion segmenter shared by every receiver (ideal, RGB, events);
//! - [`decoder`]: segmenter + the 17-token frame parser, from samples to released frames;
//! - [`events`]: the event-only receiver (event packets in, tokens and frames out).
//! - [`rgb`]: the RGB receiver (KLT trajectory extraction; RGB frames in, tokens and frames out).

pub mod agent;
pub mod decoder;
pub mod events;
pub mod perception;
pub mod rgb;
pub mod runtime;
pub mod segmenter;

pub use decoder::{DecodeStep, Decoder};
pub use segmenter::{
    Interruption, Sample, SegmentToken, Segmenter, SegmenterConfig, SegmenterError, TokenCause,
};
