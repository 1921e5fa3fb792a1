//! Command-line options every Waggle node shares.

use std::time::Duration;

use crate::auth::Credentials;
use crate::bus::Bus;
use crate::endpoints::Endpoints;
use crate::endpoints::{client_config, deny_on_every_link, open_client_config};
use crate::error::BusError;
use crate::handshake::{self, Process, mission_processes};

/// Options of every node process.
#[derive(Debug, Clone, PartialEq, clap::Args)]
pub struct NodeArgs {
    /// Session (run) id: every key lives under `waggle/<session>/`.
    #[arg(long)]
    pub session: String,
    /// Number of observers in the mission.
    #[arg(long, default_value_t = 3)]
    pub observers: usize,
    /// No launcher takes part (processes started by hand): nobody waits for it.
    #[arg(long)]
    pub standalone: bool,
    /// A recorder (`recorder-node`) takes part in the start-up handshake: the clock starts only
    /// once it is ready, so it records from tick 0.
    #[arg(long)]
    pub recorder: bool,
    /// How long to wait for every process of the session at start-up, seconds.
    #[arg(long, default_value_t = 120.0)]
    pub startup_timeout_s: f64,
    /// Key expression this process's links must deny (Zenoh access control); repeatable.
    #[arg(long = "deny", value_name = "KEYEXPR")]
    pub deny: Vec<String>,
    /// Join as a client of the session's router (the launcher's) instead of as a peer.
    #[arg(long)]
    pub client: bool,
    /// File holding this process's `user:password` for the session's router (implies
    /// `--client`). The launcher writes one per process, readable only by its user.
    #[arg(long, value_name = "FILE")]
    pub credentials: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub endpoints: Endpoints,
}

impl Bus {
    /// Opens the session of a node process from its command-line options: a client of the
    /// session's router (authenticated with `--credentials` when given), or a peer with its
    /// `--deny` access-control list.
    pub fn open_node(node: &NodeArgs) -> Result<Self, BusError> {
        let mut config = match &node.credentials {
            Some(path) => client_config(&node.endpoints, &Credentials::read(path)?)?,
            None if node.client => open_client_config(&node.endpoints)?,
            None => return Self::open_with_acl(&node.session, &node.endpoints, &node.deny),
        };
        deny_on_every_link(&mut config, &node.deny)?;
        Self::open_config(&node.session, config)
    }
}

impl NodeArgs {
    /// Every process of the session.
    pub fn processes(&self) -> Vec<Process> {
        let mut out = mission_processes(self.observers, !self.standalone);
        if self.recorder {
            out.push(Process::singleton(proto::Role::Recorder));
        }
        out
    }

    pub fn startup_timeout(&self) -> Duration {
        Duration::from_secs_f64(self.startup_timeout_s.clamp(0.0, 86_400.0))
    }

    /// Runs the start-up handshake as `me`, waiting for every process of this session.
    pub fn join(&self, bus: &mut Bus, me: &Process) -> Result<(), BusError> {
        handshake::join(bus, me, &self.processes(), self.startup_timeout())
    }

    /// The arguments that reproduce these options in a child process.
    pub fn to_args(&self) -> Vec<String> {
        let mut out = vec![
            "--session".to_string(),
            self.session.clone(),
            "--observers".to_string(),
            self.observers.to_string(),
            "--startup-timeout-s".to_string(),
            self.startup_timeout_s.to_string(),
        ];
        if self.standalone {
            out.push("--standalone".into());
        }
        if self.recorder {
            out.push("--recorder".into());
        }
        for d in &self.deny {
            out.push("--deny".into());
            out.push(d.clone());
        }
        if self.client {
            out.push("--client".into());
        }
        if let Some(c) = &self.credentials {
            out.push("--credentials".into());
            out.push(c.display().to_string());
        }
        out.extend(self.endpoints.to_args());
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        node: NodeArgs,
    }

    #[test]
    fn node_arguments_survive_a_round_trip_through_a_child_command_line() {
        let node = NodeArgs {
            session: "run-1".into(),
            observers: 2,
            standalone: true,
            recorder: false,
            startup_timeout_s: 30.0,
            deny: vec!["waggle/run-1/sim/**".into()],
            client: true,
            credentials: Some("/tmp/x/sim.credentials".into()),
            endpoints: Endpoints {
                connect: vec!["tcp/127.0.0.1:7000".into()],
                listen: vec![],
            },
        };
        let mut argv = vec!["x".to_string()];
        argv.extend(node.to_args());
        assert_eq!(Cli::parse_from(argv).node, node);
        assert_eq!(node.processes().len(), 3 + 4);
        let recorded = NodeArgs {
            recorder: true,
            ..node
        };
        let mut argv = vec!["x".to_string()];
        argv.extend(recorded.to_args());
        assert_eq!(Cli::parse_from(argv).node, recorded);
        assert!(
            recorded
                .processes()
                .contains(&Process::singleton(proto::Role::Recorder))
        );
    }
}
