//! `waggle`: the Waggle launcher and user-facing command line (the adapters and the library
//! are in the `deploy` crate).

use clap::Parser;
use deploy::cli;

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
    Link(cli::link::LinkArgs),
    /// Fly a whole case (physics, cameras, performer, observers, scheduler) in one process.
    Mission(cli::mission::MissionArgs),
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
    /// Run a case once per camera render path (full, damage) in one invocation and print
    /// wall/sim, camera CPU per simulated second and their ratio side by side.
    Bench(cli::bench::BenchArgs),
    /// Decode an event camera's recording (EVT 3.0 `.raw`) with one observer's event receiver:
    /// tokens, frames and payloads.
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
    match Cli::parse() {
        Cli::Payload(args) => cli::payload::run(args),
        Cli::Allocate(args) => cli::allocate::run(args),
        Cli::Link(args) => cli::link::run(args),
        Cli::Mission(args) => cli::mission::run(args),
        Cli::Run(args) => cli::run::run(args),
        Cli::Compose(args) => cli::compose::run(args),
        Cli::Up(args) => cli::up::run(args),
        Cli::Router(args) => cli::router::run(args),
        Cli::Bundle(args) => cli::bundle::run(args),
        Cli::Events(args) => cli::events::run(args),
        Cli::Decode(args) => cli::decode::run(args),
        Cli::Bench(args) => cli::bench::run(args),
        Cli::Replay(args) => cli::replay::run(args),
        Cli::Audit(args) => cli::audit::run(args),
        Cli::Export(args) => cli::export::run(args),
        Cli::Sweep(args) => cli::sweep::run(args),
        Cli::Report(args) => cli::report::run(args),
        Cli::Viewpoints(args) => cli::viewpoints::run(args),
        Cli::Trials(args) => cli::trials::run(args),
        Cli::Study(args) => cli::study::run(args),
    }
}
