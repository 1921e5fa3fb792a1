//! One run's audit, in the JSON shape of `waggle audit DIR --json`: taken from that command
//! when it exists and the run has a recording (`DIR/session.mcap`), otherwise built from what
//! `waggle run` wrote (`summary.json`, `observers.json`, `session.json`).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};

use anyhow::{Context, Result};
use proto::{Offer, Site};
use serde::{Deserialize, Serialize};

use crate::case::Case;
use crate::report::record::SessionRecord;
use crate::run::{ObserverRecord, RunSummary};
use crate::summary::ns_s;

/// `timing` of the audit JSON (simulation seconds).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AuditTiming {
    /// Start of the first offer's frame; `None` when nothing was broadcast.
    #[serde(default)]
    pub first_offer_start_s: Option<f64>,
    /// Per observer, for each complete frame: its offer's start to its final NULL.
    #[serde(default)]
    pub offer_to_final_null_s: BTreeMap<String, Vec<f64>>,
    #[serde(default)]
    pub latest_final_reception_s: Option<f64>,
    #[serde(default)]
    pub latest_reception_to_completion_s: Option<f64>,
}

/// The JSON of `waggle audit DIR --json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AuditReport {
    /// The run did not reach its end (interrupted, or a truncated recording).
    pub partial: bool,
    pub case: String,
    /// `rgb` or `events`.
    pub modality: String,
    pub mission_time_s: f64,
    pub end_reason: String,
    /// Complete messages per observer.
    pub messages: BTreeMap<String, usize>,
    pub work_units: u32,
    #[serde(default)]
    pub work_units_by_observer: BTreeMap<String, BTreeMap<String, u32>>,
    #[serde(default)]
    pub work_units_by_site: BTreeMap<String, u32>,
    pub contact_steps: u64,
    /// `None` when the simulator reported no separation (JSON `null`).
    pub min_separation_m: Option<f64>,
    #[serde(default)]
    pub timing: AuditTiming,
    #[serde(default)]
    pub provenance_violations: Vec<String>,
    #[serde(default)]
    pub events_per_observer: BTreeMap<String, u64>,
    #[serde(default)]
    pub packets_per_observer: BTreeMap<String, u64>,
    pub pass: bool,
    #[serde(default)]
    pub reasons: Vec<String>,
}

/// Where an audit came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AuditSource {
    /// `waggle audit DIR --json` on the recording.
    Recording,
    /// Built from `summary.json` and friends; the string says why the recording was not used.
    Summary(String),
}

/// Everything `waggle run` wrote into a run directory.
#[derive(Debug, Clone)]
pub struct RunFiles {
    pub summary: RunSummary,
    pub observers: BTreeMap<String, ObserverRecord>,
    /// Absent for runs made before the launcher wrote it.
    pub session: Option<SessionRecord>,
}

impl RunFiles {
    pub fn load(dir: &Path) -> Result<Self> {
        let read = |name: &str| -> Result<String> {
            let p = dir.join(name);
            std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))
        };
        let summary: RunSummary = serde_json::from_str(&read("summary.json")?)
            .with_context(|| format!("parsing {}/summary.json", dir.display()))?;
        let observers = serde_json::from_str(&read("observers.json")?)
            .with_context(|| format!("parsing {}/observers.json", dir.display()))?;
        let session = match dir.join("session.json").exists() {
            true => Some(
                serde_json::from_str(&read("session.json")?)
                    .with_context(|| format!("parsing {}/session.json", dir.display()))?,
            ),
            false => None,
        };
        Ok(Self {
            summary,
            observers,
            session,
        })
    }
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
        partial: f.summary.interrupted,
        case: m.case.clone(),
        modality: m.modality.clone(),
        mission_time_s: m.mission_time_s,
        end_reason: m.end_reason.clone(),
        messages,
        work_units: m.work_units,
        work_units_by_observer: by_observer,
        work_units_by_site: by_site,
        contact_steps: m.contact_steps,
        min_separation_m: m.min_separation_m.is_finite().then_some(m.min_separation_m),
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
        events_per_observer: BTreeMap::new(),
        packets_per_observer,
        pass: m.pass,
        reasons: m.reasons.clone(),
    }
}

/// Runs `waggle audit DIR --json` (this executable) when the run has a recording and the
/// command exists; otherwise, or when it gives no parsable answer, builds the audit from the
/// run's files.
pub fn audit_run(dir: &Path, files: &RunFiles) -> (AuditReport, AuditSource) {
    if !dir.join("session.mcap").exists() {
        return (
            from_run_files(files),
            AuditSource::Summary("no session.mcap".into()),
        );
    }
    let why = match audit_command(dir) {
        Ok(a) => return (a, AuditSource::Recording),
        Err(e) => format!("{e:#}"),
    };
    (from_run_files(files), AuditSource::Summary(why))
}

fn audit_command(dir: &Path) -> Result<AuditReport> {
    let exe = std::env::current_exe().context("locating waggle")?;
    let out = Command::new(exe)
        .arg("audit")
        .arg(dir)
        .arg("--json")
        .stdin(Stdio::null())
        .output()
        .context("starting waggle audit")?;
    // A failing case still prints its JSON (and exits non-zero): parse stdout either way.
    serde_json::from_slice(&out.stdout).with_context(|| {
        let err = String::from_utf8_lossy(&out.stderr);
        format!(
            "waggle audit gave no audit JSON ({}): {}",
            out.status,
            err.lines().last().unwrap_or("")
        )
    })
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
