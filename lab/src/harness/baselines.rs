//! The `baselines` study: whole missions under each allocation arm — Waggle with RGB or event
//! cameras, the ideal-message receiver (ground truth in every camera) and the fixed-allocation
//! policy (no communication) — with the outcome measures of [`MissionMetrics`] side by side.
//!
//! ```toml
//! name = "baselines"
//! cases = ["nominal-3"]
//! arms = ["ideal", "fixed", "rgb", "events"]
//! trials = 1          # per case × arm; > 1 only makes sense with a perturbation
//! seed = 1
//! perturb = {}        # e.g. { "flight.gust_sigma_n" = 0.005 }
//! ```

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use perturb::Perturbation;
use proto::RenderPath;
use serde::{Deserialize, Serialize};

use crate::harness::mission::MissionOptions;
use crate::harness::mission_metrics::Policy;
use crate::harness::mission_trials::{MissionTrialsOptions, MissionTrialsOut, run_mission_trials};
use run_format::case::{Case, Receiver};

/// One way of allocating tasks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Arm {
    /// Waggle, observers with RGB cameras.
    Rgb,
    /// Waggle, observers with event cameras.
    Events,
    /// Waggle with the ideal-message receiver (the communication upper bound).
    Ideal,
    /// Fixed allocation, no communication.
    Fixed,
}

impl Arm {
    fn receiver_and_policy(self) -> (Receiver, Policy) {
        match self {
            Arm::Rgb => (Receiver::Rgb, Policy::Waggle),
            Arm::Events => (Receiver::Events, Policy::Waggle),
            Arm::Ideal => (Receiver::Ideal, Policy::Waggle),
            Arm::Fixed => (Receiver::Ideal, Policy::Fixed),
        }
    }

    fn label(self) -> &'static str {
        match self {
            Arm::Rgb => "waggle-rgb",
            Arm::Events => "waggle-events",
            Arm::Ideal => "ideal-message",
            Arm::Fixed => "fixed-allocation",
        }
    }
}

/// A baselines study file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BaselineStudy {
    pub name: String,
    pub cases: Vec<String>,
    pub arms: Vec<Arm>,
    pub trials: u64,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub perturb: BTreeMap<String, f64>,
}

/// Means over one arm's trials of one case.
#[derive(Debug, Clone, Serialize)]
pub struct ArmResult {
    pub case: String,
    pub arm: String,
    pub trials: u64,
    pub successes: u64,
    pub ci95: [f64; 2],
    pub work_units: f64,
    pub reward: f64,
    pub unserved_capacity: f64,
    pub completion_time_s: f64,
    pub wasted_trips: f64,
    /// Mean over every withdrawal response that was a reassignment (`null`: none was).
    pub reassignment_delay_s: Option<f64>,
    /// Withdrawal responses that were not reassignments.
    pub not_reassigned: usize,
    pub broadcast_symbols: f64,
    pub broadcast_s: f64,
}

impl BaselineStudy {
    /// Checks every field: cases load, arms apply, perturbation terms are known and in range.
    pub fn check(&self) -> Result<Perturbation> {
        if self.cases.is_empty() || self.arms.is_empty() {
            bail!("cases and arms must not be empty");
        }
        if self.trials == 0 {
            bail!("trials must be at least 1");
        }
        let mut p = Perturbation::default();
        for (k, v) in &self.perturb {
            p.set(k, *v).context("perturb")?;
        }
        MissionOptions {
            perturbation: p.clone(),
            ..MissionOptions::default()
        }
        .check()?;
        for c in &self.cases {
            let case = Case::load(c).with_context(|| format!("cases: {c}"))?;
            for arm in &self.arms {
                let (receiver, _) = arm.receiver_and_policy();
                if receiver != Receiver::Ideal && !case.modalities.contains(&receiver) {
                    bail!(
                        "arm {:?} does not apply to case {} (it lists {:?})",
                        arm,
                        case.name,
                        case.modalities
                    );
                }
            }
        }
        Ok(p)
    }
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

fn arm_result(case: &str, arm: Arm, out: &MissionTrialsOut) -> ArmResult {
    let m = || out.per_trial.iter().map(|t| &t.metrics);
    let avg = |f: &dyn Fn(&crate::harness::mission_metrics::MissionMetrics) -> f64| {
        mean(m().map(f)).unwrap_or(f64::NAN)
    };
    let responses = || m().flat_map(|x| x.reassignments.iter());
    ArmResult {
        case: case.to_owned(),
        arm: arm.label().to_owned(),
        trials: out.tally.trials,
        successes: out.tally.successes,
        ci95: out.tally.ci95,
        work_units: avg(&|x| f64::from(x.work_units)),
        reward: avg(&|x| x.reward as f64),
        unserved_capacity: avg(&|x| f64::from(x.unserved_capacity)),
        completion_time_s: avg(&|x| x.completion_time_s),
        wasted_trips: avg(&|x| f64::from(x.wasted_trips)),
        reassignment_delay_s: mean(responses().filter_map(|r| r.delay_s)),
        not_reassigned: responses().filter(|r| r.delay_s.is_none()).count(),
        broadcast_symbols: avg(&|x| x.broadcast_symbols as f64),
        broadcast_s: avg(&|x| x.broadcast_s),
    }
}

/// Runs every case × arm into `out/<case>-<arm>/trials.json`, then `out/report.md` and
/// `out/study.json`.
pub fn run_baselines(
    study: &BaselineStudy,
    out: &Path,
    render: RenderPath,
    jobs: usize,
    stop: &Arc<AtomicBool>,
    progress: impl Fn(usize, usize, u64, u64) + Sync,
) -> Result<Vec<ArmResult>> {
    let perturbation = study.check()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let points: Vec<(String, Arm)> = study
        .cases
        .iter()
        .flat_map(|c| study.arms.iter().map(move |a| (c.clone(), *a)))
        .collect();
    let mut results = Vec::new();
    for (k, (case_name, arm)) in points.iter().enumerate() {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let case = Case::load(case_name)?;
        let (modality, policy) = arm.receiver_and_policy();
        let opts = MissionTrialsOptions {
            case,
            modality,
            policy,
            trials: study.trials,
            seed: study.seed,
            perturbation: perturbation.clone(),
            jobs,
            render,
        };
        let trials = run_mission_trials(&opts, stop, |done, _| {
            progress(k, points.len(), done, study.trials);
        })?;
        let dir = out.join(format!("{}-{}", opts.case.name, arm.label()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        std::fs::write(
            dir.join("trials.json"),
            serde_json::to_string_pretty(&trials)? + "\n",
        )
        .with_context(|| format!("writing {}", dir.display()))?;
        if trials.tally.trials > 0 {
            results.push(arm_result(&opts.case.name, *arm, &trials));
        }
    }
    std::fs::write(
        out.join("study.json"),
        serde_json::to_string_pretty(&results)? + "\n",
    )
    .with_context(|| format!("writing {}", out.join("study.json").display()))?;
    std::fs::write(out.join("report.md"), report(study, &results))
        .with_context(|| format!("writing {}", out.join("report.md").display()))?;
    Ok(results)
}

/// `report.md`: one table of outcome measures per case.
pub fn report(study: &BaselineStudy, results: &[ArmResult]) -> String {
    let mut s = format!(
        "# Study: {}\n\nWhole missions in one process per trial; {} trial(s) per case × arm, seed {}{}. \
         Arms: `waggle-rgb`/`waggle-events` decode the performer with their own cameras, \
         `ideal-message` decodes ground truth projected into each camera (the communication upper \
         bound), `fixed-allocation` reads nothing (observer i always takes offer site i mod sites). \
         Communication cost is the motion symbols (tokens) and seconds of broadcast the arm relies \
         on (none for the fixed arm). Reassignment delay: from the withdrawal broadcast's start to \
         the departure for another site of each observer that served the withdrawn site in the \
         round before.\n",
        study.name,
        study.trials,
        study.seed,
        if study.perturb.is_empty() {
            String::new()
        } else {
            format!(
                ", perturbation {}",
                study
                    .perturb
                    .iter()
                    .map(|(k, v)| format!("`{k}={v}`"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        }
    );
    let opt = |v: Option<f64>| v.map_or("—".to_owned(), |x| format!("{x:.2}"));
    for case in &study.cases {
        s.push_str(&format!(
            "\n## {case}\n\n| arm | expected outcome met | work units | reward | unserved capacity | completion (s) | wasted trips | reassignment delay (s) | not reassigned | symbols | broadcast (s) |\n| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n"
        ));
        for r in results.iter().filter(|r| &r.case == case) {
            s.push_str(&format!(
                "| {} | {}/{} [{:.2}, {:.2}] | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {:.0} | {:.2} |\n",
                r.arm,
                r.successes,
                r.trials,
                r.ci95[0],
                r.ci95[1],
                r.work_units,
                r.reward,
                r.unserved_capacity,
                r.completion_time_s,
                r.wasted_trips,
                opt(r.reassignment_delay_s),
                r.not_reassigned,
                r.broadcast_symbols,
                r.broadcast_s
            ));
        }
    }
    s
}
