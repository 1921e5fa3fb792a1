//! One node of a session: its binary and its own arguments, typed.

use clap::{Parser, Subcommand};

use crate::{CameraArgs, ObserverArgs, PerformerArgs, RecorderArgs, SchedulerArgs};

/// Why a node's arguments were refused.
#[derive(Debug, thiserror::Error)]
pub enum NodeArgsError {
    #[error(
        "unknown node binary {0:?} (expected sim-node, scheduler-node, performer-node, observer-node or recorder-node)"
    )]
    UnknownBinary(String),
    #[error("{binary} {args}: {message}")]
    Parse {
        binary: String,
        args: String,
        message: String,
    },
    #[error("the event sensor's model: {0}")]
    Sensor(String),
}

/// A node process of a session and its own arguments (the session-wide ones are added by the
/// launcher).
#[derive(Debug, Clone, PartialEq)]
pub enum NodeCommand {
    /// `sim-node run`: physics and the clock.
    Sim,
    Scheduler(SchedulerArgs),
    /// `performer-node`.
    Performer(PerformerArgs),
    /// `sim-node camera …`: one observer's camera.
    Camera(CameraArgs),
    Observer(ObserverArgs),
    Recorder(RecorderArgs),
}

impl NodeCommand {
    /// The binary that runs it.
    pub fn binary(&self) -> &'static str {
        match self {
            NodeCommand::Sim | NodeCommand::Camera(_) => "sim-node",
            NodeCommand::Scheduler(_) => "scheduler-node",
            NodeCommand::Performer(_) => "performer-node",
            NodeCommand::Observer(_) => "observer-node",
            NodeCommand::Recorder(_) => "recorder-node",
        }
    }

    /// Its own arguments (subcommand first for `sim-node`).
    pub fn to_args(&self) -> Vec<String> {
        match self {
            NodeCommand::Sim => vec!["run".into()],
            NodeCommand::Camera(c) => std::iter::once("camera".to_string())
                .chain(c.to_args())
                .collect(),
            NodeCommand::Scheduler(s) => s.to_args(),
            NodeCommand::Performer(p) => p.to_args(),
            NodeCommand::Observer(o) => o.to_args(),
            NodeCommand::Recorder(r) => r.to_args(),
        }
    }
}

/// One line of a compose file: a node's command and the access-control list it must hold from
/// its first message (`--deny KEYEXPR`, a session-wide option of `bus::NodeArgs` that the composer
/// decides per node).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeLine {
    pub command: NodeCommand,
    /// Key expressions the node's links deny.
    pub deny: Vec<String>,
}

impl NodeLine {
    /// A node with no access-control list of its own.
    pub fn new(command: NodeCommand) -> Self {
        Self {
            command,
            deny: Vec::new(),
        }
    }

    /// The binary that runs it.
    pub fn binary(&self) -> &'static str {
        self.command.binary()
    }

    /// Its arguments: the command's own, then `--deny KEYEXPR` for each denied key.
    pub fn to_args(&self) -> Vec<String> {
        let mut a = self.command.to_args();
        for key in &self.deny {
            a.extend(["--deny".to_string(), key.clone()]);
        }
        a
    }

    /// The node `binary` runs with `args` (its own arguments and `--deny`), refusing unknown
    /// binaries and arguments its parser would refuse, with clap's message.
    pub fn parse(binary: &str, args: &[String]) -> Result<Self, NodeArgsError> {
        let fail = |e: clap::Error| NodeArgsError::Parse {
            binary: binary.to_string(),
            args: args.join(" "),
            // clap's message up to its usage hint, on one line.
            message: e
                .to_string()
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(" "),
        };
        let argv = std::iter::once(binary).chain(args.iter().map(String::as_str));
        fn own<T: clap::Args>(
            argv: impl Iterator<Item = impl Into<std::ffi::OsString> + Clone>,
        ) -> Result<(T, Vec<String>), clap::Error> {
            Own::<T>::try_parse_from(argv).map(|o| (o.own, o.deny))
        }
        let (command, deny) = match binary {
            "sim-node" => {
                let cli = SimCli::try_parse_from(argv).map_err(fail)?;
                let command = match cli.command {
                    SimCommand::Run(o) => {
                        return Ok(Self {
                            command: NodeCommand::Sim,
                            deny: o.deny,
                        });
                    }
                    SimCommand::Camera(c) => *c,
                };
                (NodeCommand::Camera(command.own), command.deny)
            }
            "scheduler-node" => {
                let (a, d) = own::<SchedulerArgs>(argv).map_err(fail)?;
                (NodeCommand::Scheduler(a), d)
            }
            "performer-node" => {
                let (a, d) = own::<PerformerArgs>(argv).map_err(fail)?;
                (NodeCommand::Performer(a), d)
            }
            "observer-node" => {
                let (a, d) = own::<ObserverArgs>(argv).map_err(fail)?;
                (NodeCommand::Observer(a), d)
            }
            "recorder-node" => {
                let (a, d) = own::<RecorderArgs>(argv).map_err(fail)?;
                (NodeCommand::Recorder(a), d)
            }
            other => return Err(NodeArgsError::UnknownBinary(other.to_string())),
        };
        Ok(Self { command, deny })
    }
}

/// A node's own arguments and its `--deny` list (what a compose file stores).
#[derive(Parser)]
struct Own<T: clap::Args> {
    #[command(flatten)]
    own: T,
    #[arg(long = "deny")]
    deny: Vec<String>,
}

#[derive(Parser)]
struct SimCli {
    #[command(subcommand)]
    command: SimCommand,
}

#[derive(Subcommand)]
enum SimCommand {
    Run(Deny),
    Camera(Box<OwnCamera>),
}

#[derive(clap::Args)]
struct Deny {
    #[arg(long = "deny")]
    deny: Vec<String>,
}

#[derive(clap::Args)]
struct OwnCamera {
    #[command(flatten)]
    own: CameraArgs,
    #[arg(long = "deny")]
    deny: Vec<String>,
}
