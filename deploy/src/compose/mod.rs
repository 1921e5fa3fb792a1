//! A session as a file: which node runs on which host with which arguments, the session's
//! router and its endpoints, the injected faults and the case itself. `waggle compose` writes
//! one ([`build`]), `waggle up` runs the nodes of one host or of all ([`crate::launch::up`]),
//! and `waggle run` is the two in one on one host — the same nodes with the same arguments, so
//! the same outcome.
//!
//! The file lists only what differs between nodes; what every node of the session shares (the
//! session id, the number of observers, whether a recorder takes part, the router to dial and
//! the node's own credentials file) and the paths inside the run directory (the recorder's
//! output) are added by `waggle up` on the host that starts it.

pub mod build;
pub mod place;
pub mod site;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use node_args::{NodeCommand, NodeLine, SensorArgs};
use proto::{Modality, ObserverId, Role};
use serde::{Deserialize, Serialize};

use crate::case::Case;
use crate::fault::{ExtraFaults, Injected};

/// The compose format this build reads and writes.
pub const COMPOSE_VERSION: u32 = 1;

/// A compose file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compose {
    /// Format version ([`COMPOSE_VERSION`]).
    pub version: u32,
    /// Session id: every key lives under `waggle/<session>/`.
    pub session: String,
    /// The observers' sensor modality.
    pub modality: Modality,
    /// The case as named when composing (a built-in name or a path), for the recording.
    pub case_name: String,
    /// Every node authenticates with its own credentials and the router enforces each role's
    /// access list; `false` is an open bus, allowed only on loopback.
    pub auth: bool,
    /// A router listener on plain `tcp/` beyond loopback is accepted (authenticated, not
    /// encrypted); without it only `quic/` (mutual TLS) may listen beyond loopback.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub plain_tcp: bool,
    /// The session's credentials directory, relative to this file (authenticated sessions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub secrets: Option<PathBuf>,
    /// The case file's text (the case as flown).
    pub case: String,
    /// The session's Zenoh router (`[router]`).
    pub router: Router,
    /// Sites' own routers (a chain of two): the nodes of a site's hosts dial their site's
    /// router, which dials the session's router.
    #[serde(default, rename = "site", skip_serializing_if = "Vec::is_empty")]
    pub sites: Vec<SiteRouter>,
    #[serde(default, skip_serializing_if = "ExtraFaults::is_empty")]
    pub faults: ExtraFaults,
    /// Every node process (`[[node]]`).
    #[serde(rename = "node")]
    pub nodes: Vec<Node>,
}

/// The session's Zenoh router.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Router {
    /// The host it runs on.
    pub host: String,
    /// Endpoints it listens on; nodes on other hosts dial these, so a multi-host session needs
    /// an address they reach (e.g. `tcp/192.168.1.10:7447`). Port 0 (any free port) works only
    /// when every node runs on the router's host.
    pub listen: Vec<String>,
    /// Endpoints it connects to (another router, say); nodes on its host dial them too.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub connect: Vec<String>,
}

/// A site's router: hosted by the launcher of its host (`waggle up --host HOST`), it dials the
/// session's router as that launcher (its user and certificate) and serves the processes of its
/// host and of the hosts it `serves`, checking their passwords and access lists itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SiteRouter {
    /// The host it runs on.
    pub host: String,
    /// Endpoints it listens on; the nodes of the hosts it serves dial these.
    pub listen: Vec<String>,
    /// The other hosts whose nodes dial it (its own host's always do).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub serves: Vec<String>,
}

impl SiteRouter {
    /// Its host and the hosts it serves.
    pub fn hosts(&self) -> impl Iterator<Item = &String> {
        std::iter::once(&self.host).chain(&self.serves)
    }
}

/// One node process.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Node {
    /// Its process, written as its name (as in `summary.json`): `sim`, `scheduler`,
    /// `performer`, `recorder`, `camera-Oi`, `observer-Oi`; any other name is refused when the
    /// file is read.
    pub role: bus::Process,
    /// The host it runs on (a name of the user's choosing, given to `waggle up --host`).
    pub host: String,
    /// The node binary, looked up in the launcher's binary directory.
    pub binary: String,
    /// Its own arguments (the session-wide ones are added by `waggle up`).
    #[serde(default)]
    pub args: Vec<String>,
}

impl Node {
    /// Its command line, typed: refused (naming the node) when its binary is unknown or its
    /// arguments are not ones that binary takes.
    pub fn line(&self) -> Result<NodeLine> {
        NodeLine::parse(&self.binary, &self.args)
            .with_context(|| format!("node {}", self.role.name()))
    }
}

pub(crate) use commands::assign::check_name;

/// `proto/address:port` with a port number; the address and port.
fn endpoint_parts(endpoint: &str) -> Result<(String, u16)> {
    let bad = || {
        anyhow::anyhow!(
            "router endpoint {endpoint:?} is not PROTOCOL/ADDRESS:PORT (e.g. tcp/10.0.0.1:7447)"
        )
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
fn as_loopback(endpoint: &str) -> String {
    endpoint
        .replace("0.0.0.0", "127.0.0.1")
        .replace("[::]", "[::1]")
}

/// The listeners of `listen` other hosts can dial.
fn reachable(listen: &[String]) -> Vec<String> {
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
    /// Reads and checks a compose file.
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let compose: Compose =
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        compose
            .check()
            .with_context(|| format!("checking {}", path.display()))?;
        Ok(compose)
    }

    /// The file's text.
    pub fn to_toml(&self) -> Result<String> {
        let body = toml::to_string(self).context("writing the compose file")?;
        Ok(format!(
            "# A Waggle session: `waggle up THIS_FILE [--host NAME]` on each host \
             (see README, multi-host).\n{body}"
        ))
    }

    /// The case.
    pub fn case(&self) -> Result<Case> {
        Ok(Case::from_text(
            &self.case,
            &format!("the case of session {}", self.session),
        )?)
    }

    /// The faults the launcher injects: the case's and the file's.
    pub fn injected(&self, case: &Case) -> Result<Vec<Injected>> {
        crate::fault::injected_faults(case, &self.faults)
    }

    /// A recorder takes part.
    pub fn records(&self) -> bool {
        self.nodes.iter().any(|n| n.role.role == Role::Recorder)
    }

    /// Every host of the session (sorted): those of its nodes, the router's and the sites'.
    pub fn hosts(&self) -> Vec<String> {
        let mut hosts: BTreeSet<String> = self.nodes.iter().map(|n| n.host.clone()).collect();
        hosts.insert(self.router.host.clone());
        hosts.extend(self.sites.iter().map(|s| s.host.clone()));
        hosts.into_iter().collect()
    }

    /// The site whose router `host`'s nodes dial (none: they dial the session's router).
    pub fn site_of(&self, host: &str) -> Option<&SiteRouter> {
        self.sites.iter().find(|s| s.hosts().any(|h| h == host))
    }

    /// The site whose router runs on `host`.
    pub fn site_on(&self, host: &str) -> Option<&SiteRouter> {
        self.sites.iter().find(|s| s.host == host)
    }

    /// The host that runs the simulator: its launcher supervises the session and writes the
    /// summary.
    pub fn supervisor_host(&self) -> &str {
        self.nodes
            .iter()
            .find(|n| n.role.role == Role::Sim)
            .map_or(self.router.host.as_str(), |n| n.host.as_str())
    }

    /// The nodes placed on `host`, in file order.
    pub fn nodes_on<'a>(&'a self, host: &'a str) -> impl Iterator<Item = &'a Node> + 'a {
        self.nodes.iter().filter(move |n| n.host == host)
    }

    /// What a node on `host` dials: its site's router when a site serves it, else the
    /// session's router ([`Compose::router_dial_from`]). On a site router's own host, its
    /// listeners with the unspecified address as loopback; on the hosts it serves, those they
    /// can reach.
    pub fn dial_from(&self, host: &str) -> Vec<String> {
        match self.site_of(host) {
            Some(site) if site.host == host => site.listen.iter().map(|l| as_loopback(l)).collect(),
            Some(site) => reachable(&site.listen),
            None => self.router_dial_from(host),
        }
    }

    /// What `host` dials to reach the session's router itself (a site's router dials this): on
    /// the router's host, its listeners (the unspecified address as loopback) and its connect
    /// endpoints; elsewhere, the listeners other hosts can reach.
    pub fn router_dial_from(&self, host: &str) -> Vec<String> {
        if host == self.router.host {
            return self
                .router
                .listen
                .iter()
                .map(|l| as_loopback(l))
                .chain(self.router.connect.iter().cloned())
                .collect();
        }
        reachable(&self.router.listen)
    }

    /// The event cameras' sensor model, from the cameras' own arguments (every camera must
    /// carry the same one).
    pub fn sensor(&self) -> Result<SensorArgs> {
        let mut models = Vec::new();
        for n in &self.nodes {
            if let NodeCommand::Camera(c) = n.line()?.command {
                models.push((n.role.name(), c.sensor));
            }
        }
        let Some((first, spec)) = models.first() else {
            return Ok(SensorArgs::default());
        };
        if let Some((other, _)) = models.iter().find(|(_, m)| m != spec) {
            bail!(
                "nodes {first} and {other} carry different sensor models (--sensor-preset, \
                 --perturb, --seed): every camera of a session carries the same"
            );
        }
        Ok(spec.clone())
    }

    /// The process names this session must list: the mission's processes, and the recorder
    /// when one takes part.
    fn expected_roles(&self, observers: usize) -> Vec<String> {
        let mut out: Vec<String> = bus::mission_processes(observers, false)
            .iter()
            .map(bus::Process::name)
            .collect();
        if self.records() {
            out.push(Role::Recorder.as_str().to_string());
        }
        out
    }

    /// The user names of the session's credentials: every node, the supervising launcher and
    /// each host's launcher.
    pub fn users(&self) -> Vec<String> {
        let mut out: Vec<String> = self.nodes.iter().map(|n| n.role.name()).collect();
        out.push(Role::Launcher.as_str().to_string());
        out.extend(
            self.hosts()
                .iter()
                .map(|h| bus::Process::host_launcher(h).name()),
        );
        out
    }

    /// The credentials `host` needs: its nodes' and its launcher's.
    pub fn users_on(&self, host: &str) -> Vec<String> {
        let mut out: Vec<String> = self.nodes_on(host).map(|n| n.role.name()).collect();
        out.push(self.launcher_of(host));
        out
    }

    /// The bus name of `host`'s launcher: the supervising launcher on the simulator's host,
    /// `launcher-HOST` elsewhere. A site's router is its host's launcher on the bus.
    pub fn launcher_of(&self, host: &str) -> String {
        if host == self.supervisor_host() {
            Role::Launcher.as_str().to_string()
        } else {
            bus::Process::host_launcher(host).name()
        }
    }

    /// Checks every field, naming the bad one.
    pub fn check(&self) -> Result<()> {
        if self.version != COMPOSE_VERSION {
            bail!(
                "version = {}: this waggle reads compose version {COMPOSE_VERSION}",
                self.version
            );
        }
        proto::Keys::new(&self.session).with_context(|| format!("session {:?}", self.session))?;
        let case = self.case()?;
        crate::case::run_modality(&case, Some(self.modality))?;
        self.injected(&case)?;
        self.check_nodes(&case)?;
        self.sensor()?.check(self.modality)?;
        self.check_router()?;
        self.check_sites()?;
        if self.auth {
            if self.secrets.is_none() {
                bail!("auth = true needs secrets = DIR (written by `waggle compose`)");
            }
            let plain: Vec<&String> = self
                .router
                .listen
                .iter()
                .chain(self.sites.iter().flat_map(|s| &s.listen))
                .filter(|l| l.starts_with("tcp/") && !bus::is_loopback_endpoint(l))
                .collect();
            if !plain.is_empty() && !self.plain_tcp {
                bail!(
                    "a router would listen on plain TCP beyond loopback ({}): the bus would \
                     cross the network unencrypted. Listen on quic/ instead (mutual TLS with the \
                     session's certificates, e.g. --router quic/192.168.1.10:7447), or accept \
                     it explicitly with --plain-tcp (plain_tcp = true)",
                    plain
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        } else if !self
            .router
            .listen
            .iter()
            .all(|l| bus::is_loopback_endpoint(l))
        {
            bail!(
                "auth = false with a router listening beyond loopback ({}) would open the \
                 session to the network",
                self.router.listen.join(", ")
            );
        } else if !self.sites.is_empty() {
            bail!(
                "auth = false with sites' routers: a chain of routers crosses hosts, so it authenticates"
            );
        }
        Ok(())
    }

    fn check_nodes(&self, case: &Case) -> Result<()> {
        let expected = self.expected_roles(case.observers);
        let mut seen = BTreeSet::new();
        for n in &self.nodes {
            check_name("host", &n.host)?;
            let name = n.role.name();
            if !expected.contains(&name) {
                bail!(
                    "node {:?} is not a process of this session (a case with {} observers has: {})",
                    name,
                    case.observers,
                    expected.join(", ")
                );
            }
            if !seen.insert(name.clone()) {
                bail!("node {name:?} is listed twice");
            }
            if n.binary.is_empty() || n.binary.contains('/') || n.binary.starts_with('.') {
                bail!(
                    "node {name}: binary {:?} must be a file name in the binary directory",
                    n.binary
                );
            }
            n.line()?;
        }
        if let Some(missing) = expected.iter().find(|r| !seen.contains(r.as_str())) {
            bail!("no node runs {missing}");
        }
        for f in self.injected(case)? {
            ObserverId::new(f.observer().as_str())?;
        }
        Ok(())
    }

    fn check_router(&self) -> Result<()> {
        check_name("router host", &self.router.host)?;
        if self.router.listen.is_empty() {
            bail!("router.listen is empty: the router must listen somewhere");
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
            bail!(
                "hosts {} run nodes but the router (on {}) listens only on {}: give it an \
                 address they reach, e.g. --router quic/192.168.1.10:7447",
                remote.join(", "),
                self.router.host,
                self.router.listen.join(", ")
            );
        }
        if let Some(any) = self
            .router
            .listen
            .iter()
            .find(|l| endpoint_parts(l).is_ok_and(|(_, p)| p == 0))
        {
            bail!("router endpoint {any}: port 0 works only when every node runs on one host");
        }
        Ok(())
    }

    /// Each site's router: on a host of its own (not the session router's, not another
    /// site's), listening where its hosts reach it, serving hosts that run nodes and belong to
    /// no other site, and able to reach the session's router.
    fn check_sites(&self) -> Result<()> {
        let node_hosts: BTreeSet<&str> = self.nodes.iter().map(|n| n.host.as_str()).collect();
        let mut served = BTreeSet::new();
        for site in &self.sites {
            check_name("site router host", &site.host)?;
            let what = format!("the site router on {}", site.host);
            if site.host == self.router.host {
                bail!("{what}: the session's router runs on {} already", site.host);
            }
            if site.listen.is_empty() {
                bail!("{what} listens nowhere: give it an endpoint its hosts reach");
            }
            for e in &site.listen {
                let (_, port) = endpoint_parts(e).with_context(|| what.clone())?;
                if port == 0 {
                    bail!(
                        "{what}: endpoint {e}: port 0 works only when every node runs on one host"
                    );
                }
            }
            for h in site.hosts() {
                check_name("host", h)?;
                if !served.insert(h.clone()) {
                    bail!("host {h} is in two sites (or serves its own site twice)");
                }
            }
            for h in &site.serves {
                if *h == self.router.host {
                    bail!("{what} cannot serve {h}: the session's router runs there");
                }
                if !node_hosts.contains(h.as_str()) {
                    bail!("{what} serves {h}, which runs no node");
                }
            }
            if !site.serves.is_empty() && reachable(&site.listen).is_empty() {
                bail!(
                    "{what} serves {} but listens only on {}: give it an address they reach",
                    site.serves.join(", "),
                    site.listen.join(", ")
                );
            }
            if self.router_dial_from(&site.host).is_empty() {
                bail!(
                    "{what} cannot reach the session's router (it listens only on {})",
                    self.router.listen.join(", ")
                );
            }
        }
        Ok(())
    }

    /// Replaces port 0 in the routers' listeners with a free port of this machine (one-host
    /// sessions), so its nodes know where to dial.
    pub fn resolve_free_ports(&mut self) -> Result<()> {
        let listeners = self
            .router
            .listen
            .iter_mut()
            .chain(self.sites.iter_mut().flat_map(|s| s.listen.iter_mut()));
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

    /// The secrets directory, resolved against the compose file's directory.
    pub fn secrets_dir(&self, compose_file: &Path) -> Option<PathBuf> {
        let dir = self.secrets.as_ref()?;
        Some(match compose_file.parent() {
            Some(p) if dir.is_relative() => p.join(dir),
            _ => dir.clone(),
        })
    }
}

#[cfg(test)]
mod tests;
