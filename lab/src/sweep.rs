//! `waggle sweep`: every case × modality as its own `waggle run` (the `waggle` beside
//! `waggle-lab`, in a child process each), up to `--jobs` at a time, then the audit of each and
//! `DIR/report.md`.
//!
//! A run goes to `DIR/<case>-<modality>/` (cleared first); its launcher's output to
//! `waggle-run.out` / `waggle-run.log` there. `DIR/sweep.json` lists the planned runs and how
//! each ended, so `waggle report DIR` can rebuild the report later. Ctrl-C interrupts every
//! running child (each stops its own processes and writes what it gathered), starts no more and
//! still writes the report. The exit code is non-zero when any run misses its case's expected
//! outcome, fails to finish, or the sweep was interrupted.

use commands::sweep::SweepModality;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use nix::sys::signal::Signal;

use crate::report::{self, RunEntry};
use proto::Receiver;
use run_eval::child::{exit_label, signal};
use run_format::case::{Case, PAPER_CASES};
use run_format::run_dir::{PlannedRun, SWEEP_FILE, SweepManifest};

/// The options of `waggle sweep`.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Which sensor modalities to run (each case only in the modalities it applies to).
    pub modality: SweepModality,
    /// Sweep directory: one subdirectory per run, report.md, figures/, sweep.json.
    pub out: PathBuf,
    /// Runs in parallel (default: half the cores, at least 1).
    pub jobs: Option<usize>,
    /// Only these cases (built-in names or case files); empty: every built-in case.
    pub cases: Vec<String>,
    /// Skip the sensor-comparison figure.
    pub no_sensor_figure: bool,
    /// How every run's cameras render (each `waggle run --render`).
    pub render: proto::RenderPath,
}

/// Default parallelism: one run per two cores.
fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| (n.get() / 2).max(1))
}

impl SweepOptions {
    fn jobs(&self) -> usize {
        self.jobs.unwrap_or_else(default_jobs).max(1)
    }
}

/// One run to make.
#[derive(Debug, Clone, PartialEq)]
struct Job {
    case: String,
    modality: &'static str,
    dir: String,
}

fn plan(args: &SweepOptions) -> Result<(Vec<Job>, Vec<String>)> {
    let names: Vec<String> = if args.cases.is_empty() {
        PAPER_CASES.iter().map(|n| n.to_string()).collect()
    } else {
        args.cases.clone()
    };
    let mut jobs = Vec::new();
    let mut skipped = Vec::new();
    for name in &names {
        let case = Case::load(name)?;
        for (m, cm) in [("rgb", Receiver::Rgb), ("events", Receiver::Events)] {
            let wanted = match args.modality {
                SweepModality::Both => true,
                SweepModality::Rgb => m == "rgb",
                SweepModality::Events => m == "events",
            };
            if !wanted {
                continue;
            }
            if !case.modalities.contains(&cm) {
                skipped.push(format!("{} does not apply to {m}", case.name));
                continue;
            }
            let job = Job {
                case: name.clone(),
                modality: m,
                dir: format!("{}-{m}", case.name),
            };
            if !jobs.contains(&job) {
                jobs.push(job);
            }
        }
    }
    Ok((jobs, skipped))
}

/// Asks a child `waggle run` to stop the way Ctrl-C would (it then stops its own processes).
fn interrupt(child: &Child) {
    signal(child, Signal::SIGINT);
}

struct Running {
    index: usize,
    child: Child,
    started: Instant,
    bar: ProgressBar,
    interrupted_at: Option<Instant>,
}

fn start(exe: &Path, out: &Path, job: &Job, render: proto::RenderPath) -> Result<Child> {
    let dir = out.join(&job.dir);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    Command::new(exe)
        .args([
            "run",
            &job.case,
            "--modality",
            job.modality,
            "--render",
            render.as_str(),
            "--quiet",
            "--out",
        ])
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(dir.join("waggle-run.out"))?)
        .stderr(std::fs::File::create(dir.join("waggle-run.log"))?)
        .spawn()
        .with_context(|| {
            format!(
                "starting waggle run {} --modality {}",
                job.case, job.modality
            )
        })
}

fn stderr_tail(out: &Path, job: &Job) -> Option<String> {
    let text = std::fs::read_to_string(out.join(&job.dir).join("waggle-run.log")).ok()?;
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    (!lines.is_empty()).then(|| lines[lines.len().saturating_sub(3)..].join(" / "))
}

/// Runs the jobs; returns the manifest.
fn execute(args: &SweepOptions, jobs: &[Job]) -> Result<SweepManifest> {
    let exe = crate::waggle_binary()?;
    let stop = bus::on_stop_signal();
    let started = Instant::now();
    let multi = MultiProgress::new();
    let total = multi.add(ProgressBar::new(jobs.len() as u64));
    total.set_style(
        ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {pos}/{len} runs · {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let spinner = ProgressStyle::with_template("  {spinner} {prefix} · {elapsed} · {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
    let mut planned: Vec<PlannedRun> = jobs
        .iter()
        .map(|j| PlannedRun {
            case: j.case.clone(),
            modality: j.modality.to_string(),
            dir: j.dir.clone(),
            exit: "not started".into(),
            wall_s: 0.0,
            error_tail: None,
        })
        .collect();
    let mut next = 0usize;
    let mut running: Vec<Running> = Vec::new();
    let mut failed = 0usize;
    let mut interrupted = false;
    loop {
        if stop.load(Ordering::SeqCst) && !interrupted {
            interrupted = true;
            total.set_message("interrupted: stopping the running runs");
            for r in &mut running {
                interrupt(&r.child);
                r.interrupted_at = Some(Instant::now());
            }
        }
        while !interrupted && running.len() < args.jobs() && next < jobs.len() {
            let job = &jobs[next];
            let bar = multi.add(ProgressBar::new_spinner());
            bar.set_style(spinner.clone());
            bar.set_prefix(job.dir.clone());
            bar.set_message("running");
            match start(&exe, &args.out, job, args.render) {
                Ok(child) => running.push(Running {
                    index: next,
                    child,
                    started: Instant::now(),
                    bar,
                    interrupted_at: None,
                }),
                Err(e) => {
                    planned[next].exit = "not started".into();
                    planned[next].error_tail = Some(format!("{e:#}"));
                    bar.finish_and_clear();
                    failed += 1;
                    total.inc(1);
                }
            }
            next += 1;
        }
        if running.is_empty() && (interrupted || next >= jobs.len()) {
            break;
        }
        let mut still = Vec::new();
        for mut r in running.drain(..) {
            if r.interrupted_at
                .is_some_and(|t| t.elapsed() > Duration::from_secs(60))
            {
                let _ = r.child.kill();
            }
            match r.child.try_wait()? {
                Some(status) => {
                    let p = &mut planned[r.index];
                    p.exit = exit_label(status);
                    p.wall_s = r.started.elapsed().as_secs_f64();
                    if !status.success() {
                        failed += 1;
                        p.error_tail = stderr_tail(&args.out, &jobs[r.index]);
                    }
                    r.bar.finish_and_clear();
                    let line = format!(
                        "{} {} ({}, {:.0} s)",
                        if status.success() { "done  " } else { "FAILED" },
                        p.dir,
                        p.exit,
                        p.wall_s
                    );
                    if multi.is_hidden() {
                        println!("{line}");
                    } else {
                        let _ = multi.println(line);
                    }
                    total.inc(1);
                    total.set_message(format!("{failed} failed so far"));
                }
                None => {
                    r.bar.tick();
                    still.push(r);
                }
            }
        }
        running = still;
        std::thread::sleep(Duration::from_millis(200));
    }
    total.finish_and_clear();
    Ok(SweepManifest {
        runs: planned,
        jobs: args.jobs(),
        wall_s: started.elapsed().as_secs_f64(),
        interrupted,
    })
}

/// The sweep's verdict: an error naming every run that missed its expected outcome.
pub fn verdict(entries: &[RunEntry], interrupted: bool) -> Result<()> {
    let failed: Vec<&str> = entries
        .iter()
        .filter(|e| !e.pass())
        .map(|e| e.name.as_str())
        .collect();
    if interrupted {
        bail!("the sweep was interrupted (Ctrl-C)");
    }
    if !failed.is_empty() {
        bail!(
            "{} of {} run(s) did not meet their expected outcome: {}",
            failed.len(),
            entries.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

/// Runs the sweep, writes `sweep.json` and the report; an error when any run missed its
/// expected outcome or the sweep was interrupted.
pub fn run_sweep(args: &SweepOptions) -> Result<()> {
    let (jobs, skipped) = plan(args)?;
    for s in &skipped {
        println!("skipped: {s}");
    }
    if jobs.is_empty() {
        bail!("nothing to run");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    println!(
        "sweep: {} run(s), {} at a time, into {}",
        jobs.len(),
        args.jobs(),
        args.out.display()
    );
    let manifest = execute(args, &jobs)?;
    std::fs::write(
        args.out.join(SWEEP_FILE),
        serde_json::to_string_pretty(&manifest)?,
    )?;
    let (entries, manifest) = report::gather(&args.out)?;
    let interrupted = manifest.as_ref().is_some_and(|m| m.interrupted);
    let path = report::write_report(
        &args.out,
        &entries,
        manifest.as_ref(),
        !args.no_sensor_figure && !interrupted,
    )?;
    report::print_outcomes(&entries);
    println!("report: {}", path.display());
    verdict(&entries, interrupted)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::report::run_audit::check_against_case;
    use run_format::run_dir::audit::{AuditReport, AuditTiming};

    fn audit(messages: [usize; 3], work_units: u32, pass: bool) -> AuditReport {
        AuditReport {
            partial: false,
            partial_reason: None,
            case: "only-a".into(),
            modality: Some(proto::Receiver::Events),
            session: "s".into(),
            mission_time_s: 120.0,
            end_reason: Some(proto::EndReason::NoDecision),
            messages: ["O1", "O2", "O3"]
                .iter()
                .zip(messages)
                .map(|(o, n)| (o.to_string(), n))
                .collect(),
            payloads: BTreeMap::new(),
            work_units,
            work_units_by_observer: BTreeMap::new(),
            work_units_by_site: BTreeMap::new(),
            contact_steps: 0,
            min_separation_m: 0.4,
            timing: AuditTiming::default(),
            provenance_violations: vec![],
            assignments_audited: 0,
            events_per_observer: BTreeMap::new(),
            packets_per_observer: BTreeMap::new(),
            empty_packets_per_observer: BTreeMap::new(),
            undecodable_messages: 0,
            rejects: BTreeMap::new(),
            viewpoints: BTreeMap::new(),
            deaf_observers: vec![],
            pass,
            reasons: if pass {
                vec![]
            } else {
                vec!["O2 ends 0.3 m from its home".into()]
            },
        }
    }

    fn entry(a: AuditReport) -> RunEntry {
        let case = Case::load(&a.case).unwrap();
        RunEntry {
            name: "only-a-events".into(),
            case: a.case.clone(),
            modality: a.modality.map_or_else(String::new, |m| m.to_string()),
            files: None,
            failures: check_against_case(&case, &a),
            audit: Some(a),
            source: None,
        }
    }

    #[test]
    fn a_failing_audit_makes_the_sweep_fail() {
        assert!(verdict(&[entry(audit([1, 1, 1], 0, true))], false).is_ok());
        // The audit's own verdict counts even when the counts look right.
        let e = entry(audit([1, 1, 1], 0, false));
        assert_eq!(e.failures, ["O2 ends 0.3 m from its home"]);
        let err = verdict(&[entry(audit([1, 1, 1], 0, true)), e], false).unwrap_err();
        assert!(err.to_string().contains("1 of 2"), "{err}");
        // Counts that differ from the case file fail even if the audit said pass.
        let e = entry(audit([1, 0, 1], 0, true));
        assert_eq!(
            e.failures,
            ["complete messages [1, 0, 1], expected [1, 1, 1]"]
        );
        assert!(verdict(&[e], false).is_err());
        // An interrupted sweep fails.
        assert!(verdict(&[entry(audit([1, 1, 1], 0, true))], true).is_err());
    }

    #[test]
    fn the_plan_covers_each_case_in_its_modalities_only() {
        let args = |modality, cases: &[&str]| SweepOptions {
            modality,
            out: PathBuf::from("x"),
            jobs: Some(1),
            cases: cases.iter().map(|s| s.to_string()).collect(),
            no_sensor_figure: true,
            render: proto::RenderPath::default(),
        };
        let (all, skipped) = plan(&args(SweepModality::Both, &[])).unwrap();
        assert_eq!(all.len(), 13, "six cases × 2 + dropout-o2 events");
        assert_eq!(skipped, ["dropout-o2 does not apply to rgb"]);
        assert!(all.iter().any(|j| j.dir == "dropout-o2-events"));
        let (rgb, _) = plan(&args(SweepModality::Rgb, &["dropout-o2", "only-a"])).unwrap();
        assert_eq!(
            rgb.iter().map(|j| j.dir.as_str()).collect::<Vec<_>>(),
            ["only-a-rgb"]
        );
        assert!(plan(&args(SweepModality::Both, &["nope"])).is_err());
    }
}
