//! The checks of a compose file that need neither file system nor network: its version and
//! session id, its case and faults, every node's name, host, binary and arguments, the routers'
//! endpoints, who can reach whom, and what an open (`auth = false`) or plain-TCP bus may
//! expose. Each refusal names the field at fault.

use std::collections::BTreeSet;

use proto::ObserverId;
use run_format::case::{Case, run_modality};

use crate::{COMPOSE_VERSION, Compose, ComposeError};

/// A refusal naming the field at fault.
fn refuse<T>(why: String) -> Result<T, ComposeError> {
    Err(ComposeError::Refused(why))
}

/// A host or role name: it becomes part of a user name and a key.
fn check_name(what: &str, name: &str) -> Result<(), ComposeError> {
    // The launcher's option parsing checks names with the same function, so a file and a
    // command line refuse the same names with the same words.
    commands::assign::check_name(what, name).map_err(|e| ComposeError::Refused(e.to_string()))
}

/// `proto/address:port` with a port number; the address and port.
///
/// # Errors
///
/// When `endpoint` is not of that shape, naming it.
pub fn endpoint_parts(endpoint: &str) -> Result<(String, u16), ComposeError> {
    let bad = || {
        ComposeError::Refused(format!(
            "router endpoint {endpoint:?} is not PROTOCOL/ADDRESS:PORT (e.g. tcp/10.0.0.1:7447)"
        ))
    };
    let (_, locator) = endpoint.split_once('/').ok_or_else(bad)?;
    let locator = locator.split(['#', '?']).next().unwrap_or("");
    let (address, port) = locator.rsplit_once(':').ok_or_else(bad)?;
    let port = port.parse::<u16>().map_err(|_| bad())?;
    if address.is_empty() {
        return Err(bad());
    }
    Ok((address.trim_matches(['[', ']']).to_string(), port))
}

/// `endpoint` as dialled on its own host: the unspecified address as loopback.
pub(crate) fn as_loopback(endpoint: &str) -> String {
    endpoint
        .replace("0.0.0.0", "127.0.0.1")
        .replace("[::]", "[::1]")
}

/// The listeners of `listen` other hosts can dial.
pub(crate) fn reachable(listen: &[String]) -> Vec<String> {
    listen.iter().filter(|l| !local_only(l)).cloned().collect()
}

/// True for an endpoint other hosts cannot dial: loopback or the unspecified address.
fn local_only(endpoint: &str) -> bool {
    bus::is_loopback_endpoint(endpoint)
        || endpoint_parts(endpoint).is_ok_and(|(a, _)| {
            a.parse::<std::net::IpAddr>()
                .is_ok_and(|ip| ip.is_unspecified())
        })
}

impl Compose {
    /// Checks every field, naming the bad one.
    ///
    /// # Errors
    ///
    /// The first field found at fault, with what is wrong with it.
    pub fn check(&self) -> Result<(), ComposeError> {
        if self.version != COMPOSE_VERSION {
            return refuse(format!(
                "version = {}: this waggle reads compose version {COMPOSE_VERSION}",
                self.version
            ));
        }
        proto::Keys::new(&self.session).map_err(|source| ComposeError::Session {
            session: self.session.clone(),
            source,
        })?;
        let case = self.case()?;
        run_modality(&case, Some(self.modality))?;
        self.injected(&case)?;
        self.check_nodes(&case)?;
        self.sensor()?.check(self.modality)?;
        self.check_router()?;
        self.check_sites()?;
        self.check_exposure()
    }

    /// An authenticated bus crosses the network encrypted unless plain TCP is asked for; an
    /// open one stays on loopback.
    fn check_exposure(&self) -> Result<(), ComposeError> {
        if self.auth {
            if self.secrets.is_none() {
                return refuse(
                    "auth = true needs secrets = DIR (written by `waggle compose`)".to_string(),
                );
            }
            let plain: Vec<&str> = self
                .router
                .listen
                .iter()
                .chain(self.sites.iter().flat_map(|s| &s.listen))
                .filter(|l| l.starts_with("tcp/") && !bus::is_loopback_endpoint(l))
                .map(String::as_str)
                .collect();
            if !plain.is_empty() && !self.plain_tcp {
                return refuse(format!(
                    "a router would listen on plain TCP beyond loopback ({}): the bus would \
                     cross the network unencrypted. Listen on quic/ instead (mutual TLS with the \
                     session's certificates, e.g. --router quic/192.168.1.10:7447), or accept \
                     it explicitly with --plain-tcp (plain_tcp = true)",
                    plain.join(", ")
                ));
            }
        } else if !self
            .router
            .listen
            .iter()
            .all(|l| bus::is_loopback_endpoint(l))
        {
            return refuse(format!(
                "auth = false with a router listening beyond loopback ({}) would open the \
                 session to the network",
                self.router.listen.join(", ")
            ));
        } else if !self.sites.is_empty() {
            return refuse(
                "auth = false with sites' routers: a chain of routers crosses hosts, so it \
                 authenticates"
                    .to_string(),
            );
        }
        Ok(())
    }

    fn check_nodes(&self, case: &Case) -> Result<(), ComposeError> {
        let expected = self.expected_roles(case.observers);
        let mut seen = BTreeSet::new();
        for n in &self.nodes {
            check_name("host", &n.host)?;
            let name = n.role.name();
            if !expected.contains(&name) {
                return refuse(format!(
                    "node {:?} is not a process of this session (a case with {} observers has: {})",
                    name,
                    case.observers,
                    expected.join(", ")
                ));
            }
            if !seen.insert(name.clone()) {
                return refuse(format!("node {name:?} is listed twice"));
            }
            if n.binary.is_empty() || n.binary.contains('/') || n.binary.starts_with('.') {
                return refuse(format!(
                    "node {name}: binary {:?} must be a file name in the binary directory",
                    n.binary
                ));
            }
            n.line()?;
        }
        if let Some(missing) = expected.iter().find(|r| !seen.contains(r.as_str())) {
            return refuse(format!("no node runs {missing}"));
        }
        for f in self.injected(case)? {
            ObserverId::new(f.observer().as_str())?;
        }
        Ok(())
    }

    fn check_router(&self) -> Result<(), ComposeError> {
        check_name("router host", &self.router.host)?;
        if self.router.listen.is_empty() {
            return refuse("router.listen is empty: the router must listen somewhere".to_string());
        }
        for e in self.router.listen.iter().chain(&self.router.connect) {
            endpoint_parts(e)?;
        }
        let remote: Vec<String> = self
            .hosts()
            .into_iter()
            .filter(|h| *h != self.router.host)
            .collect();
        if remote.is_empty() {
            return Ok(());
        }
        if self.router_dial_from(&remote[0]).is_empty() {
            return refuse(format!(
                "hosts {} run nodes but the router (on {}) listens only on {}: give it an \
                 address they reach, e.g. --router quic/192.168.1.10:7447",
                remote.join(", "),
                self.router.host,
                self.router.listen.join(", ")
            ));
        }
        if let Some(any) = self
            .router
            .listen
            .iter()
            .find(|l| endpoint_parts(l).is_ok_and(|(_, p)| p == 0))
        {
            return refuse(format!(
                "router endpoint {any}: port 0 works only when every node runs on one host"
            ));
        }
        Ok(())
    }

    /// Each site's router: on a host of its own (not the session router's, not another
    /// site's), listening where its hosts reach it, serving hosts that run nodes and belong to
    /// no other site, and able to reach the session's router.
    fn check_sites(&self) -> Result<(), ComposeError> {
        let node_hosts: BTreeSet<&str> = self.nodes.iter().map(|n| n.host.as_str()).collect();
        let mut served = BTreeSet::new();
        for site in &self.sites {
            check_name("site router host", &site.host)?;
            let what = format!("the site router on {}", site.host);
            if site.host == self.router.host {
                return refuse(format!(
                    "{what}: the session's router runs on {} already",
                    site.host
                ));
            }
            if site.listen.is_empty() {
                return refuse(format!(
                    "{what} listens nowhere: give it an endpoint its hosts reach"
                ));
            }
            for e in &site.listen {
                let (_, port) = endpoint_parts(e).map_err(|source| ComposeError::Site {
                    site: what.clone(),
                    source: Box::new(source),
                })?;
                if port == 0 {
                    return refuse(format!(
                        "{what}: endpoint {e}: port 0 works only when every node runs on one host"
                    ));
                }
            }
            for h in site.hosts() {
                check_name("host", h)?;
                if !served.insert(h.clone()) {
                    return refuse(format!(
                        "host {h} is in two sites (or serves its own site twice)"
                    ));
                }
            }
            for h in &site.serves {
                if *h == self.router.host {
                    return refuse(format!(
                        "{what} cannot serve {h}: the session's router runs there"
                    ));
                }
                if !node_hosts.contains(h.as_str()) {
                    return refuse(format!("{what} serves {h}, which runs no node"));
                }
            }
            if !site.serves.is_empty() && reachable(&site.listen).is_empty() {
                return refuse(format!(
                    "{what} serves {} but listens only on {}: give it an address they reach",
                    site.serves.join(", "),
                    site.listen.join(", ")
                ));
            }
            if self.router_dial_from(&site.host).is_empty() {
                return refuse(format!(
                    "{what} cannot reach the session's router (it listens only on {})",
                    self.router.listen.join(", ")
                ));
            }
        }
        Ok(())
    }
}
