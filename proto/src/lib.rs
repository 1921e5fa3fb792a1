//! Waggle wire contracts.
//!
//! One crate owns every message exchanged between Waggle processes, the key expressions they are
//! published under, and the single [`encode`]/[`decode`] pair (serde + bincode with a format
//! version). Decoding is strict: unknown versions, trailing bytes and internally inconsistent
//! messages are rejected with a typed [`DecodeError`].

pub mod codec;
pub mod scene;
pub mod sensor;

pub use codec::{DecodeError, FORMAT_VERSION, decode, encode};
pub use sensor::{EventPacket, Polarity, RgbFrame};
