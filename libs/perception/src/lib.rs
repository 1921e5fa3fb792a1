//! Observer perception: everything an observer does with its own sensor data, as pure code (no
//! I/O, no clock but the sim time of the input), so the `observer-node` process, `waggle replay`
//! and the in-process mission run exactly the same receiver.
//!
//! - [`events`]: the event-only receiver (event packets in, tokens and frames out);
//! - [`rgb`]: the RGB receiver (KLT trajectory extraction; RGB frames in, tokens and frames out);
//! - [`sensing`]: one receiver of either modality behind one interface ([`Perception`]), and the
//!   [`Receiving`] trait a receiver from elsewhere (a plug-in) implements to take its place;
//! - [`agent`]: offer cache, allocation and the observer's decisions;
//! - [`runtime`]: perception + frame parser + agent, one step per tick;
//! - [`tick`]: the sans-IO tick assembler that decides which tick the runtime processes next
//!   and with what (session controls, packet, or a missing packet);
//! - [`observer`]: the one observer core — assembler and runtime driven as one — that
//!   `observer-node`, `waggle replay` and the in-process mission all run.
//!
//! The segmenter and decoder the receivers share with the ideal receiver live in
//! [`proto::logic`].

pub mod agent;
pub mod events;
pub mod observer;
pub mod rgb;
pub mod runtime;
pub mod sensing;
pub mod tick;

pub use sensing::{Perception, PerceptionError, Receiving, SensorInput};
