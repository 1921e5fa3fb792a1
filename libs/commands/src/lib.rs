//! `commands`: the `waggle` command line, defined once. Every command's arguments and help text
//! are here, grouped by purpose; `waggle` parses every command line with [`parse`], so its
//! errors and `--help` come from this one parser whichever binary then runs the command, and
//! `waggle-lab` (the commands that fly the simulator, [`Binary::Lab`]) parses the same way.
//! Man pages and shell completions are generated from the same definition ([`shell`]).
//!
//! The crate links no MuJoCo; the types it parses into are the ones the libraries act on
//! (faults, shards, value enums), so no adapter converts between two spellings of one option.

// Help texts name files such as `DIR/<observer>.raw`; they are printed as written, so rustdoc
// must not read them as HTML.
#![allow(rustdoc::invalid_html_tags)]
#![forbid(unsafe_code)]

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

pub mod allocate;
pub mod assign;
pub mod audit;
pub mod bench;
pub mod bundle;
pub mod common;
pub mod compose;
pub mod decode;
pub mod events;
pub mod export;
pub mod fault;
pub mod inputs;
pub mod link;
pub mod mission;
pub mod observe;
pub mod payload;
pub mod replay;
pub mod report;
pub mod router;
pub mod run;
pub mod sensor_fit;
pub mod shard;
pub mod shell;
pub mod study;
pub mod sweep;
pub mod trials;
pub mod up;
pub mod viewpoints;

pub use common::{CaseOverrides, PerturbArgs, Policy, RenderArg};

/// `waggle`'s command line.
#[derive(Debug, Parser)]
#[command(
    name = "waggle",
    bin_name = "waggle",
    version,
    about = "Waggle: motion-mediated drone recruitment"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Every command, by group (the groups `waggle --help` lists them under).
#[derive(Debug, Subcommand)]
pub enum Command {
    #[command(flatten)]
    Deploy(DeployCommand),
    #[command(flatten)]
    Inspect(InspectCommand),
    #[command(flatten)]
    Studies(StudiesCommand),
    #[command(flatten)]
    Data(DataCommand),
    #[command(flatten)]
    Shell(ShellCommand),
}

/// Run and deploy: fly a case, in one process or as a supervised session over hosts.
#[derive(Debug, Subcommand)]
pub enum DeployCommand {
    /// Run a whole case as separate processes over Zenoh (simulator, cameras, performer,
    /// observers, scheduler), supervised, with a progress bar and a summary.
    Run(run::RunArgs),
    /// Fly a whole case (physics, cameras, performer, observers, scheduler) in one process.
    Mission(mission::MissionArgs),
    /// Fly a broadcast in one process and decode it with each observer's receiver.
    Link(link::LinkArgs),
    /// Write a session's compose file: every node with its arguments, placed on hosts
    /// (`--place camera-*=b`), the router's endpoint and the session's credentials.
    Compose(compose::ComposeArgs),
    /// Start and supervise the nodes a compose file places on this host (`--host NAME`; every
    /// node without it). The simulator's host writes the summary.
    Up(up::UpArgs),
    /// Serve a session's Zenoh router on its own (authenticated from its compose file).
    Router(router::RouterArgs),
    /// Write what one host of a session needs (the compose file and only that host's
    /// credentials) into a new directory, to copy to that host.
    Bundle(bundle::BundleArgs),
    /// Run a case once per camera render path (`--paths`; default MuJoCo's damage path and
    /// Waggle's renderer) in one invocation and print wall/sim, camera CPU per simulated second
    /// and their ratio side by side.
    Bench(bench::BenchArgs),
}

/// Inspect a run: what a run directory or recording holds, checked and re-derived.
#[derive(Debug, Subcommand)]
pub enum InspectCommand {
    /// The paper's tables, provenance audit and expected outcome from a recording alone.
    Audit(audit::AuditArgs),
    /// Re-run the event receivers from a recording's raw event packets and session controls
    /// and compare with the live decodes.
    Replay(replay::ReplayArgs),
    /// Rebuild report.md and its figures from a run or sweep directory, without re-running.
    Report(report::ReportArgs),
}

/// Studies: seeded trials, studies and sweeps with their intervals.
#[derive(Debug, Subcommand)]
pub enum StudiesCommand {
    /// One condition, N seeded trials under a perturbation: success rate with its Wilson 95 %
    /// interval and per-trial measurements in DIR/trials.json.
    Trials(trials::TrialsArgs),
    /// Run a study (conditions × levels × modalities as seeded trials) and write DIR/report.md
    /// with success probabilities, their 95 % intervals and a figure.
    Study(study::StudyArgs),
    /// Run every case × modality (`waggle run` each), audit each and write DIR/report.md with
    /// the paper's tables and the figures; exit 1 if any run misses its expected outcome.
    Sweep(sweep::SweepArgs),
    /// Measure decode success against viewing angle and distance: observers placed at each
    /// viewpoint, one flight per group of up to eight, per receiver and rectification.
    Viewpoints(viewpoints::ViewpointsArgs),
}

/// Data in and out: recordings decoded and converted, runs exported, the protocol by hand.
#[derive(Debug, Subcommand)]
pub enum DataCommand {
    /// Decode a camera's recording (EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4, a ROS 2 bag, PNG frames)
    /// with one observer's receiver: tokens, frames and payloads.
    Decode(decode::DecodeArgs),
    /// Decode a live camera, a ROS 2 topic on rmw_zenoh (`event_camera_msgs` EventPacket in
    /// evt3, or images), with one observer's receiver; its tokens and frames published back
    /// as ROS 2 messages.
    Observe(observe::ObserveArgs),
    /// One trial's sensor inputs, as its receivers get them, with the ground truth (broadcast
    /// symbols and their intervals, the performer's image position per input, the ideal
    /// receiver's tokens): a stream the Python package reads, for offline work and training.
    Inputs(inputs::InputsArgs),
    /// Synthetic event camera tools (convert PNG frames into events).
    Events(events::EventsArgs),
    /// Measure a real camera from its recording: background activity by polarity, hot pixels,
    /// the refractory floor; optionally write them as a preset file for `--sensor-preset`.
    SensorFit(sensor_fit::SensorFitArgs),
    /// Export a run's recording for other tools: `export ros2 RUN_DIR --out BAG_DIR` writes a
    /// ROS 2 bag (rosbag2 of ROS 2 Jazzy, MCAP storage).
    Export(export::ExportArgs),
    /// Decode or encode a six-bit task offer.
    Payload(payload::PayloadArgs),
    /// Run the local allocation policy on a set of offers.
    Allocate(allocate::AllocateArgs),
}

/// Shell: completions and manual pages of this command line.
#[derive(Debug, Subcommand)]
pub enum ShellCommand {
    /// Print the completion script of a shell (bash, zsh, fish, elvish, powershell), e.g.
    /// `waggle completions bash > ~/.local/share/bash-completion/completions/waggle`.
    Completions(shell::CompletionsArgs),
    /// Write the manual pages (waggle.1, and waggle-COMMAND.1 for every command) into a
    /// directory, e.g. `waggle man --out ~/.local/share/man/man1`.
    Man(shell::ManArgs),
}

/// The binary that runs a command: `waggle` links no simulator; `waggle-lab`, beside it, runs
/// the commands that fly one in-process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Binary {
    Waggle,
    Lab,
}

impl Command {
    /// Which binary runs this command.
    pub fn binary(&self) -> Binary {
        match self {
            Command::Deploy(DeployCommand::Mission(_) | DeployCommand::Link(_))
            | Command::Inspect(InspectCommand::Report(_))
            | Command::Studies(_)
            | Command::Data(
                DataCommand::Decode(_)
                | DataCommand::Observe(_)
                | DataCommand::Inputs(_)
                | DataCommand::Events(_)
                | DataCommand::SensorFit(_),
            ) => Binary::Lab,
            Command::Deploy(_) | Command::Inspect(_) | Command::Data(_) | Command::Shell(_) => {
                Binary::Waggle
            }
        }
    }
}

/// The groups of `waggle --help`: a heading and the subcommands its enum declares.
/// Adds a group's subcommands to a command.
type Augment = fn(clap::Command) -> clap::Command;

const GROUPS: [(&str, Augment); 5] = [
    ("Run and deploy", DeployCommand::augment_subcommands),
    ("Inspect a run", InspectCommand::augment_subcommands),
    ("Studies", StudiesCommand::augment_subcommands),
    ("Data in and out", DataCommand::augment_subcommands),
    ("Shell", ShellCommand::augment_subcommands),
];

/// The whole command line, its top-level help listing the commands by group.
pub fn command() -> clap::Command {
    let mut rows: Vec<(&str, String, String)> = Vec::new();
    for (heading, augment) in GROUPS {
        for sub in augment(clap::Command::new("group")).get_subcommands() {
            let about = sub.get_about().map(ToString::to_string).unwrap_or_default();
            rows.push((heading, sub.get_name().to_owned(), about));
        }
    }
    let width = rows
        .iter()
        .map(|(_, name, _)| name.len())
        .max()
        .unwrap_or(0);
    let mut listing = String::new();
    let mut last = "";
    for (heading, name, about) in &rows {
        if *heading != last {
            if !last.is_empty() {
                listing.push('\n');
            }
            listing.push_str(&format!("{heading}:\n"));
            last = heading;
        }
        listing.push_str(&format!("  {name:<width$}  {about}\n"));
    }
    listing.push_str(&format!(
        "  {:<width$}  Print this message or the help of the given subcommand(s)\n",
        "help"
    ));
    Cli::command().help_template(format!(
        "{{before-help}}{{about-with-newline}}\n{{usage-heading}} {{usage}}\n\n{listing}\n\
         Options:\n{{options}}{{after-help}}"
    ))
}

/// Parses `args` (the program's name first), or the error clap prints and exits with (help and
/// version included).
///
/// # Errors
///
/// What clap reports of a command line that does not parse, or its `--help`/`--version` output.
pub fn try_parse_from<I, T>(args: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let mut command = command();
    let matches = command.try_get_matches_from_mut(args)?;
    Cli::from_arg_matches(&matches).map_err(|e| e.format(&mut command))
}

/// Parses this process's command line; on an error, `--help` or `--version`, prints what clap
/// says and exits.
pub fn parse() -> Cli {
    try_parse_from(std::env::args_os()).unwrap_or_else(|e| e.exit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_definition_is_consistent() {
        command().debug_assert();
    }

    #[test]
    fn every_command_is_listed_once_under_a_group() {
        let help = command().render_help().to_string();
        for sub in command().get_subcommands() {
            let row = format!("\n  {} ", sub.get_name());
            assert_eq!(
                help.matches(&row).count(),
                1,
                "{} in\n{help}",
                sub.get_name()
            );
        }
        for (heading, _) in GROUPS {
            assert!(help.contains(&format!("\n{heading}:\n")), "{heading}");
        }
    }

    #[test]
    fn commands_run_in_the_binary_their_kind_needs() {
        let binary = |line: &str| {
            let cli = try_parse_from(line.split(' ')).unwrap();
            cli.command.binary()
        };
        assert_eq!(binary("waggle mission nominal-3"), Binary::Lab);
        assert_eq!(binary("waggle run nominal-3"), Binary::Waggle);
        assert_eq!(binary("waggle report DIR"), Binary::Lab);
        assert_eq!(binary("waggle audit DIR"), Binary::Waggle);
        assert_eq!(binary("waggle completions bash"), Binary::Waggle);
    }

    #[test]
    fn a_negative_azimuth_is_a_value() {
        let cli = try_parse_from([
            "waggle",
            "link",
            "--payload",
            "011010",
            "--viewpoint",
            "-20,0,1.6",
        ]);
        assert!(cli.is_ok(), "{:?}", cli.err());
    }
}
