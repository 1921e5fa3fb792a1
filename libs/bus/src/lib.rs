//! Zenoh plumbing shared by every Waggle process (DESIGN.md §2).
//!
//! - [`Endpoints`]: the `--connect` / `--listen` options every node takes, and the session
//!   [`config`] built from them (peer mode, multicast scouting off, loopback by default);
//! - [`Bus`]: one Zenoh session with a single ordered inbox. Every subscription and liveliness
//!   watch of a process feeds the same channel, so data messages from one peer arrive in the
//!   order that peer published them, whichever key they were on. Liveliness changes are
//!   declarations, sent at Zenoh's control priority: they may overtake data still in flight,
//!   so a token's deletion never means "no more messages will come" (the lockstep therefore
//!   never relies on cross-key order: every per-tick message names its tick);
//! - [`handshake`]: the start-up protocol (`alive` then `ready` tokens) that guarantees every
//!   subscriber exists before the simulator publishes tick 0;
//! - [`on_stop_signal`]: the SIGINT/SIGTERM flag with which processes end cleanly.
//!
//! Key expressions come from [`proto::Keys`] only; payloads go through [`proto::encode`] /
//! [`proto::decode`] only.

mod bus;
pub mod cli;
mod endpoints;
pub mod handshake;
mod stop;

pub use bus::{Bus, BusError, Inbound, decode};
pub use cli::NodeArgs;
pub use endpoints::{Endpoints, config};
pub use handshake::{Process, mission_processes};
pub use stop::on_stop_signal;
