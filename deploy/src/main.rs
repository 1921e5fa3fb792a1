//! `waggle`: the Waggle launcher and user-facing command line.

use clap::Parser;

mod case;
mod cmd_allocate;
mod cmd_audit;
mod cmd_events;
mod cmd_link;
mod cmd_payload;
mod cmd_replay;
mod cmd_sweep;
mod mission;
mod performer_flight;
mod recording;
mod report;
mod run;
mod summary;

#[derive(Parser)]
#[command(
    name = "waggle",
    version,
    about = "Waggle: motion-mediated drone recruitment"
)]
enum Cli {
    /// Decode or encode a six-bit task offer.
    Payload(cmd_payload::PayloadArgs),
    /// Run the local allocation policy on a set of offers.
    Allocate(cmd_allocate::AllocateArgs),
    /// Fly a broadcast in one process and decode it with each observer's receiver.
    Link(cmd_link::LinkArgs),
    /// Fly a whole case (physics, cameras, performer, observers, scheduler) in one process.
    Mission(mission::MissionArgs),
    /// Run a whole case as separate processes over Zenoh (simulator, cameras, performer,
    /// observers, scheduler), supervised, with a progress bar and a summary.
    Run(run::RunArgs),
    /// Synthetic event camera tools (convert PNG frames into events).
    Events(cmd_events::EventsArgs),
    /// Run every case × modality (`waggle run` each), audit each and write DIR/report.md with
    /// the paper's tables and the figures; exit 1 if any run misses its expected outcome.
    Sweep(cmd_sweep::SweepArgs),
    /// Rebuild report.md and its figures from a run or sweep directory, without re-running.
    Report(report::ReportArgs),
    /// Re-run the event receivers from a recording's raw event packets and session controls
    /// and compare with the live decodes.
    Replay(cmd_replay::ReplayArgs),
    /// The paper's tables, provenance audit and expected outcome from a recording alone.
    Audit(cmd_audit::AuditArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse() {
        Cli::Payload(args) => cmd_payload::run(args),
        Cli::Allocate(args) => cmd_allocate::run(args),
        Cli::Link(args) => cmd_link::run(args),
        Cli::Mission(args) => mission::run(args),
        Cli::Run(args) => run::run(args),
        Cli::Events(args) => cmd_events::run(args),
        Cli::Replay(args) => cmd_replay::run(args),
        Cli::Audit(args) => cmd_audit::run(args),
        Cli::Sweep(args) => cmd_sweep::run(args),
        Cli::Report(args) => report::run(args),
    }
}
