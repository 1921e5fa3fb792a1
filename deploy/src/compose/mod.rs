//! A session as a file, on disk: `waggle compose` writes one ([`build`]), `waggle up` runs the
//! nodes of one host or of all ([`crate::launch::up`]), and `waggle run` is the two in one on
//! one host — the same nodes with the same arguments, so the same outcome. This module owns
//! reading the file ([`load`]), composing one and binding free ports; the file's fields, parse
//! and checks are the `compose-file` library, re-exported here.

pub mod build;
pub mod place;
pub mod site;

use std::path::Path;

use anyhow::{Context, Result};

pub use compose_file::check::endpoint_parts;
pub use compose_file::{COMPOSE_VERSION, Compose, ComposeError, Node, Router, SiteRouter};

/// Reads and checks a compose file.
///
/// # Errors
///
/// When the file cannot be read, does not parse, or a check refuses it (naming the file).
pub fn load(path: &Path) -> Result<Compose> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let compose = Compose::parse(&text).with_context(|| format!("parsing {}", path.display()))?;
    compose
        .check()
        .with_context(|| format!("checking {}", path.display()))?;
    Ok(compose)
}

/// Replaces port 0 in the routers' listeners with a free port of this machine (one-host
/// sessions), so its nodes know where to dial.
///
/// # Errors
///
/// When a listener is not an endpoint, or no free port can be bound.
pub fn resolve_free_ports(compose: &mut Compose) -> Result<()> {
    let listeners = compose
        .router
        .listen
        .iter_mut()
        .chain(compose.sites.iter_mut().flat_map(|s| s.listen.iter_mut()));
    for l in listeners {
        let (address, port) = endpoint_parts(l)?;
        if port != 0 {
            continue;
        }
        // QUIC listens on UDP, everything else here on TCP.
        let free = if l.starts_with("quic/") {
            std::net::UdpSocket::bind((address.as_str(), 0))
                .and_then(|s| s.local_addr())
                .with_context(|| format!("finding a free port for {l}"))?
                .port()
        } else {
            std::net::TcpListener::bind((address.as_str(), 0))
                .and_then(|s| s.local_addr())
                .with_context(|| format!("finding a free port for {l}"))?
                .port()
        };
        let cut = l.rfind(":0").context("endpoint without port")?;
        *l = format!("{}:{free}{}", &l[..cut], &l[cut + 2..]);
    }
    Ok(())
}

#[cfg(test)]
mod tests;
