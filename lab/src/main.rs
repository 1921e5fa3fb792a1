//! `waggle-lab`: the lab commands of `waggle` (the ones that fly the simulator). `waggle
//! LABCMD ARGS…` runs `waggle-lab LABCMD ARGS…` (`deploy::cli::lab`), so this binary calls
//! itself `waggle` in its help and errors: its users type `waggle`.

use clap::Parser;
use lab::cli;

#[derive(Parser)]
#[command(
    name = "waggle",
    bin_name = "waggle",
    version,
    about = "Waggle: motion-mediated drone recruitment (the lab commands, run by `waggle`)"
)]
enum Cli {
    /// Fly a broadcast in one process and decode it with each observer's receiver.
    Link(cli::link::LinkArgs),
    /// Fly a whole case (physics, cameras, performer, observers, scheduler) in one process.
    Mission(cli::mission::MissionArgs),
    /// Decode a camera's recording (EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4, a ROS 2 bag, PNG frames)
    /// with one observer's receiver: tokens, frames and payloads.
    Decode(cli::decode::DecodeArgs),
    /// Synthetic event camera tools (convert PNG frames into events).
    Events(cli::events::EventsArgs),
    /// Run every case × modality (`waggle run` each), audit each and write DIR/report.md with
    /// the paper's tables and the figures; exit 1 if any run misses its expected outcome.
    Sweep(cli::sweep::SweepArgs),
    /// Measure decode success against viewing angle and distance: observers placed at each
    /// viewpoint, one flight per group of up to eight, per receiver and rectification.
    Viewpoints(cli::viewpoints::ViewpointsArgs),
    /// One condition, N seeded trials under a perturbation: success rate with its Wilson 95 %
    /// interval and per-trial measurements in DIR/trials.json.
    Trials(cli::trials::TrialsArgs),
    /// Run a study (conditions × levels × modalities as seeded trials) and write DIR/report.md
    /// with success probabilities, their 95 % intervals and a figure.
    Study(cli::study::StudyArgs),
    /// Rebuild report.md and its figures from a run or sweep directory, without re-running.
    Report(cli::report::ReportArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse() {
        Cli::Link(args) => cli::link::run(args),
        Cli::Mission(args) => cli::mission::run(args),
        Cli::Decode(args) => cli::decode::run(args),
        Cli::Events(args) => cli::events::run(args),
        Cli::Sweep(args) => cli::sweep::run(args),
        Cli::Viewpoints(args) => cli::viewpoints::run(args),
        Cli::Trials(args) => cli::trials::run(args),
        Cli::Study(args) => cli::study::run(args),
        Cli::Report(args) => cli::report::run(args),
    }
}
