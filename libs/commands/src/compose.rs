//! `waggle compose`: a session's compose file, its nodes placed on hosts.

use crate::assign::{HostIs, HostPlacement};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ComposeArgs {
    #[command(flatten)]
    pub session: super::run::SessionArgs,
    /// Place nodes on a host: `ROLE=HOST`, ROLE a process name (`sim`, `scheduler`,
    /// `performer`, `recorder`, `camera-O1`, `observer-O1`, `router`) or a glob of them
    /// (`camera-*`, `*-O2`); applied in order, later ones win. Unplaced nodes run on `local`.
    #[arg(long = "place", value_name = "ROLE=HOST")]
    pub place: Vec<HostPlacement>,
    /// Endpoint the router listens on and other hosts dial, e.g. `quic/192.168.1.10:7447`
    /// (mutual TLS; plain `tcp/` beyond loopback needs `--plain-tcp`; default
    /// `tcp/127.0.0.1:0`, one host); repeatable.
    #[arg(long = "router", value_name = "ENDPOINT")]
    pub router: Vec<String>,
    /// A site's own router on HOST, listening on ENDPOINT (repeat for more endpoints): the
    /// nodes of HOST and of the hosts it serves (`--site-serves`) dial it, and it dials the
    /// session's router — a chain of two routers, one link between the sites.
    #[arg(long = "site", value_name = "HOST=ENDPOINT")]
    pub site: Vec<HostIs>,
    /// HOST's nodes dial the site router on SITE (named by `--site SITE=…`).
    #[arg(long = "site-serves", value_name = "HOST=SITE")]
    pub site_serves: Vec<HostIs>,
    /// An existing certificate authority (an institution's) to issue the session's
    /// certificates instead of a new CA of the session's own: its certificate (PEM). Needs
    /// `--ca-key`. Certificates then expire with the session or the CA, whichever is first.
    #[arg(long, value_name = "FILE", requires = "ca_key")]
    pub ca_cert: Option<PathBuf>,
    /// That CA's private key (PEM, readable by its owner only): read to sign, never copied.
    #[arg(long, value_name = "FILE", requires = "ca_cert")]
    pub ca_key: Option<PathBuf>,
    /// The compose file to write. Its credentials go to FILE's name with `.secrets` (a private
    /// directory; `waggle bundle FILE --host NAME` extracts what one host needs).
    #[arg(long)]
    pub out: PathBuf,
}
