//! `waggle run CASE`: a whole case as separate processes over Zenoh ([`crate::launch`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use bus::Endpoints;
use clap::Args;
use proto::Modality;

use crate::case::Case;
use crate::eval::summary::print_summary;
use crate::launch::fault::{BlackSpec, ExtraFaults, KillSpec, ThrottleSpec};
use crate::launch::{RunOptions, run_case, run_modality};
use crate::run_dir::RunSummary;

#[derive(Debug, Args)]
pub struct RunArgs {
    /// Built-in case name (one-observer, two-observers, nominal-3, black-o2, no-broadcast,
    /// only-a, dropout-o2) or a path to a case TOML file.
    case: String,
    /// Observer sensor modality (default: events when the case applies to it).
    #[arg(long, value_enum)]
    modality: Option<Modality>,
    #[command(flatten)]
    render: super::RenderArg,
    #[command(flatten)]
    flights: super::FlightsArg,
    /// Write DIR/summary.json, DIR/observers.json and the process logs (DIR/logs) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
    /// Session id (default: `run-<pid>-<unix ms>`); every key lives under `waggle/<session>/`.
    #[arg(long)]
    session: Option<String>,
    /// Directory holding the node binaries (default: the one `waggle` is in).
    #[arg(long)]
    bin_dir: Option<PathBuf>,
    /// Wall-clock time after which an observer judges a late packet missing, ms.
    #[arg(long, default_value_t = 10_000)]
    grace_ms: u64,
    /// Extra fault: black input of this observer from start-up (e.g. `O2`); repeatable.
    #[arg(long)]
    black: Vec<BlackSpec>,
    /// Extra fault: SIGKILL this observer's camera at a sim time, `O2@35`; repeatable.
    #[arg(long)]
    kill: Vec<KillSpec>,
    /// Extra fault: throttle a camera, `O1@0:250:0` = observer@from_s:drop per mille:delay ms.
    #[arg(long)]
    throttle: Vec<ThrottleSpec>,
    /// Run every observer behind a Zenoh access-control list that denies it ground truth
    /// (`sim/**`, `truth/**`), the performer's and scheduler's commands, faults and every other
    /// observer's keys (DESIGN.md §2: the run must still pass).
    #[arg(long)]
    observer_acl: bool,
    /// Open bus for debugging with Zenoh tools: no authentication, no per-role access control
    /// (prints a warning; refused with a non-loopback --listen). By default every process
    /// authenticates to the launcher's router with its own per-session credentials and may
    /// publish only its own keys and read only what it needs.
    #[arg(long)]
    no_auth: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Do not record the session (by default `recorder-node` writes DIR/session.mcap, with the
    /// case in its metadata; see `waggle audit` and `waggle replay`).
    #[arg(long)]
    no_record: bool,
    /// A view image of every RGB frame in the recording (by default one in 25, i.e. 1 Hz; the
    /// raw channel holds every frame losslessly either way).
    #[arg(long)]
    record_all_rgb: bool,
    /// The launcher's own endpoints (default: listen on a free loopback port). Children
    /// connect to every listen endpoint given here, plus every connect endpoint.
    #[command(flatten)]
    endpoints: Endpoints,
}

pub fn run(args: RunArgs) -> Result<()> {
    let case = args.flights.apply(Case::load(&args.case)?);
    let modality = run_modality(&case, args.modality)?;
    let json = args.json;
    let opts = RunOptions {
        case_arg: args.case,
        out: args.out,
        session: args.session,
        bin_dir: args.bin_dir,
        grace_ms: args.grace_ms,
        extra_faults: ExtraFaults {
            black: args.black,
            kill: args.kill,
            throttle: args.throttle,
        },
        observer_acl: args.observer_acl,
        no_auth: args.no_auth,
        quiet: args.quiet,
        no_record: args.no_record,
        record_all_rgb: args.record_all_rgb,
        endpoints: args.endpoints,
        render: args.render.path,
    };
    let done = run_case(&case, modality, &opts)?;
    if opts.out.is_none() && !json {
        println!("summary and logs in {}", done.out_dir.display());
    }
    let summary = done.summary;
    if json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary.mission);
        print_run_figures(&summary);
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
    for f in &s.faults {
        println!("  fault: {f}");
    }
    for f in &s.faults_seen {
        println!("  fault seen on the bus: {f}");
    }
    println!("{}", crate::eval::summary::rejects_line(&s.rejects));
}
