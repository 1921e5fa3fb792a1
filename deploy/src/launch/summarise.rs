//! The end of `waggle run`: from what was gathered and how each process ended, the run's
//! `summary.json` ([`RunSummary`]), `observers.json` and `session.json`.

use std::collections::BTreeMap;
use std::time::Instant;

use proto::scene::{distance_m, observer_home_m, observer_name};
use proto::{MissionReport, Modality, ObserverId, RenderPath};

use super::gather::{Gathered, SeenFault};
use super::process::Proc;
use super::supervise::Supervised;
use crate::case::Case;
use crate::fault::Injected;
use crate::run_dir::session::SessionRecord;
use crate::run_dir::track_spool::SpooledRecord;
use crate::run_dir::{CameraRenders, MissionSummary, ObserverSummary, ProcessFigures, RunSummary};
use run_eval::summary::{check_expected, ns_s, provenance_violations};

/// What a run writes into its directory.
pub struct RunOutputs {
    pub summary: RunSummary,
    /// Serialise as `observers.json`'s records, their tracks read back from disk.
    pub observers: BTreeMap<String, SpooledRecord>,
    pub session: SessionRecord,
}

/// The run's identity, for the summary.
pub struct RunInfo<'a> {
    pub case: &'a Case,
    pub modality: Modality,
    pub render: RenderPath,
    /// The event cameras' sensor model (`None`: ideal).
    pub sensor: Option<crate::run_dir::SensorRecord>,
    pub session: &'a str,
    /// When the launcher started.
    pub started: Instant,
    /// The faults the launcher injected.
    pub injected: &'a [Injected],
}

/// Builds the run's outputs.
pub fn summarise(info: &RunInfo<'_>, run: Supervised, procs: &[Proc]) -> RunOutputs {
    let Supervised {
        gathered: mut g,
        fault_log,
        interrupted,
    } = run;
    let case = info.case;
    let report = g.report.clone();
    let (records, observers, violations) = observer_records(case.observers, &mut g, &report);
    let false_releases = run_eval::summary::false_releases(
        records.values().flat_map(|r| &r.frames),
        &run_eval::summary::flown_payloads(&g.broadcasts),
    );
    let mut mission = MissionSummary {
        case: case.name.clone(),
        modality: Some(info.modality.into()),
        observers,
        work_units: report.as_ref().map_or(0, |r| r.work_units),
        mission_time_s: report.as_ref().map_or(ns_s(g.now_ns()), |r| ns_s(r.end_ns)),
        end_reason: report.as_ref().map(|r| r.end_reason),
        contact_steps: g.contacts.as_ref().map_or(0, |c| c.contact_steps),
        min_separation_m: g.contacts.as_ref().map_or(f64::NAN, |c| c.min_separation_m),
        provenance_violations: violations,
        pass: false,
        reasons: Vec::new(),
        wall_seconds: info.started.elapsed().as_secs_f64(),
        viewpoints: BTreeMap::new(),
        deaf_observers: Vec::new(),
        flights: proto::FlightMode::default(),
        false_releases,
    };
    run_eval::summary::annotate_case(&mut mission, case);
    mission.reasons = check_expected(case, &mission);
    if report.is_none() {
        mission
            .reasons
            .push("no mission report from the scheduler".into());
    }
    let home_error_m = home_errors(case.observers, &g, &mut mission.reasons);
    let processes = process_figures(procs, interrupted, &mut mission.reasons);
    let faults_seen = seen_faults(&g.faults_seen, info.injected, &mut mission.reasons);
    let rejects = g
        .reject_reports()
        .into_iter()
        .map(|(p, r)| (p, r.counts))
        .collect();
    let sensor_digests = g
        .cameras
        .iter()
        .map(|(o, r)| (o.to_string(), r.digest_line()))
        .collect();
    let camera_renders = g
        .cameras
        .iter()
        .map(|(o, r)| (o.to_string(), CameraRenders::from(r)))
        .collect();
    mission.pass = mission.reasons.is_empty() && !interrupted;
    let sim_s = ns_s(g.now_ns());
    let wall_over_sim = match (g.clock_started, g.last_tick_at) {
        (Some(a), Some(b)) if sim_s > 0.0 => (b - a).as_secs_f64() / sim_s,
        _ => f64::NAN,
    };
    let startup_s = g
        .clock_started
        .map_or(f64::NAN, |c| (c - info.started).as_secs_f64());
    let end_ns = g.now_ns();
    let session = std::mem::take(&mut g.session).finish(end_ns);
    RunOutputs {
        summary: RunSummary {
            mission,
            session: info.session.to_string(),
            wall_over_sim,
            startup_s,
            missing_packets: g.missing.iter().map(|(o, m)| (o.to_string(), *m)).collect(),
            home_error_m,
            max_excursion_m: g.excursion_m.clone(),
            sensor_digests,
            render: info.render,
            camera_renders,
            sensor: info.sensor.clone(),
            processes,
            faults: fault_log,
            faults_seen,
            rejects,
            router_refusals: super::refusals::counted(),
            interrupted,
        },
        observers: records,
        session,
    }
}

/// One line per fault message seen on the bus; a reason for each the launcher did not inject
/// (a forged fault may have been obeyed: such a run proves nothing).
fn seen_faults(
    seen: &[SeenFault],
    injected: &[Injected],
    reasons: &mut Vec<String>,
) -> Vec<String> {
    seen.iter()
        .map(|s| {
            let ours = injected
                .iter()
                .any(|i| matches!(i, Injected::Message(f) if *f == s.fault));
            let when = s
                .at_tick
                .map_or("before the clock started".to_string(), |t| {
                    format!("at sim {:.2} s", ns_s(t * proto::TICK_NS))
                });
            let f = &s.fault;
            let line = format!(
                "{}: {:?} on {} from {:.2} s, seen {when}: {}",
                s.key,
                f.kind,
                f.observer,
                ns_s(f.from_ns),
                if ours {
                    "injected by the launcher"
                } else {
                    "NOT injected by the launcher"
                }
            );
            if !ours {
                reasons.push(format!(
                    "a fault the launcher did not inject reached the bus ({line})"
                ));
            }
            line
        })
        .collect()
}

/// Each observer's record (sorted), its summary line, and the provenance violations.
fn observer_records(
    n: usize,
    g: &mut Gathered,
    report: &Option<MissionReport>,
) -> (
    BTreeMap<String, SpooledRecord>,
    BTreeMap<String, ObserverSummary>,
    Vec<String>,
) {
    let departures: BTreeMap<(ObserverId, u32), u64> = report
        .iter()
        .flat_map(|r| r.departures.iter())
        .map(|d| ((d.observer.clone(), d.round), d.t_ns))
        .collect();
    let mut records = BTreeMap::new();
    let mut summaries = BTreeMap::new();
    let mut violations = Vec::new();
    for i in 0..n {
        let id = ObserverId::from_index(i);
        let mut rec = g
            .records
            .remove(&id)
            .unwrap_or_else(|| SpooledRecord::new_in(&g.spool_dir));
        rec.tokens.sort_by_key(|t| t.seq);
        rec.frames.sort_by_key(|f| f.seq);
        let services = report
            .as_ref()
            .and_then(|r| r.services.get(&id).cloned())
            .unwrap_or_default();
        summaries.insert(
            id.to_string(),
            ObserverSummary::from_record(&rec.frames, &rec.decisions, &services, rec.tokens.len()),
        );
        violations.extend(provenance_violations(&rec.decisions, &departures));
        records.insert(id.to_string(), rec);
    }
    (records, summaries, violations)
}

/// Each observer's distance from its home at the end; a reason for each beyond 5 cm.
fn home_errors(n: usize, g: &Gathered, reasons: &mut Vec<String>) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let Some(state) = &g.state else {
        return out;
    };
    for i in 0..n {
        let name = observer_name(i);
        if let Some(d) = state.drone(&name) {
            let e = distance_m(d.pos_m, observer_home_m(i, n));
            if e > 0.05 {
                reasons.push(format!("{name} ends {e:.3} m from its home"));
            }
            out.insert(name, e);
        }
    }
    out
}

/// Per-process figures; a reason for each failed process.
fn process_figures(
    procs: &[Proc],
    interrupted: bool,
    reasons: &mut Vec<String>,
) -> BTreeMap<String, ProcessFigures> {
    let mut processes = BTreeMap::new();
    for p in procs {
        if !p.success && !p.killed_by_fault && !interrupted {
            reasons.push(format!(
                "{} ended with {}",
                p.name,
                p.exit.as_deref().unwrap_or("?")
            ));
        }
        processes.insert(p.name.clone(), p.figures());
    }
    processes
}
