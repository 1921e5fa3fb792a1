//! `waggle run CASE`: a whole case as separate processes over Zenoh ([`crate::launch`]).

use anyhow::{Context, Result, bail};
use bus::Endpoints;
use proto::Modality;

use crate::case::Case;

use crate::fault::ExtraFaults;
use crate::launch::{RunOptions, run_case, run_modality};
use crate::run_dir::RunSummary;
use commands::run::{LaunchArgs, RunArgs, SessionArgs};
use node_args::SensorArgs;
use run_eval::summary::print_summary;

/// The case `session` names (with any `--flights` override), its modality and the run options.
pub fn session_options(session: SessionArgs) -> Result<(Case, Modality, RunOptions)> {
    let case = session.flights.apply(Case::load(&session.case)?);
    let modality = run_modality(&case, session.modality)?;
    let sensor = SensorArgs {
        preset: session.perturb.sensor_preset,
        perturb: session.perturb.perturb,
        seed: session.seed,
    };
    sensor.check(modality)?;
    let receivers = session
        .receivers
        .checked()?
        .into_iter()
        .map(|r| (r.observer, r.plugin))
        .collect();
    let plugin_time_limit_ms = session
        .receivers
        .time_limit()
        .map(|l| u64::try_from(l.as_millis()).unwrap_or(u64::MAX));
    let opts = RunOptions {
        case_arg: session.case,
        out: None,
        session: session.session,
        bin_dir: None,
        grace_ms: session.grace_ms,
        extra_faults: ExtraFaults {
            black: session.black,
            kill: session.kill,
            throttle: session.throttle,
        },
        observer_acl: session.observer_acl,
        no_auth: session.no_auth,
        plain_tcp: session.plain_tcp,
        quiet: false,
        no_record: session.no_record,
        record_all_rgb: session.record_all_rgb,
        record_events: session.record_events,
        endpoints: Endpoints::default(),
        render: session.render.path,
        live: None,
        ros2: None,
        ros2_cameras: Default::default(),
        sensor,
        receivers,
        plugin_time_limit_ms,
        rss_every_s: None,
    };
    Ok((case, modality, opts))
}

/// Loads every observer's plug-in once, here, before any process starts: a plug-in that cannot
/// be imported or built is refused by name instead of leaving its observer deaf. (Once running,
/// a plug-in that fails leaves its observer deaf; its log, DIR/logs, says why.)
fn check_plugins(case: &Case, opts: &RunOptions) -> Result<()> {
    let limit = opts
        .plugin_time_limit_ms
        .map(std::time::Duration::from_millis);
    for (observer, spec) in &opts.receivers {
        if !case.has_observer(observer.as_str()) {
            bail!(
                "--receiver {}=…: the case has {} observers",
                observer.as_str(),
                case.observers
            );
        }
        receiver_plugin::worker::check_loads(spec, limit)
            .with_context(|| format!("{}'s receiver {spec}", observer.as_str()))?;
    }
    Ok(())
}

/// The live ROS 2 view `launch` asks for, if any.
pub fn ros2_view(launch: &LaunchArgs) -> Option<crate::launch::up::Ros2View> {
    launch
        .ros2_domain
        .map(|domain| crate::launch::up::Ros2View {
            domain,
            router: launch.ros2_router.clone(),
        })
}

pub fn run(args: RunArgs) -> Result<()> {
    let (case, modality, mut opts) = session_options(args.session)?;
    let launch = args.launch;
    opts.ros2 = ros2_view(&launch);
    opts.out = launch.out;
    opts.bin_dir = launch.bin_dir;
    opts.quiet = launch.quiet;
    opts.live = launch.live;
    opts.rss_every_s = launch.rss_every_s;
    opts.endpoints = args.endpoints;
    opts.ros2_cameras = args
        .ros2_camera
        .into_iter()
        .map(|c| (c.observer, c.topic))
        .collect();
    check_plugins(&case, &opts)?;
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
        Ok(super::session_options(cli.run.session)?.2)
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
