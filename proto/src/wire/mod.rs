//! The wire layer: every message exchanged between Waggle processes, the key expressions they
//! are published under ([`keys::Keys`], the one key grammar) and the single strict
//! [`codec::encode`]/[`codec::decode`] pair. Nothing here decides anything.

pub mod camera;
pub mod clock;
pub mod codec;
pub mod end_reason;
pub mod fault;
pub mod keys;
pub mod modality;
pub mod observer;
pub mod rejects;
pub mod sched;
pub mod sensor;
pub mod token;
pub mod track;
pub mod world;
