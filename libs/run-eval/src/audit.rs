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
//! [`audit_recording`] is the library entry point (used by `waggle audit`, `waggle report` and
//! `waggle sweep`).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use proto::{
    Broadcast, Decision, FrameEvent, Key, MissionReport, ObserverId, Offer, SimContacts, TICK_NS,
};
use proto::{GestureConfig, broadcast};
use recording::Decoded;

use crate::recording::{Item, Scan, scan, topic_key, topic_observer};
use crate::summary::{check_expected, end_reason_text, ns_s, provenance_violations, receiver_text};
use run_format::case::Case;
use run_format::run_dir::audit::{AuditReport, AuditTiming};
use run_format::run_dir::{MissionSummary, ObserverSummary};

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
    rejects: BTreeMap<String, Vec<proto::RejectCount>>,
}

impl Gathered {
    fn take(&mut self, item: Item<'_>) {
        let observer = || topic_observer(item.topic).map_or("?".to_string(), |o| o.to_string());
        match &item.msg {
            Decoded::EventPacket(p) => {
                let o = observer();
                *self.packets.entry(o.clone()).or_default() += 1;
                *self.events.entry(o.clone()).or_default() += p.len() as u64;
                if p.is_empty() {
                    *self.empty_packets.entry(o).or_default() += 1;
                }
                return;
            }
            // An event camera's recorded input is not a packet it published.
            Decoded::RgbUpdate(_) if matches!(topic_key(item.topic), Some(Key::CameraInput(_))) => {
                return;
            }
            Decoded::RgbFrame(_) | Decoded::RgbUpdate(_) => {
                *self.packets.entry(observer()).or_default() += 1;
                return;
            }
            _ => {}
        }
        match item.msg {
            Decoded::FrameEvent(f) => self.frames.entry(f.observer.clone()).or_default().push(f),
            Decoded::TokenEvent(t) => *self.tokens.entry(t.observer).or_default() += 1,
            Decoded::Decision(d) => self
                .decisions
                .entry(d.observer.clone())
                .or_default()
                .push(d),
            Decoded::BroadcastTick(b) => self.broadcasts.extend(b.broadcast),
            Decoded::MissionReport(r) => self.report = Some(r),
            Decoded::SimContacts(c)
                if self.contacts.as_ref().is_none_or(|old| c.tick >= old.tick) =>
            {
                self.contacts = Some(c);
            }
            Decoded::Clock(c) => self.last_tick = self.last_tick.max(c.tick),
            Decoded::RejectReport(r) => {
                self.rejects.insert(r.process, r.counts);
            }
            _ => {}
        }
    }

    /// Each observer's summary (sorting its frames by sequence), with the audit figures.
    fn observers(&mut self, n: usize) -> Observers {
        let departures: BTreeMap<(ObserverId, u32), u64> = self
            .report
            .iter()
            .flat_map(|r| r.departures.iter())
            .map(|d| ((d.observer.clone(), d.round), d.t_ns))
            .collect();
        let mut out = Observers::default();
        for i in 0..n {
            let id = ObserverId::from_index(i);
            let mut frames = self.frames.remove(&id).unwrap_or_default();
            frames.sort_by_key(|f| f.seq);
            let decisions = self.decisions.remove(&id).unwrap_or_default();
            let services = self
                .report
                .as_ref()
                .and_then(|r| r.services.get(&id).cloned())
                .unwrap_or_default();
            let summary = ObserverSummary::from_record(
                &frames,
                &decisions,
                &services,
                self.tokens.get(&id).copied().unwrap_or(0),
            );
            out.payloads
                .insert(id.to_string(), summary.payloads.clone());
            out.summaries.insert(id.to_string(), summary);
            out.assignments_audited += decisions
                .iter()
                .filter(|d| {
                    d.assignment.is_some() && departures.contains_key(&(id.clone(), d.round))
                })
                .count();
            out.violations
                .extend(provenance_violations(&decisions, &departures));
            self.frames.insert(id, frames);
        }
        out
    }
}

/// The per-observer part of the audit.
#[derive(Default)]
struct Observers {
    summaries: BTreeMap<String, ObserverSummary>,
    payloads: BTreeMap<String, Vec<String>>,
    violations: Vec<String>,
    assignments_audited: usize,
}

/// Work units per observer and site, and per site.
fn work_units(
    report: Option<&MissionReport>,
) -> (
    BTreeMap<String, BTreeMap<String, u32>>,
    BTreeMap<String, u32>,
) {
    let mut by_observer: BTreeMap<String, BTreeMap<String, u32>> = BTreeMap::new();
    let mut by_site: BTreeMap<String, u32> = BTreeMap::new();
    for (o, services) in report.iter().flat_map(|r| r.services.iter()) {
        let per = by_observer.entry(o.to_string()).or_default();
        for (_, site) in services {
            *per.entry(site.to_string()).or_default() += 1;
            *by_site.entry(site.to_string()).or_default() += 1;
        }
    }
    (by_observer, by_site)
}

/// Why the recording does not meet its case's expected outcome (empty: it does).
fn reasons(
    scanned: &Scan,
    case: Option<&Case>,
    mission: &MissionSummary,
    has_report: bool,
) -> Vec<String> {
    let mut reasons = Vec::new();
    if let Some(problem) = &scanned.outcome.problem {
        reasons.push(format!("partial recording: {problem}"));
    }
    match case {
        Some(c) => reasons.extend(check_expected(c, mission)),
        None => reasons.push("the recording holds no case, so no expected outcome".into()),
    }
    if !has_report {
        reasons.push("no mission report from the scheduler in the recording".into());
    }
    if scanned.undecodable > 0 {
        reasons.push(format!(
            "{} recorded messages do not decode",
            scanned.undecodable
        ));
    }
    reasons
}

/// Audits the recording at `path` (a run directory or an `.mcap` file).
pub fn audit_recording(path: &Path) -> Result<AuditReport> {
    let mut g = Gathered::default();
    let scanned = scan(path, |item| {
        g.take(item);
        Ok(())
    })?;
    let case = scanned.case()?;
    let info = &scanned.info;
    // A recording of the event cameras' input counts their packets from the recorder's account
    // of what it received.
    if info.events_from_input
        && let Some(received) = crate::recording::received(&scanned.outcome.metadata)?
    {
        for (o, r) in received {
            g.packets.insert(o.clone(), r.packets);
            g.events.insert(o, r.events);
        }
    }
    let n = match (info.observers, &case) {
        (0, Some(c)) => c.observers,
        (n, _) => n,
    };
    let modality: Option<proto::Receiver> = info
        .modality
        .as_deref()
        .map(str::parse)
        .transpose()
        .with_context(|| format!("{}: the recording's session metadata", path.display()))?;
    let obs = g.observers(n);
    let report = g.report.clone();
    let end_ns = report.as_ref().map_or(g.last_tick * TICK_NS, |r| r.end_ns);
    let mut mission = MissionSummary {
        case: info
            .case_name
            .clone()
            .or_else(|| case.as_ref().map(|c| c.name.clone()))
            .unwrap_or_default(),
        modality,
        observers: obs.summaries,
        work_units: report.as_ref().map_or(0, |r| r.work_units),
        mission_time_s: ns_s(end_ns),
        end_reason: report.as_ref().map(|r| r.end_reason),
        contact_steps: g.contacts.as_ref().map_or(0, |c| c.contact_steps),
        min_separation_m: g.contacts.as_ref().map_or(f64::NAN, |c| c.min_separation_m),
        provenance_violations: obs.violations,
        pass: false,
        reasons: Vec::new(),
        wall_seconds: f64::NAN,
        viewpoints: BTreeMap::new(),
        deaf_observers: Vec::new(),
        flights: proto::FlightMode::default(),
        false_releases: Vec::new(),
    };
    mission.false_releases = crate::summary::false_releases(
        g.frames.values().flatten(),
        &crate::summary::flown_payloads(&g.broadcasts),
    );
    crate::summary::annotate(&mut mission, n);
    if let Some(c) = &case {
        mission.flights = c.flights;
    }
    let reasons = reasons(&scanned, case.as_ref(), &mission, report.is_some());
    mission.pass = reasons.is_empty();
    let (work_units_by_observer, work_units_by_site) = work_units(report.as_ref());
    let check = case.as_ref().map(|c| c.frame_check).unwrap_or_default();
    let timing = timing(
        &g.broadcasts,
        &g.frames,
        report.as_ref().map(|r| r.end_ns),
        check,
    )?;
    Ok(AuditReport {
        partial: !scanned.outcome.complete,
        partial_reason: scanned.outcome.problem.clone(),
        case: mission.case,
        modality: mission.modality,
        session: info.session.clone(),
        mission_time_s: mission.mission_time_s,
        end_reason: mission.end_reason,
        messages: mission
            .observers
            .iter()
            .map(|(o, s)| (o.clone(), s.complete_messages))
            .collect(),
        payloads: obs.payloads,
        work_units: mission.work_units,
        work_units_by_observer,
        work_units_by_site,
        contact_steps: mission.contact_steps,
        min_separation_m: mission.min_separation_m,
        timing,
        provenance_violations: mission.provenance_violations,
        assignments_audited: obs.assignments_audited,
        events_per_observer: g.events,
        packets_per_observer: g.packets,
        empty_packets_per_observer: g.empty_packets,
        undecodable_messages: scanned.undecodable,
        rejects: g.rejects,
        viewpoints: mission.viewpoints,
        deaf_observers: mission.deaf_observers,
        pass: mission.pass,
        reasons,
    })
}

/// The timing table from the recorded broadcasts and released frames.
fn timing(
    broadcasts: &[Broadcast],
    frames: &BTreeMap<ObserverId, Vec<FrameEvent>>,
    end_ns: Option<u64>,
    check: proto::FrameCheck,
) -> Result<AuditTiming> {
    let gesture = GestureConfig::default();
    // (round, payload) → offer start.
    let mut starts: BTreeMap<(u32, u8), u64> = BTreeMap::new();
    let mut first: Option<u64> = None;
    for b in broadcasts {
        let payloads: Vec<u8> = b.offers.iter().map(Offer::to_payload).collect();
        if payloads.is_empty() {
            continue;
        }
        let schedule = match broadcast(b.start_ns, &payloads, b.acquisition, &gesture, check) {
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
    Ok(AuditTiming {
        first_offer_start_s: first.map(ns_s),
        offer_to_final_null_s: per,
        latest_final_reception_s: latest.map(ns_s),
        latest_reception_to_completion_s: match (end_ns, latest) {
            (Some(e), Some(l)) => Some(ns_s(e.saturating_sub(l))),
            _ => None,
        },
    })
}

/// Prints the audit as tables (`waggle audit` without `--json`).
pub fn print_audit(r: &AuditReport) {
    println!(
        "audit of case {} ({}) session {} — {}{}",
        r.case,
        receiver_text(r.modality),
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
        end_reason_text(r.end_reason),
        r.work_units,
        r.work_units_by_site,
        r.contact_steps,
        r.min_separation_m
    );
    println!(
        "{:<4} {:>13} {:>9} {:>28} {:>12} {:>10} {:>9}",
        "obs", "view", "messages", "payloads", "work units", "events", "packets"
    );
    for (o, m) in &r.messages {
        let view = r.viewpoints.get(o).map_or(String::new(), |v| {
            format!("{:.0}° {:.2} m", v.viewing_angle_deg, v.distance_m)
        });
        println!(
            "{o:<4} {view:>13} {m:>9} {:>28} {:>12} {:>10} {:>9}",
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
    if let Some(w) = crate::summary::deaf_warning(&r.deaf_observers, &r.viewpoints) {
        println!("  ⚠ {w}");
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
    println!(
        "{} · undecodable in the recording: {}",
        crate::summary::rejects_line(&r.rejects),
        r.undecodable_messages
    );
    for reason in &r.reasons {
        println!("  ✗ {reason}");
    }
}
