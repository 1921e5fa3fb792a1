//! What `waggle trials` writes: `trials.json`'s records (no wall-clock value: same seed, same
//! file) and `cost.json`'s wall-clock figures.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::harness::trials::pool::{Outcome, Tally};

pub use run_format::trial_record::{
    ObserverTrial, PluginFailure, TokenTiming, TrialFlight, TrialRecord,
};

impl Outcome for TrialRecord {
    fn index(&self) -> u64 {
        self.index
    }
    fn success(&self) -> bool {
        self.success
    }
}

/// Means over the finished trials.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrialsSummary {
    pub mean_token_error_ms: Option<f64>,
    pub mean_latency_s: Option<f64>,
    pub messages_lost: u64,
    /// Trials a plug-in receiver failed (raised, malformed output, died), when any.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub plugin_failed: u64,
    /// Trials a plug-in receiver ran past the time limit, when any.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub plugin_timed_out: u64,
    /// `false` when a wall clock decided an outcome (a trial timed out): the same seed may
    /// not give the same file. Absent when nothing but the seed decided.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reproducible: Option<bool>,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// What `trials.json` holds (no wall-clock value: same seed, same file): the header's fields,
/// then the tally, the summary and every trial.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrialsOut {
    #[serde(flatten)]
    pub header: TrialsHeader,
    #[serde(flatten)]
    pub tally: Tally,
    pub summary: TrialsSummary,
    pub per_trial: Vec<TrialRecord>,
}

/// Everything `trials.json` holds besides the tally and the trials: the condition and the
/// reference, fixed once the flight is flown (`point.json` beside the per-trial records).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrialsHeader {
    pub criterion: String,
    pub link: Vec<String>,
    pub observers: usize,
    pub placements: BTreeMap<String, PlacementOut>,
    pub modality: String,
    pub perturb: BTreeMap<String, f64>,
    pub flight: String,
    pub seed: u64,
    pub ideal_released: BTreeMap<String, Vec<String>>,
    /// The real-noise source (`--real-noise`), when one was laid over the event sensor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub real_noise: Option<RealNoiseOut>,
}

/// A real-noise source as `trials.json` records it: which file (by digest) and which of its
/// events were taken as background.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RealNoiseOut {
    pub file: String,
    pub sha256: String,
    /// `isolated`, or `static START_NS–END_NS` (the recording's clock).
    pub background: String,
    pub background_events: u64,
    pub background_s: f64,
    pub size_px: [u16; 2],
}

impl RealNoiseOut {
    pub fn of(source: &event_camera::real_noise::RealNoise) -> Self {
        use event_camera::fit::Background;
        Self {
            file: source.name.clone(),
            sha256: source.digest.clone(),
            background: match source.fitted.background {
                Background::Isolated => "isolated".to_owned(),
                Background::Static { start_ns, end_ns } => format!("static {start_ns}–{end_ns}"),
            },
            background_events: source.len() as u64,
            background_s: source.duration_ns as f64 * 1e-9,
            size_px: [source.width, source.height],
        }
    }
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

impl TrialsOut {
    /// `trials.json` of `requested` trials from its header and the finished records (sorted by
    /// index here, so the file does not depend on which process or thread ran which trial).
    pub fn assemble(header: TrialsHeader, requested: u64, mut per_trial: Vec<TrialRecord>) -> Self {
        per_trial.sort_by_key(|r| r.index);
        let tally = Tally::of(&per_trial, requested);
        let all_observers = || per_trial.iter().flat_map(|r| r.observers.values());
        let failures = |outcome: &str| {
            per_trial
                .iter()
                .filter(|r| {
                    r.plugin_failure
                        .as_ref()
                        .is_some_and(|f| f.outcome == outcome)
                })
                .count() as u64
        };
        let summary = TrialsSummary {
            mean_token_error_ms: mean(
                all_observers().filter_map(|o| o.token_timing.mean_abs_error_ms),
            ),
            mean_latency_s: mean(all_observers().flat_map(|o| o.latency_s.iter().copied())),
            messages_lost: all_observers().map(|o| o.messages_lost).sum(),
            plugin_failed: failures("failed"),
            plugin_timed_out: failures("timed-out"),
            reproducible: (failures("timed-out") > 0).then_some(false),
        };
        Self {
            header,
            tally,
            summary,
            per_trial,
        }
    }
}

/// An observer's placement as `trials.json` records it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct PlacementOut {
    pub home_m: [f64; 3],
    pub yaw_deg: f64,
    pub camera_pitch_deg: f64,
}

/// Wall-clock figures of a run, reported beside (never inside) `trials.json`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TrialsCost {
    /// Flights used (flown, or read from the render cache).
    pub flights: u64,
    /// Of them, read from the render cache on disk.
    pub flights_from_cache: u64,
    pub fly_and_render_s: f64,
    pub trials_s: f64,
    pub render_cache_mb: f64,
}
