//! The audit report: what `waggle audit --json` prints, and what the session report reads for
//! each run (from the recording, or rebuilt from the run's JSON files).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::null_as_nan;

/// The timing table (simulation seconds).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AuditTiming {
    /// Start of the first offer frame of the mission (after any acquisition motion); `None`
    /// when nothing was broadcast.
    #[serde(default)]
    pub first_offer_start_s: Option<f64>,
    /// Per observer, for each released frame matched to its broadcast offer (same round,
    /// same payload), final NULL minus offer start, in release order.
    #[serde(default)]
    pub offer_to_final_null_s: BTreeMap<String, Vec<f64>>,
    /// Latest final-NULL time of any released frame.
    #[serde(default)]
    pub latest_final_reception_s: Option<f64>,
    /// Mission end minus the latest final reception.
    #[serde(default)]
    pub latest_reception_to_completion_s: Option<f64>,
}

/// What `waggle audit --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AuditReport {
    /// The recording was cut short or damaged (or the run interrupted): figures cover what
    /// could be read.
    pub partial: bool,
    /// Why it is partial.
    #[serde(default)]
    pub partial_reason: Option<String>,
    pub case: String,
    /// `rgb` or `events`.
    /// `null` when the recording was cut before its session metadata.
    pub modality: Option<proto::Receiver>,
    #[serde(default)]
    pub session: String,
    pub mission_time_s: f64,
    /// Why the mission ended; `null` when the recording holds no mission report.
    pub end_reason: Option<proto::EndReason>,
    /// Complete messages per observer.
    pub messages: BTreeMap<String, usize>,
    #[serde(default)]
    pub payloads: BTreeMap<String, Vec<String>>,
    pub work_units: u32,
    #[serde(default)]
    pub work_units_by_observer: BTreeMap<String, BTreeMap<String, u32>>,
    #[serde(default)]
    pub work_units_by_site: BTreeMap<String, u32>,
    pub contact_steps: u64,
    /// NaN (JSON `null`) when the simulator reported no separation.
    #[serde(deserialize_with = "null_as_nan")]
    pub min_separation_m: f64,
    #[serde(default)]
    pub timing: AuditTiming,
    #[serde(default)]
    pub provenance_violations: Vec<String>,
    /// Assignments audited for provenance (decisions with an assignment and a departure).
    #[serde(default)]
    pub assignments_audited: usize,
    #[serde(default)]
    pub events_per_observer: BTreeMap<String, u64>,
    #[serde(default)]
    pub packets_per_observer: BTreeMap<String, u64>,
    #[serde(default)]
    pub empty_packets_per_observer: BTreeMap<String, u64>,
    #[serde(default)]
    pub undecodable_messages: u64,
    /// What each process reported it dropped (its recorded `rejects/<role>/<id>` message).
    #[serde(default)]
    pub rejects: BTreeMap<String, Vec<proto::RejectCount>>,
    /// Each observer's viewing angle and distance (its home in the case's formation).
    #[serde(default)]
    pub viewpoints: BTreeMap<String, super::ObserverViewpoint>,
    /// Observers that released no frame while others released some.
    #[serde(default)]
    pub deaf_observers: Vec<String>,
    pub pass: bool,
    #[serde(default)]
    pub reasons: Vec<String>,
}

impl AuditReport {
    /// The minimum separation, when the simulator reported one.
    pub fn min_separation(&self) -> Option<f64> {
        self.min_separation_m
            .is_finite()
            .then_some(self.min_separation_m)
    }
}
