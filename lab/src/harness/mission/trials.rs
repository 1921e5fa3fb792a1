//! Seeded repeated trials of a whole mission (`waggle trials --case`): the case flown in one
//! process N times, each under its own draw of the perturbation; success is the case's expected
//! outcome (checked as `waggle mission` checks it). Each trial re-flies physics and rendering,
//! so a trial costs a whole in-process mission.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, bail};
use perturb::Perturbation;
use perturb::seed::trial_seed;
use proto::RenderPath;
use serde::{Deserialize, Serialize};

use crate::harness::mission::metrics::MissionMetrics;
use crate::harness::mission::{MissionOptions, MissionRun, fly_case_with};
use crate::harness::runs::records::Recordable;
use crate::harness::trials::pool::{Outcome, Tally, run_pool_on};
use commands::Policy;
use proto::Receiver;
use run_format::case::Case;
use run_format::run_dir::{FalseRelease, ObserverSummary, OfferReception};

/// One case and how many times to fly it.
#[derive(Debug, Clone)]
pub struct MissionTrialsOptions {
    pub case: Case,
    pub modality: Receiver,
    pub policy: Policy,
    pub trials: u64,
    pub seed: u64,
    pub perturbation: Perturbation,
    pub jobs: usize,
    pub render: RenderPath,
}

/// One flown mission.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MissionTrial {
    pub index: u64,
    pub seed: u64,
    pub success: bool,
    /// Why the case's expected outcome was missed (empty on success).
    pub reasons: Vec<String>,
    pub end_reason: Option<proto::EndReason>,
    pub metrics: MissionMetrics,
    pub observers: BTreeMap<String, ObserverSummary>,
    pub min_separation_m: f64,
    pub contact_steps: u64,
    /// Released payloads the performer did not fly in their round (omitted when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub false_releases: Vec<FalseRelease>,
    /// What became of the offers flown to each observer (received, lost, false releases).
    #[serde(default)]
    pub receptions: BTreeMap<String, OfferReception>,
}

impl Recordable for MissionTrial {
    fn record_index(&self) -> u64 {
        self.index
    }
}

impl Outcome for MissionTrial {
    fn index(&self) -> u64 {
        self.index
    }
    fn success(&self) -> bool {
        self.success
    }
}

/// What `trials.json` holds for `--case` (no wall-clock value).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MissionTrialsOut {
    pub criterion: String,
    pub case: String,
    pub modality: Receiver,
    pub policy: Policy,
    pub perturb: BTreeMap<String, f64>,
    pub seed: u64,
    #[serde(flatten)]
    pub tally: Tally,
    /// False releases over every mission, and the missions with one (omitted when none).
    #[serde(skip_serializing_if = "FalseReleaseTally::is_none")]
    pub false_releases: FalseReleaseTally,
    /// Each observer's offers over every mission: flown, received, lost, falsely released.
    pub receptions: BTreeMap<String, OfferReception>,
    pub per_trial: Vec<MissionTrial>,
}

/// How often missions released a payload that was not flown.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct FalseReleaseTally {
    pub releases: u64,
    pub missions: u64,
}

impl FalseReleaseTally {
    fn of(per_trial: &[MissionTrial]) -> Self {
        Self {
            releases: per_trial
                .iter()
                .map(|t| t.false_releases.len() as u64)
                .sum(),
            missions: per_trial
                .iter()
                .filter(|t| !t.false_releases.is_empty())
                .count() as u64,
        }
    }

    pub fn is_none(&self) -> bool {
        self.releases == 0
    }
}

/// The criterion printed before the first trial and recorded in `trials.json`.
pub fn mission_criterion(opts: &MissionTrialsOptions) -> String {
    format!(
        "success = case {}'s expected outcome (messages, work units, services per observer, \
         no contact, provenance, no false release)",
        opts.case.name
    )
}

/// Flies the trials `indices` (up to `opts.jobs` at once), calling `on_record` as each ends
/// (from the thread that flew it: where a record is written) and then `progress(done,
/// successes)`. When `stop` is raised, flying trials are abandoned and no more start.
pub fn run_mission_trials_on(
    opts: &MissionTrialsOptions,
    indices: &[u64],
    stop: &Arc<AtomicBool>,
    on_record: impl Fn(&MissionTrial) -> Result<()> + Sync,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<Vec<MissionTrial>> {
    if opts.trials == 0 {
        bail!("--trials must be at least 1");
    }
    MissionOptions {
        perturbation: opts.perturbation.clone(),
        ..MissionOptions::default()
    }
    .check(opts.modality)?;
    run_pool_on(
        indices,
        opts.jobs,
        stop,
        |index| {
            let seed = trial_seed(opts.seed, index);
            let mission = MissionOptions {
                render: opts.render,
                policy: opts.policy,
                perturbation: opts.perturbation.clone(),
                seed,
                stop: Some(Arc::clone(stop)),
                ..MissionOptions::default()
            };
            let Some(MissionRun {
                summary,
                metrics,
                receptions,
                ..
            }) = fly_case_with(&opts.case, opts.modality, &mission)?
            else {
                return Ok(None);
            };
            let trial = MissionTrial {
                index,
                seed,
                success: summary.pass,
                reasons: summary.reasons,
                end_reason: summary.end_reason,
                metrics,
                observers: summary.observers,
                min_separation_m: summary.min_separation_m,
                contact_steps: summary.contact_steps,
                false_releases: summary.false_releases,
                receptions,
            };
            on_record(&trial)?;
            Ok(Some(trial))
        },
        progress,
    )
}

/// What `trials.json` holds for `opts`' trials `per_trial` (sorted here by index).
pub fn mission_trials_out(
    opts: &MissionTrialsOptions,
    mut per_trial: Vec<MissionTrial>,
) -> MissionTrialsOut {
    per_trial.sort_by_key(|t| t.index);
    let tally = Tally::of(&per_trial, opts.trials);
    let mut receptions: BTreeMap<String, OfferReception> = BTreeMap::new();
    for (o, r) in per_trial.iter().flat_map(|t| &t.receptions) {
        *receptions.entry(o.clone()).or_default() += *r;
    }
    MissionTrialsOut {
        false_releases: FalseReleaseTally::of(&per_trial),
        receptions,
        criterion: mission_criterion(opts),
        case: opts.case.name.clone(),
        modality: opts.modality,
        policy: opts.policy,
        perturb: opts.perturbation.recorded(),
        seed: opts.seed,
        tally,
        per_trial,
    }
}

/// What `run.json` holds for `waggle trials --case` (JSON): the case's text, so a merge on
/// another machine rebuilds exactly the options it ran with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionsDefinition {
    /// The case as given (a built-in name or a path), and its text.
    pub case: String,
    pub case_text: String,
    pub modality: Receiver,
    pub policy: Policy,
    pub seed: u64,
    pub perturb: BTreeMap<String, f64>,
    /// `--max-broadcasts`, when it overrode the case's own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_broadcasts: Option<u32>,
    /// `--frame-check`, when it overrode the case's own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_check: Option<proto::FrameCheck>,
}

impl MissionsDefinition {
    /// The definition of `opts`, whose case was given as `case` with text `case_text` (and
    /// `opts.case` may carry a `--max-broadcasts` override of it).
    pub fn of(opts: &MissionTrialsOptions, case: &str, case_text: &str) -> Result<Self> {
        let written = Case::from_text(case_text, case)?;
        Ok(Self {
            case: case.to_string(),
            case_text: case_text.to_string(),
            modality: opts.modality,
            policy: opts.policy,
            seed: opts.seed,
            perturb: opts.perturbation.recorded(),
            max_broadcasts: (opts.case.max_broadcasts != written.max_broadcasts)
                .then_some(opts.case.max_broadcasts),
            frame_check: (opts.case.frame_check != written.frame_check)
                .then_some(opts.case.frame_check),
        })
    }

    /// As `run.json`'s `definition`.
    ///
    /// # Errors
    ///
    /// Never in practice (JSON of plain fields).
    pub fn to_text(&self) -> Result<String> {
        Ok(serde_json::to_string(self)?)
    }

    /// The options it describes, `trials` per run (one job, the default render path: neither
    /// changes a result).
    ///
    /// # Errors
    ///
    /// A definition that does not parse, a case or a term that does not load.
    pub fn options(text: &str, trials: u64) -> Result<MissionTrialsOptions> {
        let d: Self = serde_json::from_str(text).context("run.json: the definition")?;
        let mut perturbation = Perturbation::default();
        for (k, v) in &d.perturb {
            perturbation.set(k, *v).context("run.json: perturb")?;
        }
        perturbation.check().context("run.json: perturb")?;
        let mut case = Case::from_text(&d.case_text, &d.case)?;
        if let Some(n) = d.max_broadcasts {
            case.max_broadcasts = n;
        }
        if let Some(c) = d.frame_check {
            case.frame_check = c;
        }
        Ok(MissionTrialsOptions {
            case,
            modality: d.modality,
            policy: d.policy,
            trials,
            seed: d.seed,
            perturbation,
            jobs: 1,
            render: RenderPath::default(),
        })
    }
}
