//! The session report: `DIR/report.md` with the functional-case table and the nominal timing
//! table laid out like the paper's (ours beside the paper's values), one section per run with
//! its audit, and the figures (`DIR/figures/`): per-run session timeline, per-observer symbol
//! trajectories over their templates, and the sensor-comparison sheet.
//!
//! `waggle report DIR` regenerates it from a run directory (`waggle run --out DIR`) or a sweep
//! directory (`waggle sweep --out DIR`) without re-running anything.

pub mod paper;
pub mod plot;
pub mod run_audit;
pub mod sensor;
pub mod timeline;
pub mod trajectory;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use run_audit::{AuditSource, audit_run, check_against_case};
use run_format::case::{BUILT_IN, Case};
use run_format::run_dir::audit::AuditReport;
use run_format::run_dir::{PlannedRun, RunFiles, SUMMARY_FILE, SWEEP_FILE, SweepManifest};

/// One run, audited and checked against its case.
#[derive(Debug, Clone)]
pub struct RunEntry {
    /// Directory name (`<case>-<modality>` in a sweep).
    pub name: String,
    pub case: String,
    pub modality: String,
    /// `None` when the run wrote no summary (it failed before the end).
    pub files: Option<RunFiles>,
    pub audit: Option<AuditReport>,
    pub source: Option<AuditSource>,
    /// Why this run does not meet its case's expected outcome (empty = it does).
    pub failures: Vec<String>,
}

impl RunEntry {
    pub fn pass(&self) -> bool {
        self.failures.is_empty()
    }

    /// Audits the run in `dir` and checks it against its case.
    pub fn evaluate(dir: &Path) -> Result<Self> {
        let files = RunFiles::load(dir)?;
        let (audit, source) = audit_run(dir, &files);
        let case_name = files.summary.mission.case.clone();
        let failures = match Case::load(&case_name) {
            Ok(case) => check_against_case(&case, &audit),
            Err(e) => {
                let mut f: Vec<String> = audit.reasons.clone();
                if !audit.pass && f.is_empty() {
                    f.push("the audit did not pass".into());
                }
                f.push(format!("case {case_name:?} not found: {e:#}"));
                f
            }
        };
        Ok(Self {
            name: dir_name(dir),
            case: case_name,
            modality: files
                .summary
                .mission
                .modality
                .map_or_else(String::new, |m| m.to_string()),
            files: Some(files),
            audit: Some(audit),
            source: Some(source),
            failures,
        })
    }

    /// A planned run that left no usable summary.
    pub fn broken(p: &PlannedRun, why: String) -> Self {
        Self {
            name: p.dir.clone(),
            case: p.case.clone(),
            modality: p.modality.clone(),
            files: None,
            audit: None,
            source: None,
            failures: vec![why],
        }
    }
}

fn dir_name(dir: &Path) -> String {
    dir.canonicalize()
        .ok()
        .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "run".into())
}

/// Table order: the paper's case order, then RGB before events.
fn order_key(case: &str, modality: &str) -> (usize, String, u8) {
    let i = BUILT_IN
        .iter()
        .position(|(n, _)| *n == case)
        .unwrap_or(BUILT_IN.len());
    (i, case.to_string(), u8::from(modality != "rgb"))
}

/// Every run of `dir`: the planned runs of a sweep (`sweep.json`), the run itself (a run
/// directory), or every subdirectory holding a `summary.json`.
pub fn gather(dir: &Path) -> Result<(Vec<RunEntry>, Option<SweepManifest>)> {
    let manifest_path = dir.join(SWEEP_FILE);
    let mut entries = Vec::new();
    let manifest: Option<SweepManifest> = if manifest_path.exists() {
        let text = std::fs::read_to_string(&manifest_path)
            .with_context(|| format!("reading {}", manifest_path.display()))?;
        Some(
            serde_json::from_str(&text)
                .with_context(|| format!("parsing {}", manifest_path.display()))?,
        )
    } else {
        None
    };
    if let Some(m) = &manifest {
        for p in &m.runs {
            let run_dir = dir.join(&p.dir);
            let entry = if run_dir.join(SUMMARY_FILE).exists() {
                RunEntry::evaluate(&run_dir)
                    .unwrap_or_else(|e| RunEntry::broken(p, format!("{e:#}")))
            } else {
                let tail = p.error_tail.clone().unwrap_or_default();
                RunEntry::broken(
                    p,
                    format!(
                        "waggle run ended with {} and wrote no summary. {tail}",
                        p.exit
                    ),
                )
            };
            entries.push(entry);
        }
    } else if dir.join(SUMMARY_FILE).exists() {
        entries.push(RunEntry::evaluate(dir)?);
    } else {
        let mut subdirs: Vec<PathBuf> = std::fs::read_dir(dir)
            .with_context(|| format!("reading {}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join(SUMMARY_FILE).exists())
            .collect();
        subdirs.sort();
        for d in subdirs {
            entries.push(RunEntry::evaluate(&d)?);
        }
    }
    if entries.is_empty() {
        bail!(
            "{} holds no run: want summary.json (waggle run --out), sweep.json (waggle sweep \
             --out) or subdirectories with summary.json",
            dir.display()
        );
    }
    entries.sort_by_key(|e| order_key(&e.case, &e.modality));
    Ok((entries, manifest))
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |x| format!("{x:.digits$}"))
}

fn messages_vector(a: &AuditReport) -> String {
    let v: Vec<String> = a.messages.values().map(|n| n.to_string()).collect();
    v.join("/")
}

/// The figure files written for the report, relative to the report's directory.
#[derive(Debug, Default)]
struct Figures {
    timeline: Option<String>,
    trajectories: Vec<(String, String)>,
}

fn write_figures(dir: &Path, entry: &RunEntry) -> Result<Figures> {
    let Some(files) = &entry.files else {
        return Ok(Figures::default());
    };
    let fig_dir = dir.join("figures");
    std::fs::create_dir_all(&fig_dir).with_context(|| format!("creating {}", fig_dir.display()))?;
    let mut out = Figures::default();
    let name = format!("{}-timeline.svg", entry.name);
    std::fs::write(fig_dir.join(&name), timeline::timeline_svg(files)?)?;
    out.timeline = Some(format!("figures/{name}"));
    for (o, rec) in &files.observers {
        let title = format!(
            "{} ({}) — {o}: trajectory of each decoded symbol over its template",
            entry.case, entry.modality
        );
        if let Some(doc) = trajectory::trajectories_svg(&title, rec)? {
            let name = format!("{}-{o}-symbols.svg", entry.name);
            std::fs::write(fig_dir.join(&name), doc)?;
            out.trajectories
                .push((o.clone(), format!("figures/{name}")));
        }
    }
    Ok(out)
}

/// Writes `dir/report.md` and its figures; returns the report's path.
pub fn write_report(
    dir: &Path,
    entries: &[RunEntry],
    manifest: Option<&SweepManifest>,
    sensor_figure: bool,
) -> Result<PathBuf> {
    let mut md = String::new();
    let passed = entries.iter().filter(|e| e.pass()).count();
    let _ = writeln!(md, "# Waggle session report\n");
    let _ = writeln!(
        md,
        "{} run(s), {passed} met their case's expected outcome, {} did not.{}\n",
        entries.len(),
        entries.len() - passed,
        manifest.map_or(String::new(), |m| format!(
            " Sweep wall time {:.0} s with {} parallel run(s){}.",
            m.wall_s,
            m.jobs,
            if m.interrupted { ", interrupted" } else { "" }
        ))
    );
    let _ = writeln!(
        md,
        "Times are simulation seconds. The paper's values (Tables \"Final functional cases\" and \
         \"Timing in the nominal three-observer missions\") stand beside ours for comparison only: \
         message counts and work units must match the case files exactly; times differ with our \
         gesture timing and are not tuned to the paper's.\n"
    );
    cases_table(&mut md, entries);
    timing_tables(&mut md, entries);

    let _ = writeln!(md, "## Runs\n");
    for e in entries {
        let figs = write_figures(dir, e)?;
        run_section(&mut md, e, &figs);
    }

    if sensor_figure {
        let fig_dir = dir.join("figures");
        std::fs::create_dir_all(&fig_dir)?;
        let observers = entries
            .iter()
            .find_map(|e| e.files.as_ref().map(|f| f.summary.mission.observers.len()))
            .unwrap_or(3)
            .max(1);
        let _ = writeln!(md, "## Sensor comparison\n");
        match sensor::sensor_comparison(observers, 0, &fig_dir.join("sensor-comparison.png")) {
            Ok(phases) => {
                let _ = writeln!(
                    md,
                    "![RGB render and 40 ms event packet](figures/sensor-comparison.png)\n\n{}\n",
                    sensor::caption(observers, 0, &phases)
                );
            }
            Err(e) => {
                let _ = writeln!(md, "Not produced: {e:#}\n");
            }
        }
    }
    let path = dir.join("report.md");
    std::fs::write(&path, md).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

fn cases_table(md: &mut String, entries: &[RunEntry]) {
    let _ = writeln!(md, "## Functional cases\n");
    let _ = writeln!(
        md,
        "| Case | Messages RGB | paper | Messages events | paper | Work RGB | paper | Work events | paper | Time RGB (s) | paper | Time events (s) | paper | Outcome |"
    );
    let _ = writeln!(md, "|{}", "---|".repeat(14));
    let mut cases: Vec<String> = entries.iter().map(|e| e.case.clone()).collect();
    cases.dedup();
    for case in &cases {
        let (label, _) = paper::case(case, "rgb");
        let find = |m: &str| entries.iter().find(|e| &e.case == case && e.modality == m);
        let (rgb, ev) = (find("rgb"), find("events"));
        let (prgb, pev) = (paper::case(case, "rgb").1, paper::case(case, "events").1);
        let ours = |e: Option<&RunEntry>, f: &dyn Fn(&AuditReport) -> String| match e {
            None => "not run".to_string(),
            Some(e) => e.audit.as_ref().map_or("✗".to_string(), f),
        };
        let paper_cell = |p: Option<paper::PaperCase>, f: &dyn Fn(&paper::PaperCase) -> String| {
            p.as_ref().map_or("—".to_string(), f)
        };
        let outcome = |e: Option<&RunEntry>, m: &str| {
            e.map(|e| format!("{m} {}", if e.pass() { "PASS" } else { "**FAIL**" }))
        };
        let outcomes: Vec<String> = [outcome(rgb, "RGB"), outcome(ev, "events")]
            .into_iter()
            .flatten()
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            label.map_or(case.clone(), |l| format!("{l} (`{case}`)")),
            ours(rgb, &messages_vector),
            paper_cell(prgb, &|p| p.messages.to_string()),
            ours(ev, &messages_vector),
            paper_cell(pev, &|p| p.messages.to_string()),
            ours(rgb, &|a| a.work_units.to_string()),
            paper_cell(prgb, &|p| p.work_units.to_string()),
            ours(ev, &|a| a.work_units.to_string()),
            paper_cell(pev, &|p| p.work_units.to_string()),
            ours(rgb, &|a| format!("{:.2}", a.mission_time_s)),
            paper_cell(prgb, &|p| format!("{:.2}", p.time_s)),
            ours(ev, &|a| format!("{:.2}", a.mission_time_s)),
            paper_cell(pev, &|p| format!("{:.2}", p.time_s)),
            outcomes.join(", ")
        );
    }
    let _ = writeln!(
        md,
        "\nMessage vectors follow O1/O2/O3 order. \"not run\": not part of this sweep; \"—\": the \
         paper has no such run (an untested condition, not a failure).\n"
    );
}

/// (min, max, mean, count) of every observer's offer-to-final-NULL interval.
fn offer_stats(a: &AuditReport) -> Option<(f64, f64, f64, usize)> {
    let all: Vec<f64> = a
        .timing
        .offer_to_final_null_s
        .values()
        .flatten()
        .copied()
        .collect();
    if all.is_empty() {
        return None;
    }
    let min = all.iter().copied().fold(f64::INFINITY, f64::min);
    let max = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some((
        min,
        max,
        all.iter().sum::<f64>() / all.len() as f64,
        all.len(),
    ))
}

fn timing_tables(md: &mut String, entries: &[RunEntry]) {
    let nominal = |m: &str| {
        entries
            .iter()
            .find(|e| e.case == "nominal-3" && e.modality == m)
            .and_then(|e| e.audit.as_ref())
    };
    let (rgb, ev) = (nominal("rgb"), nominal("events"));
    let _ = writeln!(md, "## Timing of the nominal three-observer mission\n");
    if rgb.is_none() && ev.is_none() {
        let _ = writeln!(
            md,
            "nominal-3 is not part of this sweep; the timing of every run is in the next table.\n"
        );
    } else {
        let (pr, pe) = (&paper::TIMING_RGB, &paper::TIMING_EVENTS);
        let _ = writeln!(
            md,
            "| Measurement | RGB | paper | Synthetic events | paper |\n|---|---|---|---|---|"
        );
        let row = |md: &mut String,
                   what: &str,
                   f: &dyn Fn(&AuditReport) -> String,
                   p: &dyn Fn(&paper::PaperTiming) -> String| {
            let cell = |a: Option<&AuditReport>| a.map_or("not run".to_string(), f);
            let _ = writeln!(
                md,
                "| {what} | {} | {} | {} | {} |",
                cell(rgb),
                p(pr),
                cell(ev),
                p(pe)
            );
        };
        row(
            md,
            "First offer broadcast start",
            &|a| fmt_opt(a.timing.first_offer_start_s, 3),
            &|p| format!("{:.3}", p.first_offer_start_s),
        );
        row(
            md,
            "Offer start to final NULL, observed range",
            &|a| offer_stats(a).map_or("—".into(), |(lo, hi, _, _)| format!("{lo:.3}–{hi:.3}")),
            &|p| {
                format!(
                    "{:.3}–{:.3}",
                    p.offer_to_final_null_range_s.0, p.offer_to_final_null_range_s.1
                )
            },
        );
        row(
            md,
            "Offer start to final NULL, mean (observations)",
            &|a| offer_stats(a).map_or("—".into(), |(_, _, mean, n)| format!("{mean:.3} ({n})")),
            &|p| format!("{:.3} (12)", p.offer_to_final_null_mean_s),
        );
        row(
            md,
            "Latest final reception",
            &|a| fmt_opt(a.timing.latest_final_reception_s, 3),
            &|p| format!("{:.3}", p.latest_final_reception_s),
        );
        row(
            md,
            "Latest reception to mission completion",
            &|a| fmt_opt(a.timing.latest_reception_to_completion_s, 3),
            &|p| format!("{:.3}", p.latest_reception_to_completion_s),
        );
        row(
            md,
            "Total mission duration",
            &|a| format!("{:.3}", a.mission_time_s),
            &|p| format!("{:.3}", p.total_s),
        );
        let _ = writeln!(
            md,
            "\nOffer start: the start of the offer's first NULL hover as flown by the performer \
             (with event cameras that hover is also the quiet after the acquisition motion, which \
             the paper counts before its offer start); broadcasts are matched to frames by round \
             and site.\n"
        );
    }
    let _ = writeln!(md, "### Timing of every run\n");
    let _ = writeln!(
        md,
        "| Run | First offer start | Offer start to final NULL (range, mean, n) | Latest final reception | to completion | Total | Wall (s) | wall/sim |\n|---|---|---|---|---|---|---|---|"
    );
    for e in entries {
        let (Some(a), Some(f)) = (&e.audit, &e.files) else {
            let _ = writeln!(md, "| {} | — | — | — | — | — | — | — |", e.name);
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {:.3} | {:.0} | {:.3} |",
            e.name,
            fmt_opt(a.timing.first_offer_start_s, 3),
            offer_stats(a).map_or("—".into(), |(lo, hi, mean, n)| format!(
                "{lo:.3}–{hi:.3}, {mean:.3}, {n}"
            )),
            fmt_opt(a.timing.latest_final_reception_s, 3),
            fmt_opt(a.timing.latest_reception_to_completion_s, 3),
            a.mission_time_s,
            f.summary.mission.wall_seconds,
            f.summary.wall_over_sim
        );
    }
    let _ = writeln!(md);
}

fn run_section(md: &mut String, e: &RunEntry, figs: &Figures) {
    let _ = writeln!(
        md,
        "### {} ({}) — {}\n",
        e.case,
        e.modality,
        if e.pass() { "PASS" } else { "FAIL" }
    );
    for f in &e.failures {
        let _ = writeln!(md, "- ✗ {f}");
    }
    if let (Some(a), Some(files)) = (&e.audit, &e.files) {
        let _ = writeln!(
            md,
            "- directory `{}`; audit from {}",
            e.name,
            match &e.source {
                Some(AuditSource::Recording) => "the recording (`waggle audit`)".to_string(),
                Some(AuditSource::Summary(why)) =>
                    format!("summary.json/observers.json/session.json ({why})"),
                None => "—".into(),
            }
        );
        let _ = writeln!(
            md,
            "- mission time {:.2} s ({}), wall {:.0} s; complete messages {}; work units {} {:?}",
            a.mission_time_s,
            run_eval::summary::end_reason_text(a.end_reason),
            files.summary.mission.wall_seconds,
            messages_vector(a),
            a.work_units,
            a.work_units_by_site
        );
        for (o, s) in &files.summary.mission.observers {
            let _ = writeln!(
                md,
                "- {o}: payloads {}; decisions {}; services {}; {} tokens",
                if s.payloads.is_empty() {
                    "none".into()
                } else {
                    s.payloads.join(", ")
                },
                if s.decisions.is_empty() {
                    "none".into()
                } else {
                    s.decisions.join(", ")
                },
                if s.services.is_empty() {
                    "none".into()
                } else {
                    s.services.join(", ")
                },
                s.tokens
            );
        }
        let _ = writeln!(
            md,
            "- contact steps {}; minimum separation {}; provenance violations {}; packets per observer {:?}",
            a.contact_steps,
            a.min_separation()
                .map_or("—".into(), |m| format!("{m:.3} m")),
            a.provenance_violations.len(),
            a.packets_per_observer
        );
        if !files.summary.faults.is_empty() {
            let _ = writeln!(md, "- faults: {}", files.summary.faults.join("; "));
        }
    }
    let _ = writeln!(md);
    if let Some(t) = &figs.timeline {
        let _ = writeln!(md, "![session timeline of {}]({t})\n", e.name);
    }
    if !figs.trajectories.is_empty() {
        let links: Vec<String> = figs
            .trajectories
            .iter()
            .map(|(o, p)| format!("[{o}]({p})"))
            .collect();
        let _ = writeln!(
            md,
            "Decoded symbols over their templates: {}\n",
            links.join(" · ")
        );
    } else if e.files.is_some() {
        let _ = writeln!(
            md,
            "No symbol trajectories: this run's observers published no track (runs made before \
             `observer/<o>/track` existed).\n"
        );
    }
}

/// Reasons the report fails: an error naming every run that missed its expected outcome.
pub fn verdict(entries: &[RunEntry]) -> Result<()> {
    let failed: Vec<&str> = entries
        .iter()
        .filter(|e| !e.pass())
        .map(|e| e.name.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} run(s) did not meet their expected outcome: {}",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// One line per run.
pub fn print_outcomes(entries: &[RunEntry]) {
    for e in entries {
        let detail = match &e.audit {
            Some(a) => format!(
                "messages {} · work units {} · {:.2} s",
                messages_vector(a),
                a.work_units,
                a.mission_time_s
            ),
            None => "no summary".into(),
        };
        println!(
            "{:<4} {:<24} {detail}{}",
            if e.pass() { "PASS" } else { "FAIL" },
            e.name,
            if e.pass() {
                String::new()
            } else {
                format!(" — {}", e.failures.join("; "))
            }
        );
    }
}
