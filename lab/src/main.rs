//! `waggle-lab`: the lab commands of `waggle` (the ones that fly the simulator). `waggle
//! LABCMD ARGS…` runs `waggle-lab LABCMD ARGS…` (`deploy::cli::lab`); both parse with the one
//! definition in the `commands` crate, so this binary calls itself `waggle` in its help and
//! errors: its users type `waggle`.

use anyhow::bail;
use commands::{Binary, Command, DataCommand, DeployCommand, InspectCommand, StudiesCommand};
use lab::cli;

fn main() -> anyhow::Result<()> {
    let parsed = commands::parse();
    if parsed.command.binary() != Binary::Lab {
        let name = std::env::args().nth(1).unwrap_or_default();
        bail!("`waggle {name}` runs in the waggle binary, not waggle-lab: type `waggle {name}`");
    }
    match parsed.command {
        Command::Deploy(DeployCommand::Link(args)) => cli::link::run(args),
        Command::Deploy(DeployCommand::Mission(args)) => cli::mission::run(args),
        Command::Data(DataCommand::Decode(args)) => cli::decode::run(args),
        Command::Data(DataCommand::Observe(args)) => cli::observe::run(args),
        Command::Data(DataCommand::Inputs(args)) => cli::inputs::run(args),
        Command::Data(DataCommand::Events(args)) => cli::events::run(args),
        Command::Data(DataCommand::SensorFit(args)) => cli::sensor_fit::run(args),
        Command::Studies(StudiesCommand::Sweep(args)) => cli::sweep::run(args),
        Command::Studies(StudiesCommand::Viewpoints(args)) => cli::viewpoints::run(args),
        Command::Studies(StudiesCommand::Trials(args)) => cli::trials::run(args),
        Command::Studies(StudiesCommand::Study(args)) => cli::study::run(args),
        Command::Inspect(InspectCommand::Report(args)) => cli::report::run(args),
        Command::Deploy(_) | Command::Inspect(_) | Command::Data(_) | Command::Shell(_) => {
            bail!("internal error: a waggle command was dispatched in waggle-lab")
        }
    }
}
