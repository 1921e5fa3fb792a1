//! `compose-file`: a session as a file, typed — which node runs on which host with which
//! arguments, the session's router and its endpoints, the injected faults and the case itself.
//! This crate owns the file's fields, its parse and print ([`Compose::from_toml`],
//! [`Compose::to_toml`]) and every check that needs no file system or network ([`check`]), so
//! the launcher and the fuzz targets read a compose file alike. `deploy` reads the file, writes
//! one (`waggle compose`), resolves free ports and launches.
//!
//! The file lists only what differs between nodes; what every node of the session shares (the
//! session id, the number of observers, whether a recorder takes part, the router to dial and
//! the node's own credentials file) and the paths inside the run directory (the recorder's
//! output) are added by `waggle up` on the host that starts it.
//!
//! Errors are typed ([`ComposeError`], [`fault::FaultError`]) and name the field at fault.

#![forbid(unsafe_code)]

pub mod check;
pub mod fault;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use node_args::{NodeArgsError, NodeCommand, NodeLine, SensorArgs};
use proto::{KeyError, Modality, Role};
use run_format::case::{Case, CaseError};
use serde::{Deserialize, Serialize};

use crate::check::{as_loopback, reachable};
use crate::fault::{ExtraFaults, FaultError, Injected};

/// The compose format this build reads and writes.
pub const COMPOSE_VERSION: u32 = 1;

/// Why a compose file is refused. Each layer's text names where the input went wrong; what it
/// wraps says why (printed as a chain, as `anyhow` does).
#[derive(Debug, thiserror::Error)]
pub enum ComposeError {
    /// Not TOML, or not of a compose file's shape.
    #[error(transparent)]
    Parse(#[from] toml::de::Error),
    /// The file could not be printed.
    #[error("writing the compose file")]
    Print(#[source] toml::ser::Error),
    /// The session id is not one a key can carry.
    #[error("session {session:?}")]
    Session {
        session: String,
        #[source]
        source: KeyError,
    },
    /// The case's text, or the case for this modality.
    #[error(transparent)]
    Case(#[from] CaseError),
    /// The faults to inject.
    #[error(transparent)]
    Fault(#[from] FaultError),
    /// A fault names an observer that is not a valid id.
    #[error(transparent)]
    Observer(#[from] KeyError),
    /// A node's command line.
    #[error("node {node}")]
    Node {
        node: String,
        #[source]
        source: NodeArgsError,
    },
    /// The cameras' sensor model for the session's modality.
    #[error(transparent)]
    Sensor(#[from] NodeArgsError),
    /// A site's router.
    #[error("{site}")]
    Site {
        site: String,
        #[source]
        source: Box<ComposeError>,
    },
    /// A field's value; the text names the field and what is wrong.
    #[error("{0}")]
    Refused(String),
}

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
    /// Its command line, typed.
    ///
    /// # Errors
    ///
    /// Naming the node, when its binary is unknown or its arguments are not ones that binary
    /// takes.
    pub fn line(&self) -> Result<NodeLine, ComposeError> {
        NodeLine::parse(&self.binary, &self.args).map_err(|source| ComposeError::Node {
            node: self.role.name(),
            source,
        })
    }
}

impl Compose {
    /// A compose file's text, parsed (its shape and each field's type) but not checked.
    ///
    /// # Errors
    ///
    /// When the text is not TOML of a compose file's shape.
    pub fn parse(text: &str) -> Result<Self, toml::de::Error> {
        toml::from_str(text)
    }

    /// A compose file's text, parsed and checked ([`Compose::check`]).
    ///
    /// # Errors
    ///
    /// As [`Compose::parse`] and [`Compose::check`].
    pub fn from_toml(text: &str) -> Result<Self, ComposeError> {
        let compose = Self::parse(text)?;
        compose.check()?;
        Ok(compose)
    }

    /// The file's text.
    ///
    /// # Errors
    ///
    /// When a field cannot be printed as TOML.
    pub fn to_toml(&self) -> Result<String, ComposeError> {
        let body = toml::to_string(self).map_err(ComposeError::Print)?;
        Ok(format!(
            "# A Waggle session: `waggle up THIS_FILE [--host NAME]` on each host \
             (see README, multi-host).\n{body}"
        ))
    }

    /// The case.
    ///
    /// # Errors
    ///
    /// When the case's text is not a valid case.
    pub fn case(&self) -> Result<Case, ComposeError> {
        Ok(Case::from_text(
            &self.case,
            &format!("the case of session {}", self.session),
        )?)
    }

    /// The faults the launcher injects: the case's and the file's.
    ///
    /// # Errors
    ///
    /// When a fault names an observer the case does not have.
    pub fn injected(&self, case: &Case) -> Result<Vec<Injected>, FaultError> {
        fault::injected_faults(case, &self.faults)
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
    ///
    /// # Errors
    ///
    /// When a node's command line does not parse, or two cameras carry different models.
    pub fn sensor(&self) -> Result<SensorArgs, ComposeError> {
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
            return Err(ComposeError::Refused(format!(
                "nodes {first} and {other} carry different sensor models (--sensor-preset, \
                 --perturb, --seed): every camera of a session carries the same"
            )));
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

    /// The secrets directory, resolved against the compose file's directory (a path
    /// computation: nothing is read).
    pub fn secrets_dir(&self, compose_file: &Path) -> Option<PathBuf> {
        let dir = self.secrets.as_ref()?;
        Some(match compose_file.parent() {
            Some(p) if dir.is_relative() => p.join(dir),
            _ => dir.clone(),
        })
    }
}
