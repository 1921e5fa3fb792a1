//! `waggle`: the Waggle launcher and user-facing command line (the adapters and the library
//! are in the `deploy` crate). The lab commands are listed here and run by `waggle-lab`
//! ([`deploy::cli::lab`]): their arguments are forwarded before anything is parsed.

use std::ffi::OsString;

use clap::Parser;
use deploy::cli;
use deploy::cli::lab::LabArgs;

#[derive(Parser)]
#[command(
    name = "waggle",
    version,
    about = "Waggle: motion-mediated drone recruitment"
)]
enum Cli {
    /// Decode or encode a six-bit task offer.
    Payload(cli::payload::PayloadArgs),
    /// Run the local allocation policy on a set of offers.
    Allocate(cli::allocate::AllocateArgs),
    /// Fly a broadcast in one process and decode it with each observer's receiver.
    Link(LabArgs),
    /// Fly a whole case (physics, cameras, performer, observers, scheduler) in one process.
    Mission(LabArgs),
    /// Run a whole case as separate processes over Zenoh (simulator, cameras, performer,
    /// observers, scheduler), supervised, with a progress bar and a summary.
    Run(cli::run::RunArgs),
    /// Write a session's compose file: every node with its arguments, placed on hosts
    /// (`--place camera-*=b`), the router's endpoint and the session's credentials.
    Compose(cli::compose::ComposeArgs),
    /// Start and supervise the nodes a compose file places on this host (`--host NAME`; every
    /// node without it). The simulator's host writes the summary.
    Up(cli::up::UpArgs),
    /// Serve a session's Zenoh router on its own (authenticated from its compose file).
    Router(cli::router::RouterArgs),
    /// Write what one host of a session needs (the compose file and only that host's
    /// credentials) into a new directory, to copy to that host.
    Bundle(cli::bundle::BundleArgs),
    /// Run a case once per camera render path (`--paths`; default MuJoCo's damage path and
    /// Waggle's renderer) in one invocation and print wall/sim, camera CPU per simulated second
    /// and their ratio side by side.
    Bench(cli::bench::BenchArgs),
    /// Decode a camera's recording (EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4, a ROS 2 bag, PNG frames)
    /// with one observer's receiver: tokens, frames and payloads.
    Decode(LabArgs),
    /// Synthetic event camera tools (convert PNG frames into events).
    Events(LabArgs),
    /// Run every case × modality (`waggle run` each), audit each and write DIR/report.md with
    /// the paper's tables and the figures; exit 1 if any run misses its expected outcome.
    Sweep(LabArgs),
    /// Measure decode success against viewing angle and distance: observers placed at each
    /// viewpoint, one flight per group of up to eight, per receiver and rectification.
    Viewpoints(LabArgs),
    /// One condition, N seeded trials under a perturbation: success rate with its Wilson 95 %
    /// interval and per-trial measurements in DIR/trials.json.
    Trials(LabArgs),
    /// Run a study (conditions × levels × modalities as seeded trials) and write DIR/report.md
    /// with success probabilities, their 95 % intervals and a figure.
    Study(LabArgs),
    /// Rebuild report.md and its figures from a run or sweep directory, without re-running.
    Report(LabArgs),
    /// Re-run the event receivers from a recording's raw event packets and session controls
    /// and compare with the live decodes.
    Replay(cli::replay::ReplayArgs),
    /// The paper's tables, provenance audit and expected outcome from a recording alone.
    Audit(cli::audit::AuditArgs),
    /// Export a run's recording for other tools: `export ros2 RUN_DIR --out BAG_DIR` writes a
    /// ROS 2 bag (rosbag2 of ROS 2 Jazzy, MCAP storage).
    Export(cli::export::ExportArgs),
}

fn main() -> anyhow::Result<()> {
    let args: Vec<OsString> = std::env::args_os().skip(1).collect();
    if cli::lab::lab_command(&args).is_some() {
        return cli::lab::run(&args);
    }
    match Cli::parse() {
        Cli::Payload(args) => cli::payload::run(args),
        Cli::Allocate(args) => cli::allocate::run(args),
        Cli::Run(args) => cli::run::run(args),
        Cli::Compose(args) => cli::compose::run(args),
        Cli::Up(args) => cli::up::run(args),
        Cli::Router(args) => cli::router::run(args),
        Cli::Bundle(args) => cli::bundle::run(args),
        Cli::Bench(args) => cli::bench::run(args),
        Cli::Replay(args) => cli::replay::run(args),
        Cli::Audit(args) => cli::audit::run(args),
        Cli::Export(args) => cli::export::run(args),
        Cli::Link(_)
        | Cli::Mission(_)
        | Cli::Decode(_)
        | Cli::Events(_)
        | Cli::Sweep(_)
        | Cli::Viewpoints(_)
        | Cli::Trials(_)
        | Cli::Study(_)
        | Cli::Report(_) => cli::lab::run(&args),
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::Cli;
    use deploy::cli::lab::LAB_COMMANDS;

    /// Every command forwarded to `waggle-lab` is listed, with its description, by `waggle --help`.
    #[test]
    fn every_lab_command_is_listed() {
        let cli = Cli::command();
        for name in LAB_COMMANDS {
            let command = cli
                .find_subcommand(name)
                .unwrap_or_else(|| panic!("waggle --help does not list {name}"));
            assert!(command.get_about().is_some(), "{name} has no description");
        }
    }
}
