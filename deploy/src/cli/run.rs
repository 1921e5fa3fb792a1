//! `waggle run CASE`: a whole case as separate processes over Zenoh ([`crate::launch`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use bus::Endpoints;
use clap::Args;
use proto::Modality;

use crate::case::Case;
use crate::compose::build::EventRecording;
use crate::fault::{BlackSpec, ExtraFaults, KillSpec, ThrottleSpec};
use crate::launch::{RunOptions, run_case, run_modality};
use crate::run_dir::RunSummary;
use node_args::SensorArgs;
use run_eval::summary::print_summary;

/// What defines a session: the case, its modality, faults, bus and recording (shared by
/// `waggle run` and `waggle compose`).
#[derive(Debug, Args)]
pub struct SessionArgs {
    #[arg(help = run_format::case::case_arg_help())]
    pub case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    pub modality: Option<Modality>,
    #[command(flatten)]
    pub render: super::RenderArg,
    #[command(flatten)]
    pub flights: super::FlightsArg,
    /// The event cameras' sensor model: a preset and `events.*` terms (other groups are
    /// modelled by `waggle trials` and `waggle mission` only).
    #[command(flatten)]
    pub perturb: super::PerturbArgs,
    /// Seed of the event sensors' noise draws (with --sensor-preset/--perturb): observer i draws
    /// from stream i of it, as in `waggle mission --seed`, so both build the same sensors.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Session id (default: `run-<pid>-<unix ms>`); every key lives under `waggle/<session>/`.
    #[arg(long)]
    pub session: Option<String>,
    /// Wall-clock time after which an observer judges missing a packet its camera neither sent
    /// nor said it dropped, ms: a last resort for a silent camera (throttle drops and dead
    /// cameras are told by the camera and its liveliness, never by this wait).
    #[arg(long, default_value_t = node_args::DEFAULT_GRACE_MS)]
    pub grace_ms: u64,
    /// Extra fault: black input of this observer from start-up (e.g. `O2`); repeatable.
    #[arg(long)]
    pub black: Vec<BlackSpec>,
    /// Extra fault: SIGKILL this observer's camera at a sim time, `O2@35`; repeatable.
    #[arg(long)]
    pub kill: Vec<KillSpec>,
    /// Extra fault: throttle a camera, `O1@0:250:0` = observer@from_s:drop per mille:delay ms.
    #[arg(long)]
    pub throttle: Vec<ThrottleSpec>,
    /// Run every observer behind a Zenoh access-control list that denies it ground truth
    /// (`sim/**`, `truth/**`), the performer's and scheduler's commands, faults and every other
    /// observer's keys (docs/DESIGN.md §2: the run must still pass).
    #[arg(long)]
    pub observer_acl: bool,
    /// Open bus for debugging with Zenoh tools: no authentication, no per-role access control
    /// (prints a warning; refused with a non-loopback router). By default every process
    /// authenticates to the session's router with its own per-session credentials and may
    /// publish only its own keys and read only what it needs.
    #[arg(long)]
    pub no_auth: bool,
    /// Accept a router listening on plain `tcp/` beyond loopback: authenticated, but not
    /// encrypted. Without it such a router is refused; listen on `quic/` instead (mutual TLS with
    /// the session's certificates).
    #[arg(long)]
    pub plain_tcp: bool,
    /// Do not record the session (by default `recorder-node` writes DIR/session.mcap, with the
    /// case in its metadata; see `waggle audit` and `waggle replay`).
    #[arg(long)]
    pub no_record: bool,
    /// A view image of every RGB frame in the recording (by default one in 25, i.e. 1 Hz; the
    /// raw channel holds every frame losslessly either way).
    #[arg(long)]
    pub record_all_rgb: bool,
    /// What the recording keeps of the event cameras: `packets` (every packet), `input` (what
    /// each sensor was fed — its renders — from which `waggle replay` regenerates the packets
    /// bit for bit with the recorded sensor model and seed), or `auto`: the input when the
    /// sensors have a noise model, the packets otherwise.
    #[arg(long, value_enum, default_value_t)]
    pub record_events: EventRecording,
}

impl SessionArgs {
    /// The case (with any `--flights` override), its modality and the run options.
    pub fn options(self) -> Result<(Case, Modality, RunOptions)> {
        let case = self.flights.apply(Case::load(&self.case)?);
        let modality = run_modality(&case, self.modality)?;
        let sensor = SensorArgs {
            preset: self.perturb.sensor_preset,
            perturb: self.perturb.perturb,
            seed: self.seed,
        };
        sensor.check(modality)?;
        let opts = RunOptions {
            case_arg: self.case,
            out: None,
            session: self.session,
            bin_dir: None,
            grace_ms: self.grace_ms,
            extra_faults: ExtraFaults {
                black: self.black,
                kill: self.kill,
                throttle: self.throttle,
            },
            observer_acl: self.observer_acl,
            no_auth: self.no_auth,
            plain_tcp: self.plain_tcp,
            quiet: false,
            no_record: self.no_record,
            record_all_rgb: self.record_all_rgb,
            record_events: self.record_events,
            endpoints: Endpoints::default(),
            render: self.render.path,
            live: None,
            ros2: None,
            sensor,
        };
        Ok((case, modality, opts))
    }
}

/// How this machine's launcher runs its share of a session (shared by `waggle run` and
/// `waggle up`).
#[derive(Debug, Args)]
pub struct LaunchArgs {
    /// The run directory: summary.json, observers.json (the simulator's host), session.mcap (the
    /// recorder's host), host.json (other hosts) and every local process's log in DIR/logs
    /// (default: a temporary directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    pub bin_dir: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Watch the run live: serve the view channels (event and RGB images, poses, the 3D scene,
    /// the log) over a Foxglove WebSocket on 127.0.0.1:PORT (Foxglove: Open connection), from
    /// the recorder's host.
    #[arg(long, value_name = "PORT")]
    pub live: Option<u16>,
    /// Also publish the run live as ROS 2 topics in this ROS domain, as ROS 2 Jazzy's
    /// `rmw_zenoh` does (the topics and types of `waggle export ros2`), from the recorder's
    /// host: `ros2 topic echo` under RMW_IMPLEMENTATION=rmw_zenoh_cpp sees them.
    #[arg(long, value_name = "N")]
    pub ros2_domain: Option<u32>,
    /// The ROS side's Zenoh router for --ros2-domain (default: tcp/localhost:7447, where
    /// `ros2 run rmw_zenoh_cpp rmw_zenohd` listens).
    #[arg(long, value_name = "ENDPOINT", requires = "ros2_domain")]
    pub ros2_router: Option<String>,
}

impl LaunchArgs {
    /// The live ROS 2 view asked for, if any.
    pub fn ros2(&self) -> Option<crate::launch::up::Ros2View> {
        self.ros2_domain.map(|domain| crate::launch::up::Ros2View {
            domain,
            router: self.ros2_router.clone(),
        })
    }
}

#[derive(Debug, Args)]
pub struct RunArgs {
    #[command(flatten)]
    session: SessionArgs,
    #[command(flatten)]
    launch: LaunchArgs,
    /// The session router's endpoints (default: listen on a free loopback port). Children
    /// connect to every listen endpoint given here, plus every connect endpoint.
    #[command(flatten)]
    endpoints: Endpoints,
}

pub fn run(args: RunArgs) -> Result<()> {
    let (case, modality, mut opts) = args.session.options()?;
    let launch = args.launch;
    opts.ros2 = launch.ros2();
    opts.out = launch.out;
    opts.bin_dir = launch.bin_dir;
    opts.quiet = launch.quiet;
    opts.live = launch.live;
    opts.endpoints = args.endpoints;
    let done = run_case(&case, modality, &opts)?;
    if opts.out.is_none() && !launch.json {
        println!("summary and logs in {}", done.out_dir.display());
    }
    report(&done.summary, launch.json)
}

/// Prints a supervised session's summary (JSON or the table) and fails when it was interrupted
/// or missed its expected outcome.
pub fn report(summary: &RunSummary, json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary.mission);
        print_run_figures(summary);
    }
    if summary.interrupted {
        bail!("interrupted");
    }
    if !summary.mission.pass {
        bail!(
            "case {} did not meet its expected outcome: {}",
            summary.mission.case,
            summary.mission.reasons.join("; ")
        );
    }
    Ok(())
}

fn print_run_figures(s: &RunSummary) {
    println!(
        "session {} · wall/sim {:.3} · start-up {:.1} s · missing packets {:?}",
        s.session, s.wall_over_sim, s.startup_s, s.missing_packets
    );
    let cpu: Vec<String> = s
        .processes
        .iter()
        .map(|(n, p)| format!("{n} {:.1}", p.cpu_s))
        .collect();
    println!("CPU s per process: {}", cpu.join(" · "));
    let renders: Vec<String> = s
        .camera_renders
        .iter()
        .map(|(o, r)| format!("{o} {}/{}/{}", r.full, r.damage, r.skipped))
        .collect();
    if !renders.is_empty() {
        println!(
            "camera renders ({}, full/damage/skipped): {}",
            s.render,
            renders.join(" · ")
        );
    }
    if let Some(sensor) = &s.sensor {
        let terms: Vec<String> = sensor
            .perturb
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        println!(
            "event sensors: preset {} · {} · seed {}",
            sensor.preset.as_deref().unwrap_or("none"),
            terms.join(" "),
            sensor.seed
        );
    }
    for f in &s.faults {
        println!("  fault: {f}");
    }
    for f in &s.faults_seen {
        println!("  fault seen on the bus: {f}");
    }
    println!("{}", run_eval::summary::rejects_line(&s.rejects));
    if !s.router_refusals.is_empty() {
        println!(
            "router refused: {}",
            crate::launch::router::describe_refusals(&s.router_refusals)
        );
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        run: super::RunArgs,
    }

    fn options(args: &[&str]) -> anyhow::Result<super::RunOptions> {
        let cli = Cli::try_parse_from(std::iter::once("waggle-run").chain(args.iter().copied()))?;
        Ok(cli.run.session.options()?.2)
    }

    #[test]
    fn an_unknown_sensor_preset_is_refused_naming_it_and_the_known_ones() {
        let e = format!(
            "{:#}",
            options(&["only-a", "--sensor-preset", "v2e-loud"]).unwrap_err()
        );
        assert!(e.contains("v2e-loud") && e.contains("v2e-default"), "{e}");
        let e = format!(
            "{:#}",
            options(&["only-a", "--perturb", "link.drop_rate=0.1"]).unwrap_err()
        );
        assert!(e.contains("link.drop_rate"), "{e}");
        let e = format!(
            "{:#}",
            options(&[
                "only-a",
                "--modality",
                "rgb",
                "--sensor-preset",
                "v2e-clean"
            ])
            .unwrap_err()
        );
        assert!(e.contains("rgb"), "{e}");
    }

    #[test]
    fn the_preset_terms_and_seed_reach_the_cameras_arguments() {
        let opts = options(&[
            "only-a",
            "--sensor-preset",
            "v2e-noisy",
            "--perturb",
            "events.refractory_ms=1",
            "--seed",
            "3",
        ])
        .unwrap();
        assert_eq!(opts.sensor.preset.as_deref(), Some("v2e-noisy"));
        assert_eq!(opts.sensor.perturb, ["events.refractory_ms=1"]);
        assert_eq!(opts.sensor.seed, 3);
        assert!(
            options(&["only-a", "--seed", "3"])
                .unwrap()
                .sensor
                .is_none()
        );
    }
}
