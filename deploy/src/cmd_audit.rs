//! `waggle audit DIR|FILE.mcap [--json]`: the paper's tables from a recording alone.
//!
//! From the raw messages of `session.mcap` (no summary.json, no logs): complete messages per
//! observer, work units per observer and site, mission time, contact steps and minimum
//! separation (functional-case table); first offer start, offer start to final NULL per
//! receiver and offer, latest final reception and latest reception to completion (timing
//! table); the provenance audit of every assignment; event and packet counts per observer; and
//! the case's expected outcome (the case TOML is stored in the recording) with `pass` and the
//! reasons. Offer start times come from the recorded broadcasts through the performer's own
//! schedule builder, so they are exact rather than quantised to the 40 ms tick.
//!
//! [`audit_recording`] is the library entry point (used by `waggle sweep`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Args;
use proto::{GestureConfig, broadcast};
use proto::{
    Broadcast, Decision, FrameEvent, MissionReport, ObserverId, Offer, SimContacts, TICK_NS,
};
use recording::Decoded;
use serde::{Deserialize, Serialize};

use crate::recording::scan;
use crate::summary::{MissionSummary, ObserverSummary, audit, check_expected, ns_s};

#[derive(Debug, Args)]
pub struct AuditArgs {
    /// A run directory (holding session.mcap) or an MCAP file.
    path: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// The timing table (simulation seconds).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Start of the first offer frame of the mission (after any acquisition motion).
    pub first_offer_start_s: Option<f64>,
    /// Per observer, for each released frame matched to its broadcast offer (same round,
    /// same payload), final NULL minus offer start, in release order.
    pub offer_to_final_null_s: BTreeMap<String, Vec<f64>>,
    /// Latest final-NULL time of any released frame.
    pub latest_final_reception_s: Option<f64>,
    /// Mission end minus the latest final reception.
    pub latest_reception_to_completion_s: Option<f64>,
}

/// What `waggle audit --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AuditReport {
    /// The recording was cut short or damaged: figures cover what could be read.
    pub partial: bool,
    /// Why it is partial.
    pub partial_reason: Option<String>,
    pub case: String,
    pub modality: String,
    pub session: String,
    pub mission_time_s: f64,
    pub end_reason: String,
    pub messages: BTreeMap<String, usize>,
    pub payloads: BTreeMap<String, Vec<String>>,
    pub work_units: u32,
    pub work_units_by_observer: BTreeMap<String, BTreeMap<String, u32>>,
    pub work_units_by_site: BTreeMap<String, u32>,
    pub contact_steps: u64,
    pub min_separation_m: f64,
    pub timing: Timing,
    pub provenance_violations: Vec<String>,
    /// Assignments audited for provenance (decisions with an assignment and a departure).
    pub assignments_audited: usize,
    pub events_per_observer: BTreeMap<String, u64>,
    pub packets_per_observer: BTreeMap<String, u64>,
    pub empty_packets_per_observer: BTreeMap<String, u64>,
    pub undecodable_messages: u64,
    pub pass: bool,
    pub reasons: Vec<String>,
}

#[derive(Default)]
struct Gathered {
    frames: BTreeMap<ObserverId, Vec<FrameEvent>>,
    tokens: BTreeMap<ObserverId, usize>,
    decisions: BTreeMap<ObserverId, Vec<Decision>>,
    broadcasts: Vec<Broadcast>,
    report: Option<MissionReport>,
    contacts: Option<SimContacts>,
    last_tick: u64,
    events: BTreeMap<String, u64>,
    packets: BTreeMap<String, u64>,
    empty_packets: BTreeMap<String, u64>,
}

/// Audits the recording at `path` (a run directory or an `.mcap` file).
pub fn audit_recording(path: &Path) -> Result<AuditReport> {
    let mut g = Gathered::default();
    let scanned = scan(path, |item| {
        match item.msg {
            Decoded::FrameEvent(f) => g.frames.entry(f.observer.clone()).or_default().push(f),
            Decoded::TokenEvent(t) => *g.tokens.entry(t.observer).or_default() += 1,
            Decoded::Decision(d) => g.decisions.entry(d.observer.clone()).or_default().push(d),
            Decoded::BroadcastTick(b) => g.broadcasts.extend(b.broadcast),
            Decoded::MissionReport(r) => g.report = Some(r),
            Decoded::SimContacts(c) if g.contacts.as_ref().is_none_or(|old| c.tick >= old.tick) => {
                g.contacts = Some(c);
            }
            Decoded::Clock(c) => g.last_tick = g.last_tick.max(c.tick),
            Decoded::EventPacket(p) => {
                let o = observer_of(item.topic);
                *g.packets.entry(o.clone()).or_default() += 1;
                *g.events.entry(o.clone()).or_default() += p.len() as u64;
                if p.is_empty() {
                    *g.empty_packets.entry(o).or_default() += 1;
                }
            }
            Decoded::RgbFrame(_) => *g.packets.entry(observer_of(item.topic)).or_default() += 1,
            _ => {}
        }
        Ok(())
    })?;
    let case = scanned.case()?;
    let info = &scanned.info;
    let n = match (info.observers, &case) {
        (0, Some(c)) => c.observers,
        (n, _) => n,
    };
    let partial = !scanned.outcome.complete;
    let report = g.report.clone();
    let departures: BTreeMap<(ObserverId, u32), u64> = report
        .iter()
        .flat_map(|r| r.departures.iter())
        .map(|d| ((d.observer.clone(), d.round), d.t_ns))
        .collect();
    let mut observers = BTreeMap::new();
    let mut violations = Vec::new();
    let mut assignments_audited = 0;
    let mut payloads = BTreeMap::new();
    for i in 0..n {
        let id = ObserverId::from_index(i);
        let mut frames = g.frames.remove(&id).unwrap_or_default();
        frames.sort_by_key(|f| f.seq);
        let released: Vec<_> = frames.iter().map(|f| f.frame.clone()).collect();
        let decisions = g.decisions.remove(&id).unwrap_or_default();
        let services = report
            .as_ref()
            .and_then(|r| r.services.get(&id).cloned())
            .unwrap_or_default();
        let summary = ObserverSummary::from_record(
            &released,
            &decisions,
            &services,
            g.tokens.get(&id).copied().unwrap_or(0),
        );
        payloads.insert(id.to_string(), summary.payloads.clone());
        observers.insert(id.to_string(), summary);
        assignments_audited += decisions
            .iter()
            .filter(|d| d.assignment.is_some() && departures.contains_key(&(id.clone(), d.round)))
            .count();
        violations.extend(audit(&decisions, &departures));
        g.frames.insert(id, frames);
    }
    let end_ns = report.as_ref().map_or(g.last_tick * TICK_NS, |r| r.end_ns);
    let mut mission = MissionSummary {
        case: info
            .case_name
            .clone()
            .or_else(|| case.as_ref().map(|c| c.name.clone()))
            .unwrap_or_default(),
        modality: info.modality.clone().unwrap_or_default(),
        observers,
        work_units: report.as_ref().map_or(0, |r| r.work_units),
        mission_time_s: ns_s(end_ns),
        end_reason: report
            .as_ref()
            .map_or("none (no mission report)".to_string(), |r| {
                r.end_reason.clone()
            }),
        contact_steps: g.contacts.as_ref().map_or(0, |c| c.contact_steps),
        min_separation_m: g.contacts.as_ref().map_or(f64::NAN, |c| c.min_separation_m),
        provenance_violations: violations,
        pass: false,
        reasons: Vec::new(),
        wall_seconds: f64::NAN,
    };
    let mut reasons = Vec::new();
    if let Some(problem) = &scanned.outcome.problem {
        reasons.push(format!("partial recording: {problem}"));
    }
    match &case {
        Some(c) => reasons.extend(check_expected(c, &mission)),
        None => reasons.push("the recording holds no case, so no expected outcome".into()),
    }
    if report.is_none() {
        reasons.push("no mission report from the scheduler in the recording".into());
    }
    if scanned.undecodable > 0 {
        reasons.push(format!(
            "{} recorded messages do not decode",
            scanned.undecodable
        ));
    }
    mission.pass = reasons.is_empty();
    let mut work_units_by_observer: BTreeMap<String, BTreeMap<String, u32>> = BTreeMap::new();
    let mut work_units_by_site: BTreeMap<String, u32> = BTreeMap::new();
    for (o, services) in report.iter().flat_map(|r| r.services.iter()) {
        let per = work_units_by_observer.entry(o.to_string()).or_default();
        for (_, site) in services {
            *per.entry(site.to_string()).or_default() += 1;
            *work_units_by_site.entry(site.to_string()).or_default() += 1;
        }
    }
    let timing = timing(&g.broadcasts, &g.frames, report.as_ref().map(|r| r.end_ns))?;
    Ok(AuditReport {
        partial,
        partial_reason: scanned.outcome.problem.clone(),
        case: mission.case.clone(),
        modality: mission.modality.clone(),
        session: info.session.clone(),
        mission_time_s: mission.mission_time_s,
        end_reason: mission.end_reason.clone(),
        messages: mission
            .observers
            .iter()
            .map(|(o, s)| (o.clone(), s.complete_messages))
            .collect(),
        payloads,
        work_units: mission.work_units,
        work_units_by_observer,
        work_units_by_site,
        contact_steps: mission.contact_steps,
        min_separation_m: mission.min_separation_m,
        timing,
        provenance_violations: mission.provenance_violations.clone(),
        assignments_audited,
        events_per_observer: g.events,
        packets_per_observer: g.packets,
        empty_packets_per_observer: g.empty_packets,
        undecodable_messages: scanned.undecodable,
        pass: mission.pass,
        reasons,
    })
}

/// `O1` from `/sensor/O1/events`.
fn observer_of(topic: &str) -> String {
    recording::topics::topic_observer(topic)
        .unwrap_or("?")
        .to_string()
}

/// The timing table from the recorded broadcasts and released frames.
fn timing(
    broadcasts: &[Broadcast],
    frames: &BTreeMap<ObserverId, Vec<FrameEvent>>,
    end_ns: Option<u64>,
) -> Result<Timing> {
    let gesture = GestureConfig::default();
    // (round, payload) → offer start.
    let mut starts: BTreeMap<(u32, u8), u64> = BTreeMap::new();
    let mut first: Option<u64> = None;
    for b in broadcasts {
        let payloads: Vec<u8> = b.offers.iter().map(Offer::to_payload).collect();
        if payloads.is_empty() {
            continue;
        }
        let schedule = match broadcast(b.start_ns, &payloads, b.acquisition, &gesture) {
            Ok(s) => s,
            Err(e) => bail!("rebuilding the broadcast of round {}: {e}", b.round),
        };
        for o in schedule.offers() {
            starts.entry((b.round, o.payload)).or_insert(o.start_ns);
            first = Some(first.map_or(o.start_ns, |f: u64| f.min(o.start_ns)));
        }
    }
    let mut per = BTreeMap::new();
    let mut latest: Option<u64> = None;
    for (o, fs) in frames {
        let mut v = Vec::new();
        for f in fs {
            let t = f.frame.final_null_ns();
            latest = latest.max(Some(t));
            if let Some(&s) = starts.get(&(f.round, f.frame.payload)) {
                v.push(ns_s(t.saturating_sub(s)));
            }
        }
        if !fs.is_empty() {
            per.insert(o.to_string(), v);
        }
    }
    Ok(Timing {
        first_offer_start_s: first.map(ns_s),
        offer_to_final_null_s: per,
        latest_final_reception_s: latest.map(ns_s),
        latest_reception_to_completion_s: match (end_ns, latest) {
            (Some(e), Some(l)) => Some(ns_s(e.saturating_sub(l))),
            _ => None,
        },
    })
}

fn print(r: &AuditReport) {
    println!(
        "audit of case {} ({}) session {} — {}{}",
        r.case,
        r.modality,
        r.session,
        if r.pass { "PASS" } else { "FAIL" },
        if r.partial {
            " (PARTIAL recording)"
        } else {
            ""
        }
    );
    println!(
        "mission time {:.2} s ({}) · work units {} {:?} · contact steps {} · minimum separation {:.3} m",
        r.mission_time_s,
        r.end_reason,
        r.work_units,
        r.work_units_by_site,
        r.contact_steps,
        r.min_separation_m
    );
    println!(
        "{:<4} {:>9} {:>28} {:>12} {:>10} {:>9}",
        "obs", "messages", "payloads", "work units", "events", "packets"
    );
    for (o, m) in &r.messages {
        println!(
            "{o:<4} {m:>9} {:>28} {:>12} {:>10} {:>9}",
            r.payloads.get(o).map_or(String::new(), |p| p.join(",")),
            r.work_units_by_observer.get(o).map_or("-".into(), |w| {
                w.iter()
                    .map(|(s, n)| format!("{s}:{n}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            }),
            r.events_per_observer.get(o).copied().unwrap_or(0),
            r.packets_per_observer.get(o).copied().unwrap_or(0)
        );
    }
    let t = &r.timing;
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3}"));
    println!("first offer start {} s", fmt(t.first_offer_start_s));
    for (o, v) in &t.offer_to_final_null_s {
        let list: Vec<String> = v.iter().map(|x| format!("{x:.3}")).collect();
        println!("  {o}: offer start to final NULL {} s", list.join(", "));
    }
    println!(
        "latest final reception {} s · latest reception to completion {} s",
        fmt(t.latest_final_reception_s),
        fmt(t.latest_reception_to_completion_s)
    );
    println!(
        "provenance: {} assignments audited, {} violations",
        r.assignments_audited,
        r.provenance_violations.len()
    );
    for reason in &r.reasons {
        println!("  ✗ {reason}");
    }
}

pub fn run(args: AuditArgs) -> Result<()> {
    let report = audit_recording(&args.path)?;
    if args.json {
        crate::summary::print_json(&report)?;
    } else {
        print(&report);
    }
    if !report.pass {
        bail!("audit failed: {}", report.reasons.join("; "));
    }
    Ok(())
}
