//! Zenoh plumbing shared by every Waggle process (docs/DESIGN.md §2).
//!
//! - [`Endpoints`]: the `--connect` / `--listen` options every node takes, and the session
//!   [`config`] built from them (peer mode, multicast scouting off, loopback by default);
//! - [`auth`] and [`access`]: per-session credentials (Zenoh user/password authentication) and
//!   the per-role access-control list the session's router enforces;
//! - [`Bus`]: one Zenoh session with a single ordered inbox. Every subscription and liveliness
//!   watch of a process feeds the same channel, so data messages from one peer arrive in the
//!   order that peer published them, whichever key they were on. Liveliness changes are
//!   declarations, sent at Zenoh's control priority: they may overtake data still in flight,
//!   so a token's deletion never means "no more messages will come" (the lockstep therefore
//!   never relies on cross-key order: every per-tick message names its tick);
//! - [`handshake`]: the start-up protocol (`alive` then `ready` tokens) that guarantees every
//!   subscriber exists before the simulator publishes tick 0;
//! - [`Rejects`]: what a process drops instead of aborting (undecodable, unexpected-key and
//!   out-of-contract messages), counted and reported on `rejects/<role>/<id>`;
//! - [`on_stop_signal`]: the SIGINT/SIGTERM flag with which processes end cleanly;
//! - [`delay`]: a test shim (`WAGGLE_TEST_DELAY`) holding back chosen keys' publications, to show
//!   that results do not depend on delivery timing.
//!
//! Zenoh's TCP links are built with a 1 s `SO_LINGER` (`TCP_LINGER_TIMEOUT` in
//! `.cargo/config.toml`) instead of 10 s: closing the link of a dead host blocks a thread for
//! the linger time, and 10 s equals the lease, so healthy hosts' sessions expired with it.
//!
//! Key expressions come from [`proto::Keys`] only; payloads go through [`proto::encode`] /
//! [`proto::decode`] only.

pub mod access;
pub mod auth;
mod bus;
pub mod cli;
pub mod delay;
mod endpoints;
mod error;
pub mod handshake;
mod process_name;
mod rejects;
mod stop;
pub mod tls;

pub use auth::{Credentials, DictionaryShare, SessionSecrets};
pub use bus::{Bus, Inbound, decode};
pub use cli::NodeArgs;
pub use endpoints::{
    Endpoints, client_config, config, is_loopback_endpoint, open_client_config, open_router_config,
    router_config, single_stream_quic, site_router_config,
};
pub use error::BusError;
pub use handshake::{Process, mission_processes};
pub use process_name::ProcessNameError;
pub use rejects::{LOGGED_REJECTS, Rejects};
pub use stop::on_stop_signal;
