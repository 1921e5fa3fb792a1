//! The pure protocol core: everything both ends of the waggle link must agree on, as functions
//! of their inputs (no I/O, no clock but the sim time passed in).
//!
//! - signalling: the motion [`alphabet`] and template matching, the 17-token [`frame`] parser,
//!   the six-bit [`payload`];
//! - the performer's side: symbol timing ([`gesture`]), [`min_jerk`] strokes and whole
//!   broadcasts ([`schedule`]);
//! - the receiver's side: the trajectory [`segmenter`] (NULL confirmation, candidate paths,
//!   tokens) and the [`decoder`] that feeds it into the parser;
//! - the group's side: [`task`] state, offer cache and [`allocation`] policy, the
//!   [`provenance`] audit;
//! - geometry: the shared [`scene`] layout and pinhole camera model, and the viewpoint
//!   [`rectify`] map applied before template matching, and the [`stabilise`] map that undoes
//!   the observer's own airframe turning.

pub mod allocation;
pub mod alphabet;
pub mod decoder;
pub mod frame;
pub mod gesture;
pub mod min_jerk;
pub mod payload;
pub mod provenance;
pub mod rectify;
mod rest_home;
pub mod scene;
pub mod schedule;
mod segment_sample;
pub mod segmenter;
pub mod stabilise;
pub mod task;
