//! `waggle mission`: a whole case in one process ([`crate::harness::mission`]).

use anyhow::{Context, Result, bail};

use crate::harness::mission::metrics::MissionMetrics;
use crate::harness::mission::{MissionOptions, MissionRun, fly_case_with};
use commands::mission::MissionArgs;
use proto::Receiver;
use run_eval::summary::print_summary;
use run_format::case::Case;
use run_format::run_dir::{OBSERVERS_FILE, SUMMARY_FILE};

pub fn run(args: MissionArgs) -> Result<()> {
    let case = args.flights.apply(Case::load(&args.case)?);
    if !case.modalities.contains(&args.modality) && args.modality != Receiver::Ideal {
        bail!(
            "case {} does not apply to the {:?} modality (it lists {:?})",
            case.name,
            args.modality,
            case.modalities
        );
    }
    let opts = MissionOptions {
        render: args.render.path,
        policy: args.policy,
        perturbation: args.perturb.perturbation()?,
        seed: args.seed,
        stop: None,
        receivers: args.receivers.checked()?,
        plugin_time_limit: args.receivers.time_limit(),
        keep_events: args.events_raw.is_some(),
    };
    if args.events_raw.is_some() && args.modality != Receiver::Events {
        bail!(
            "--events-raw writes event cameras' events; the {:?} modality has none",
            args.modality
        );
    }
    for r in &opts.receivers {
        receiver_plugin::worker::check_loads(&r.plugin, opts.plugin_time_limit)
            .with_context(|| format!("{}'s receiver {}", r.observer.as_str(), r.plugin))?;
    }
    let MissionRun {
        summary,
        metrics,
        observers,
        receiver_failures,
        events,
        ..
    } = fly_case_with(&case, args.modality, &opts)?.context("the mission was interrupted")?;
    if let Some(dir) = &args.events_raw {
        let names: Vec<String> = events.keys().cloned().collect();
        crate::harness::link::write_raws(dir, &names, events.values().map(Vec::as_slice))?;
    }
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(SUMMARY_FILE);
        std::fs::write(&path, serde_json::to_string_pretty(&summary)?)
            .with_context(|| format!("writing {}", path.display()))?;
        // The same file, byte for byte, as `waggle run` writes for the same case.
        let path = dir.join(OBSERVERS_FILE);
        std::fs::write(&path, serde_json::to_string_pretty(&observers)?)
            .with_context(|| format!("writing {}", path.display()))?;
        let path = dir.join("metrics.json");
        std::fs::write(&path, serde_json::to_string_pretty(&metrics)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
    }
    for (observer, why) in &receiver_failures {
        eprintln!("warning: {observer}'s receiver failed and heard nothing after it: {why}");
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary);
        print_metrics(&metrics);
    }
    if !summary.pass {
        bail!(
            "case {} did not meet its expected outcome: {}",
            summary.case,
            summary.reasons.join("; ")
        );
    }
    Ok(())
}

/// The outcome measures, one line each.
pub fn print_metrics(m: &MissionMetrics) {
    println!(
        "policy {}: {} work units, reward {}, unserved capacity {}, completion {:.2} s, \
         {} wasted trip(s), communication {} symbols / {:.2} s of broadcast",
        m.policy,
        m.work_units,
        m.reward,
        m.unserved_capacity,
        m.completion_time_s,
        m.wasted_trips,
        m.broadcast_symbols,
        m.broadcast_s
    );
    for r in &m.reassignments {
        println!(
            "  withdrawal of {} in round {}: {} went to {} — reassignment delay {}",
            r.withdrawn,
            r.round,
            r.observer,
            r.went_to.as_deref().unwrap_or("nowhere (stayed home)"),
            r.delay_s
                .map_or("none (not reassigned)".into(), |d| format!("{d:.2} s"))
        );
    }
}
