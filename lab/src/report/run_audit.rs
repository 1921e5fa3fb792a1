//! One run's audit ([`AuditReport`], what `waggle audit DIR --json` prints): from the
//! recording (`DIR/session.mcap`) through [`audit_recording`] when there is one, otherwise
//! built from what `waggle run` wrote (`summary.json`, `observers.json`, `session.json`).

use std::collections::BTreeMap;
use std::path::Path;

use proto::{Offer, Site};

use run_eval::audit::audit_recording;
use run_eval::summary::ns_s;
use run_format::case::Case;
use run_format::run_dir::audit::{AuditReport, AuditTiming};
use run_format::run_dir::session::SessionRecord;
use run_format::run_dir::{RECORDING_FILE, RunFiles};

/// Where an audit came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AuditSource {
    /// [`audit_recording`] on the run's recording.
    Recording,
    /// Built from `summary.json` and friends; the string says why the recording was not used.
    Summary(String),
}

/// The site a complete frame advertised.
fn frame_site(payload: u8) -> Option<Site> {
    Offer::from_payload(payload).ok().map(|o| o.site)
}

/// Builds the audit from `waggle run`'s files.
pub fn from_run_files(f: &RunFiles) -> AuditReport {
    let m = &f.summary.mission;
    let messages = m
        .observers
        .iter()
        .map(|(o, s)| (o.clone(), s.complete_messages))
        .collect();
    let mut by_observer: BTreeMap<String, BTreeMap<String, u32>> = BTreeMap::new();
    let mut by_site: BTreeMap<String, u32> = BTreeMap::new();
    for (o, s) in &m.observers {
        let mine = by_observer.entry(o.clone()).or_default();
        for site in &s.services {
            *mine.entry(site.clone()).or_default() += 1;
            *by_site.entry(site.clone()).or_default() += 1;
        }
    }
    let starts = f
        .session
        .as_ref()
        .map(SessionRecord::offer_starts_ns)
        .unwrap_or_default();
    let mut offer_to_final_null_s: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut latest_ns: Option<u64> = None;
    for (o, rec) in &f.observers {
        let mine = offer_to_final_null_s.entry(o.clone()).or_default();
        for fe in &rec.frames {
            let Some(site) = frame_site(fe.frame.payload) else {
                continue;
            };
            let final_ns = fe.frame.final_null_ns();
            latest_ns = latest_ns.max(Some(final_ns));
            if let Some(start) = starts.get(&(fe.round, site)) {
                mine.push(ns_s(final_ns.saturating_sub(*start)));
            }
        }
    }
    let latest = latest_ns.map(ns_s);
    let packets_per_observer = f
        .summary
        .sensor_digests
        .iter()
        .filter_map(|(o, d)| {
            let n = d
                .split_whitespace()
                .find_map(|w| w.strip_prefix("packets="))?
                .parse()
                .ok()?;
            Some((o.clone(), n))
        })
        .collect();
    AuditReport {
        rejects: f.summary.rejects.clone(),
        viewpoints: m.viewpoints.clone(),
        deaf_observers: m.deaf_observers.clone(),
        partial: f.summary.interrupted,
        partial_reason: f
            .summary
            .interrupted
            .then(|| "the run was interrupted".to_string()),
        case: m.case.clone(),
        modality: m.modality,
        session: f.summary.session.clone(),
        mission_time_s: m.mission_time_s,
        end_reason: m.end_reason,
        messages,
        payloads: m
            .observers
            .iter()
            .map(|(o, s)| (o.clone(), s.payloads.clone()))
            .collect(),
        work_units: m.work_units,
        work_units_by_observer: by_observer,
        work_units_by_site: by_site,
        contact_steps: m.contact_steps,
        min_separation_m: m.min_separation_m,
        timing: AuditTiming {
            first_offer_start_s: f
                .session
                .as_ref()
                .and_then(SessionRecord::first_offer_start_ns)
                .map(ns_s),
            offer_to_final_null_s,
            latest_final_reception_s: latest,
            latest_reception_to_completion_s: latest.map(|l| m.mission_time_s - l),
        },
        provenance_violations: m.provenance_violations.clone(),
        assignments_audited: 0,
        events_per_observer: BTreeMap::new(),
        packets_per_observer,
        empty_packets_per_observer: BTreeMap::new(),
        undecodable_messages: 0,
        pass: m.pass,
        reasons: m.reasons.clone(),
    }
}

/// Audits the run's recording when it has one; otherwise, or when the recording cannot be
/// audited, builds the audit from the run's files.
pub fn audit_run(dir: &Path, files: &RunFiles) -> (AuditReport, AuditSource) {
    if !dir.join(RECORDING_FILE).exists() {
        return (
            from_run_files(files),
            AuditSource::Summary(format!("no {RECORDING_FILE}")),
        );
    }
    match audit_recording(dir) {
        Ok(a) => (a, AuditSource::Recording),
        Err(e) => (
            from_run_files(files),
            AuditSource::Summary(format!("{e:#}")),
        ),
    }
}

/// Reasons the audit does not meet `case`'s expected outcome, beyond the audit's own verdict:
/// message counts and work units are checked again against the case file.
pub fn check_against_case(case: &Case, a: &AuditReport) -> Vec<String> {
    let mut out = Vec::new();
    if !a.pass {
        if a.reasons.is_empty() {
            out.push("the audit did not pass".to_string());
        }
        out.extend(a.reasons.iter().cloned());
    }
    if a.partial {
        out.push("partial run (interrupted or truncated recording)".into());
    }
    let got: Vec<usize> = (0..case.observers)
        .map(|i| {
            a.messages
                .get(&proto::scene::observer_name(i))
                .copied()
                .unwrap_or(0)
        })
        .collect();
    if got != case.expected.messages {
        let m = format!(
            "complete messages {got:?}, expected {:?}",
            case.expected.messages
        );
        if !out.contains(&m) {
            out.push(m);
        }
    }
    if a.work_units != case.expected.work_units {
        let m = format!(
            "{} work units, expected {}",
            a.work_units, case.expected.work_units
        );
        if !out.contains(&m) {
            out.push(m);
        }
    }
    if a.contact_steps != 0 && a.pass {
        out.push(format!("{} contact steps", a.contact_steps));
    }
    out
}
