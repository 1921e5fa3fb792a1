//! The `baselines` study: whole missions under each allocation arm — Waggle with RGB or event
//! cameras, the ideal-message receiver (ground truth in every camera) and the fixed-allocation
//! policy (no communication) — with the outcome measures of [`MissionMetrics`](crate::harness::mission::metrics::MissionMetrics) side by side.
//!
//! ```toml
//! name = "baselines"
//! cases = ["nominal-3"]
//! arms = ["ideal", "fixed", "rgb", "events"]
//! trials = 1          # per case × arm; > 1 only makes sense with a perturbation
//! seed = 1
//! perturb = {}        # e.g. { "flight.gust_sigma_n" = 0.005 }
//! [[vary]]            # optional, at most one: every case × arm at each level of one term
//! key = "wind.mean_mps"
//! levels = [0.0, 1.0, 2.0]
//! ```
//!
//! Every trial also reports its safety: the closest any two drones came and whether they
//! touched. A trial closer than [`SAFE_SEPARATION_M`] or with a contact is counted as unsafe
//! (the safety router keeps 0.4 m; the wind study's targets count such a trial as failed).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use perturb::Perturbation;
use serde::{Deserialize, Serialize};

use crate::harness::flight::air::PointTracking;
use crate::harness::mission::MissionOptions;
use crate::harness::mission::trials::{FalseReleaseTally, MissionTrialsOut};
use crate::harness::runs::records::{write_atomic, write_json};
use crate::harness::study::figure::{FigurePoint, success_figure};
use crate::harness::study::vary::Vary;
use commands::Policy;
use proto::Receiver;
use run_format::case::Case;

/// Closest approach of two drones below which a trial counts as unsafe, m.
pub const SAFE_SEPARATION_M: f64 = 0.35;

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
    pub(crate) fn receiver_and_policy(self) -> (Receiver, Policy) {
        match self {
            Arm::Rgb => (Receiver::Rgb, Policy::Waggle),
            Arm::Events => (Receiver::Events, Policy::Waggle),
            Arm::Ideal => (Receiver::Ideal, Policy::Waggle),
            Arm::Fixed => (Receiver::Ideal, Policy::Fixed),
        }
    }

    pub(crate) fn label(self) -> &'static str {
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
    /// The study's name, as its report gives it.
    pub name: String,
    /// Built-in case names or case files, each flown by every arm.
    pub cases: Vec<String>,
    /// `ideal`, `fixed`, `rgb`, `events`: the two baselines and Waggle's two receivers.
    pub arms: Vec<Arm>,
    /// Seeded trials per case, arm and level.
    pub trials: u64,
    /// The study's base seed (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Perturbation terms every trial holds.
    #[serde(default)]
    pub perturb: BTreeMap<String, f64>,
    /// At most one perturbation term and its levels: every case × arm at each level.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vary: Vec<Vary>,
}

/// Means over one arm's trials of one case.
#[derive(Debug, Clone, Serialize)]
pub struct ArmResult {
    pub case: String,
    pub arm: String,
    /// The level of the study's `vary` term (none without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<f64>,
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
    /// The closest two drones came in any trial, m.
    pub min_separation_m: f64,
    /// Trials closer than [`SAFE_SEPARATION_M`] or with a contact.
    pub unsafe_trials: u64,
    /// The performer's tracking (trials that flew the cascade or wind; none otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracking: Option<PointTracking>,
    /// Payloads released that the performer did not fly, and the missions with one (omitted
    /// when none).
    #[serde(skip_serializing_if = "FalseReleaseTally::is_none")]
    pub false_releases: FalseReleaseTally,
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
        if self.vary.len() > 1 {
            bail!(
                "a baselines study varies at most one term ([[vary]] given {} times)",
                self.vary.len()
            );
        }
        let mut levels = vec![p.clone()];
        if let Some(vary) = self.vary.first() {
            if vary.levels.is_empty() {
                bail!("vary.levels must not be empty");
            }
            for &level in &vary.levels {
                let mut at = p.clone();
                at.set(&vary.key, level).context("vary")?;
                at.check().context("vary")?;
                levels.push(at);
            }
        }
        for arm in &self.arms {
            let (receiver, _) = arm.receiver_and_policy();
            for perturbation in &levels {
                MissionOptions {
                    perturbation: perturbation.clone(),
                    ..MissionOptions::default()
                }
                .check(receiver)
                .with_context(|| format!("arm {arm:?}"))?;
            }
        }
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

pub(crate) fn arm_result(
    case: &str,
    arm: Arm,
    level: Option<f64>,
    out: &MissionTrialsOut,
) -> ArmResult {
    let m = || out.per_trial.iter().map(|t| &t.metrics);
    let avg = |f: &dyn Fn(&crate::harness::mission::metrics::MissionMetrics) -> f64| {
        mean(m().map(f)).unwrap_or(f64::NAN)
    };
    let responses = || m().flat_map(|x| x.reassignments.iter());
    let unsafe_trial = |t: &crate::harness::mission::trials::MissionTrial| {
        t.contact_steps > 0 || t.min_separation_m < SAFE_SEPARATION_M
    };
    ArmResult {
        case: case.to_owned(),
        arm: arm.label().to_owned(),
        level,
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
        min_separation_m: out
            .per_trial
            .iter()
            .map(|t| t.min_separation_m)
            .fold(f64::INFINITY, f64::min),
        unsafe_trials: out.per_trial.iter().filter(|t| unsafe_trial(t)).count() as u64,
        tracking: PointTracking::pooled(out.per_trial.iter().filter_map(|t| {
            t.metrics.performer_tracking.map(|k| {
                (
                    1,
                    PointTracking {
                        mean_rms_m: k.rms_m,
                        max_m: k.max_m,
                        contact_trials: u64::from(t.contact_steps > 0),
                    },
                )
            })
        })),
        false_releases: out.false_releases,
    }
}

/// `study.json`, `report.md` and one figure per case (with a varied term) of `results`.
pub(crate) fn write_report(study: &BaselineStudy, results: &[ArmResult], out: &Path) -> Result<()> {
    write_json(&out.join("study.json"), &results)?;
    write_atomic(&out.join("report.md"), report(study, results).as_bytes())?;
    if let Some(vary) = study.vary.first() {
        for case in &study.cases {
            let path = out.join(figure_name(case, &vary.key));
            write_atomic(&path, figure(study, vary, case, results)?.as_bytes())?;
        }
    }
    Ok(())
}

/// The figure of `case` in a study varying `key`: `success-<case>-<key>.svg`.
pub fn figure_name(case: &str, key: &str) -> String {
    format!("success-{case}-{key}.svg")
}

/// `case`'s expected outcome met against the varied term's levels, one series per arm.
fn figure(study: &BaselineStudy, vary: &Vary, case: &str, results: &[ArmResult]) -> Result<String> {
    let series: Vec<String> = study.arms.iter().map(|a| a.label().to_owned()).collect();
    let points: Vec<FigurePoint> = results
        .iter()
        .filter(|r| r.case == case)
        .filter_map(|r| {
            Some(FigurePoint {
                series: r.arm.clone(),
                level: r.level?,
                success_rate: (r.trials > 0).then(|| r.successes as f64 / r.trials as f64),
                ci95: r.ci95,
            })
        })
        .collect();
    success_figure(&format!("{} ({case})", study.name), &series, vary, &points)
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
    if let Some(v) = study.vary.first() {
        s.push_str(&format!(
            "\nVaried: `{}` over {:?}. Safety: min separation is the closest two drones came in \
             any trial; a trial closer than {SAFE_SEPARATION_M} m or with a contact is unsafe. \
             Tracking: the performer against its reference, mean over trials of each flight's \
             RMS / the largest error of any trial.\n",
            v.key, v.levels
        ));
    }
    let opt = |v: Option<f64>| v.map_or("—".to_owned(), |x| format!("{x:.2}"));
    let level_head = study
        .vary
        .first()
        .map_or(String::new(), |v| format!("{} | ", v.key));
    for case in &study.cases {
        if let Some(v) = study.vary.first() {
            s.push_str(&format!(
                "\n## {case}\n\n![expected outcome met against {}]({})\n",
                v.key,
                figure_name(case, &v.key)
            ));
        } else {
            s.push_str(&format!("\n## {case}\n"));
        }
        s.push_str(&format!(
            "\n| {level_head}arm | expected outcome met | work units | reward | unserved capacity | completion (s) | wasted trips | reassignment delay (s) | not reassigned | symbols | broadcast (s) | min separation (m) | unsafe trials | tracking RMS / max (mm) | trials with contact |\n| {}--- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
            if study.vary.is_empty() { "" } else { "---: | " }
        ));
        for r in results.iter().filter(|r| &r.case == case) {
            s.push_str(&format!(
                "| {}{} | {}/{} [{:.2}, {:.2}] | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {:.0} | {:.2} | {:.3} | {} | {} |\n",
                r.level.map_or(String::new(), |l| format!("{l} | ")),
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
                r.broadcast_s,
                r.min_separation_m,
                r.unsafe_trials,
                PointTracking::cells(r.tracking.as_ref()),
            ));
        }
        // Named apart from the table: a confident wrong offer, not a lost message.
        for r in results
            .iter()
            .filter(|r| &r.case == case && !r.false_releases.is_none())
        {
            s.push_str(&format!(
                "\nFalse releases{}, arm {}: {} payload(s) the performer did not fly, in {} of {} \
                 missions.\n",
                r.level.map_or(String::new(), |l| format!(" at {l}")),
                r.arm,
                r.false_releases.releases,
                r.false_releases.missions,
                r.trials
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(extra: &str) -> Result<BaselineStudy> {
        let text = format!(
            "name = \"t\"\ncases = [\"only-a\"]\narms = [\"ideal\"]\ntrials = 2\n\
             perturb = {{ \"flight.cascade\" = 1.0 }}\n{extra}"
        );
        let s: BaselineStudy = toml::from_str(&text)?;
        s.check()?;
        Ok(s)
    }

    #[test]
    fn one_term_may_be_varied_over_checked_levels() {
        let s = study("[[vary]]\nkey = \"wind.mean_mps\"\nlevels = [0.0, 2.0]\n").unwrap();
        assert_eq!(s.vary[0].levels, [0.0, 2.0]);
        let err = |extra: &str| format!("{:#}", study(extra).unwrap_err());
        assert!(
            err("[[vary]]\nkey = \"wind.mean_mps\"\nlevels = [-1.0]\n").contains("wind.mean_mps")
        );
        assert!(err("[[vary]]\nkey = \"wind.speed\"\nlevels = [1.0]\n").contains("wind.speed"));
        assert!(err("[[vary]]\nkey = \"wind.mean_mps\"\nlevels = []\n").contains("empty"));
        let two = "[[vary]]\nkey = \"wind.mean_mps\"\nlevels = [1.0]\n".repeat(2);
        assert!(err(&two).contains("at most one"));
    }

    #[test]
    fn a_varied_report_has_a_row_per_level_with_safety_and_tracking() {
        let s = study("[[vary]]\nkey = \"wind.mean_mps\"\nlevels = [0.0, 2.0]\n").unwrap();
        let row = |level: f64, separation_m: f64| ArmResult {
            case: "only-a".into(),
            arm: "ideal-message".into(),
            level: Some(level),
            trials: 2,
            successes: 1,
            ci95: [0.1, 0.9],
            work_units: 0.0,
            reward: 0.0,
            unserved_capacity: 0.0,
            completion_time_s: 1.0,
            wasted_trips: 0.0,
            reassignment_delay_s: None,
            not_reassigned: 0,
            broadcast_symbols: 1.0,
            broadcast_s: 1.0,
            min_separation_m: separation_m,
            unsafe_trials: u64::from(separation_m < SAFE_SEPARATION_M),
            tracking: Some(PointTracking {
                mean_rms_m: 0.0012,
                max_m: 0.004,
                contact_trials: 0,
            }),
            false_releases: FalseReleaseTally::default(),
        };
        let md = report(&s, &[row(0.0, 0.9), row(2.0, 0.3)]);
        assert!(md.contains("| wind.mean_mps | arm |"), "{md}");
        assert!(md.contains("| 2 | ideal-message | 1/2"), "{md}");
        assert!(md.contains("| 0.300 | 1 | 1.2 / 4.0 | 0 |"), "{md}");
        assert!(!md.contains("False releases"), "none, none said: {md}");
        let mut wrong = row(2.0, 0.9);
        wrong.false_releases = FalseReleaseTally {
            releases: 3,
            missions: 1,
        };
        let md = report(&s, &[row(0.0, 0.9), wrong]);
        assert!(
            md.contains(
                "False releases at 2, arm ideal-message: 3 payload(s) the performer did not fly, \
                 in 1 of 2 missions."
            ),
            "{md}"
        );
    }
}
