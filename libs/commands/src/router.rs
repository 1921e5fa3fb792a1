//! `waggle router`: a session's Zenoh router on its own.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct RouterArgs {
    /// The session's compose file: its users, access list and endpoints. Without it, only an
    /// open loopback router (`--no-auth --session S`) can be served.
    #[arg(long)]
    pub compose: Option<PathBuf>,
    /// Endpoint to listen on, replacing the compose file's; repeatable.
    #[arg(long = "listen", value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Session id of an open router (without --compose).
    #[arg(long)]
    pub session: Option<String>,
    /// Open router: no authentication, no access control (loopback only).
    #[arg(long)]
    pub no_auth: bool,
}
