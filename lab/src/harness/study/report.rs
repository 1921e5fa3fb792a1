//! A link study's `report.md` (success per level, per condition and modality), its figures
//! (`success-<key>.svg`) and `cost.md` (CPU time per trial and per decoded message, sensor
//! traffic). `report.md` holds nothing measured in wall-clock or CPU time, so it is the same bytes
//! however the study was run; the costs are in `cost.md` and `cost.json`.

use anyhow::Result;

use crate::harness::flight::air::PointTracking;
use crate::harness::runs::files::RunCost;
use crate::harness::study::figure::{FigurePoint, success_figure};
use crate::harness::study::{PointResult, StudyFile, StudyPlan, Vary, cross_key, figure_name};
use run_format::study_file::{LINK_PAYLOAD, level_text};

/// `report.md`: the study's definition and one table per modality.
#[must_use]
pub fn report(study: &StudyFile, results: &[PointResult]) -> String {
    let whole = results;
    let results = &marginals(study, whole);
    let mut s = format!("# Study: {}\n\n", study.name);
    s.push_str(&format!(
        "Broadcast {}; {}; {} trials per point, seed {}; criterion: every observer releases \
         exactly the broadcast payloads, in order (`{}`); rectification `{}`. {}: {}.",
        if study.vary.iter().any(|v| v.key == LINK_PAYLOAD) {
            format!("each point's `{LINK_PAYLOAD}`")
        } else {
            study.link.join(", ")
        },
        match (study.observers, study.viewpoint) {
            (Some(n), _) => format!("{n} observers in the built-in formation"),
            (_, Some(v)) => format!(
                "one observer at azimuth {}°, elevation {}°, {} m",
                v[0], v[1], v[2]
            ),
            _ => String::new(),
        },
        study.trials,
        study.seed,
        study.criterion,
        study.rectify.as_deref().unwrap_or("pitched"),
        if study.cross {
            "Crossed (every combination of levels)"
        } else {
            "Varied, one at a time"
        },
        study
            .vary
            .iter()
            .map(|v| format!("`{}`", v.key))
            .collect::<Vec<_>>()
            .join(", "),
    ));
    if !study.fixed.is_empty() {
        let fixed: Vec<String> = study
            .fixed
            .iter()
            .map(|(k, v)| format!("`{k}` = {v}"))
            .collect();
        s.push_str(&format!(" Held: {}.", fixed.join(", ")));
    }
    s.push('\n');
    for vary in &study.vary {
        let key = &vary.key;
        s.push_str(&format!(
            "\n## {key}\n\n![success probability against {key}]({})\n",
            figure_name(key)
        ));
        // Points that fly their own flights also show how the performer flew them.
        let flown = results
            .iter()
            .any(|r| &r.key == key && r.tracking.is_some());
        for m in study.series() {
            s.push_str(&format!(
                "\n### {m}\n\n| {key} | successes / trials | P(success) | 95 % CI (Wilson) |{}\n| ---: | ---: | ---: | :---: |{}\n",
                if flown { " performer tracking, mean RMS / max (mm) | trials with contact |" } else { "" },
                if flown { " ---: | ---: |" } else { "" },
            ));
            for r in results.iter().filter(|r| r.modality == m && &r.key == key) {
                let (p, ci) = r.rate_cells();
                let tracking = if flown {
                    format!(" {} |", PointTracking::cells(r.tracking.as_ref()))
                } else {
                    String::new()
                };
                s.push_str(&format!(
                    "| {} | {} / {} | {p} | {ci} |{tracking}\n",
                    level_text(key, r.level),
                    r.successes,
                    r.trials
                ));
            }
            if study.cross {
                s.push_str(&combinations(study, key, &m, whole));
            }
        }
    }
    s
}

/// A crossed study's results pooled per factor: for each condition, modality and level, the
/// trials of every point at that level (whatever the other factors), as points keyed by that
/// condition — what the per-condition tables and figures show. Others' results as they are.
#[must_use]
pub fn marginals(study: &StudyFile, results: &[PointResult]) -> Vec<PointResult> {
    if !study.cross {
        return results.to_vec();
    }
    let mut pooled = Vec::new();
    for vary in &study.vary {
        for &level in &vary.levels {
            for m in study.series() {
                let at: Vec<&PointResult> = results
                    .iter()
                    .filter(|r| r.modality == m && r.factors.get(&vary.key) == Some(&level))
                    .collect();
                let sum = |f: fn(&PointResult) -> u64| at.iter().map(|r| f(r)).sum::<u64>();
                let (trials, successes) = (sum(|r| r.trials), sum(|r| r.successes));
                pooled.push(PointResult {
                    key: vary.key.clone(),
                    modality: m,
                    level,
                    factors: std::collections::BTreeMap::new(),
                    trials,
                    successes,
                    success_rate: (trials > 0).then(|| successes as f64 / trials as f64),
                    ci95: perturb::stats::wilson95(successes, trials),
                    dir: String::new(),
                    decoded_messages: sum(|r| r.decoded_messages),
                    sensor_messages: sum(|r| r.sensor_messages),
                    events: sum(|r| r.events),
                    tracking: PointTracking::pooled(
                        at.iter().filter_map(|r| r.tracking.map(|t| (r.trials, t))),
                    ),
                });
            }
        }
    }
    pooled
}

/// Every combination of a crossed study for modality `m`, ordered by `key`'s level first.
fn combinations(study: &StudyFile, key: &str, m: &str, results: &[PointResult]) -> String {
    let others: Vec<&str> = study
        .vary
        .iter()
        .map(|v| v.key.as_str())
        .filter(|k| *k != key)
        .collect();
    let mut s = format!(
        "\nEvery combination:\n\n| {key} | {} | successes / trials | P(success) | 95 % CI (Wilson) |\n| ---: |{} ---: | ---: | :---: |\n",
        others.join(" | "),
        " ---: |".repeat(others.len())
    );
    let slot = |r: &PointResult, k: &str| {
        let levels = &study.vary.iter().find(|v| v.key == k).map(|v| &v.levels);
        let l = r.factors.get(k).copied().unwrap_or_default();
        levels
            .and_then(|ls| ls.iter().position(|x| *x == l))
            .unwrap_or(0)
    };
    let mut rows: Vec<&PointResult> = results.iter().filter(|r| r.modality == m).collect();
    rows.sort_by_key(|r| {
        std::iter::once(slot(r, key))
            .chain(others.iter().map(|k| slot(r, k)))
            .collect::<Vec<_>>()
    });
    for r in rows {
        let (p, ci) = r.rate_cells();
        let cells: Vec<String> = others
            .iter()
            .map(|k| level_text(k, r.factors.get(*k).copied().unwrap_or_default()))
            .collect();
        s.push_str(&format!(
            "| {} | {} | {} / {} | {p} | {ci} |\n",
            level_text(key, r.factors.get(key).copied().unwrap_or_default()),
            cells.join(" | "),
            r.successes,
            r.trials
        ));
    }
    s
}

/// `cost.md`: per condition, computation and sensor traffic per point — CPU time per trial run
/// and per decoded message (the machine's, all threads of the processes that ran it, summed over
/// shards and resumed runs), sensor messages and events per second of sim time (each message
/// covers 40 ms).
#[must_use]
pub fn cost_md(study: &StudyFile, results: &[PointResult], costs: &RunCost) -> String {
    let mut s = format!(
        "# Cost: {}\n\n{} run(s), {:.0} s wall and {:.0} core-s in total ({} trials run; {} \
         shared flight(s) flown and rendered in {:.0} s).\n",
        study.name,
        costs.runs,
        costs.wall_s,
        costs.cpu_s,
        costs.trials_run,
        costs.shared_flights,
        costs.shared_fly_s
    );
    if study.cross {
        s.push_str(&cost_table(&cross_key(study), results, costs));
    } else {
        for vary in &study.vary {
            s.push_str(&cost_table(&vary.key, results, costs));
        }
    }
    s
}

fn cost_table(key: &str, results: &[PointResult], costs: &RunCost) -> String {
    let mut s = format!(
        "\n## {key}\n\n| modality | {key} | core-s per trial | core-s per decoded \
         message | messages/s | events/s |\n| --- | ---: | ---: | ---: | ---: | ---: |\n"
    );
    for r in results.iter().filter(|r| r.key == key) {
        let c = costs.points.get(&r.dir).copied().unwrap_or_default();
        let per_trial = (c.trials_run > 0).then(|| c.cpu_s / c.trials_run as f64);
        let per = |n: u64| match per_trial {
            Some(t) if n > 0 => format!("{:.3}", t * r.trials as f64 / n as f64),
            _ => "—".to_owned(),
        };
        let sim_s = r.sensor_messages as f64 * 0.04;
        let rate = |n: u64| {
            if sim_s > 0.0 {
                format!("{:.0}", n as f64 / sim_s)
            } else {
                "—".to_owned()
            }
        };
        let at = if r.factors.is_empty() {
            level_text(key, r.level)
        } else {
            let f: Vec<String> = r
                .factors
                .iter()
                .map(|(k, v)| format!("{k}={}", level_text(k, *v)))
                .collect();
            f.join(", ")
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.modality,
            at,
            per(r.trials),
            per(r.decoded_messages),
            rate(r.sensor_messages),
            if r.modality.starts_with("events") {
                rate(r.events)
            } else {
                "—".to_owned()
            },
        ));
    }
    s
}

/// The success probability with its interval against the levels of `vary`, one series per
/// modality.
pub fn figure(study: &StudyFile, vary: &Vary, results: &[PointResult]) -> Result<String> {
    let series = study.series();
    let points: Vec<FigurePoint> = results
        .iter()
        .filter(|r| r.key == vary.key)
        .map(|r| FigurePoint {
            series: r.modality.clone(),
            level: r.level,
            success_rate: r.success_rate,
            ci95: r.ci95,
        })
        .collect();
    success_figure(&study.name, &series, vary, &points)
}
