//! `waggle`: the Waggle launcher and user-facing command line. Every command line is parsed by
//! the one definition in the `commands` crate, so errors and `--help` are the same whichever
//! binary runs the command; the commands that fly the simulator are then run by `waggle-lab`
//! ([`deploy::cli::lab`]), the others by the adapters in [`deploy::cli`].

use std::ffi::OsString;

use commands::{
    Binary, Command, DataCommand, DeployCommand, InspectCommand, ShellCommand, StudiesCommand,
};
use deploy::cli;

fn main() -> anyhow::Result<()> {
    let parsed = commands::parse();
    if parsed.command.binary() == Binary::Lab {
        let args: Vec<OsString> = std::env::args_os().skip(1).collect();
        return cli::lab::run(&args);
    }
    match parsed.command {
        Command::Deploy(c) => match c {
            DeployCommand::Run(args) => cli::run::run(args),
            DeployCommand::Compose(args) => cli::compose::run(args),
            DeployCommand::Up(args) => cli::up::run(args),
            DeployCommand::Router(args) => cli::router::run(args),
            DeployCommand::Bundle(args) => cli::bundle::run(args),
            DeployCommand::Bench(args) => cli::bench::run(args),
            DeployCommand::Mission(_) | DeployCommand::Link(_) => unreachable_lab(),
        },
        Command::Inspect(c) => match c {
            InspectCommand::Audit(args) => cli::audit::run(args),
            InspectCommand::Replay(args) => cli::replay::run(args),
            InspectCommand::Report(_) => unreachable_lab(),
        },
        Command::Data(c) => match c {
            DataCommand::Export(args) => cli::export::run(args),
            DataCommand::Payload(args) => cli::payload::run(args),
            DataCommand::Allocate(args) => cli::allocate::run(args),
            DataCommand::Decode(_)
            | DataCommand::Observe(_)
            | DataCommand::Inputs(_)
            | DataCommand::Events(_)
            | DataCommand::SensorFit(_) => unreachable_lab(),
        },
        Command::Shell(c) => match c {
            ShellCommand::Completions(args) => {
                commands::shell::completions(args.shell, &mut std::io::stdout());
                Ok(())
            }
            ShellCommand::Man(args) => {
                for page in commands::shell::man_pages(&args.out)? {
                    println!("{}", page.display());
                }
                Ok(())
            }
        },
        Command::Studies(
            StudiesCommand::Trials(_)
            | StudiesCommand::Study(_)
            | StudiesCommand::Sweep(_)
            | StudiesCommand::Viewpoints(_),
        ) => unreachable_lab(),
    }
}

/// A lab command reached the launcher's dispatch: [`Command::binary`] and this match disagree.
fn unreachable_lab() -> anyhow::Result<()> {
    anyhow::bail!("internal error: a waggle-lab command was dispatched in waggle")
}
