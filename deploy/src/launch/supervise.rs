//! The supervisor loop of `waggle run`: waits for every process at start-up, publishes the
//! fault messages, declares the launcher ready, then gathers from the bus, kills cameras at
//! their dropout time, watches the children and draws the progress line until the scheduler's
//! report is in and every child has exited (or a child fails, or Ctrl-C).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use bus::{Bus, BusError, Inbound, handshake};
use indicatif::{ProgressBar, ProgressStyle};
use proto::scene::{observer_home_m, observer_name};
use proto::{Keys, ObserverId, Role};

use super::gather::Gathered;
use super::process::Proc;
use super::rss::RssSampler;
use crate::case::Case;
use crate::fault::Injected;
use run_eval::summary::ns_s;

/// How long every process gets to start and join the handshake.
const STARTUP_TIMEOUT: Duration = Duration::from_secs(180);
/// How long the children get to exit once the mission report is in.
const EXIT_AFTER_REPORT: Duration = Duration::from_secs(20);
/// How long the launcher reads what is still queued once the mission is over, while every
/// expected reject report is in (it stops sooner at the first 200 ms of silence).
const DRAIN: Duration = Duration::from_secs(2);
/// How long it waits, at most, for reject reports still missing: each process publishes its
/// report as it exits, and on a flooded bus the report can queue behind seconds of junk
/// (`tests/hostile.rs` lost observer-O1's this way once, at 2 s).
const REPORTS_WAIT: Duration = Duration::from_secs(10);
/// How often the mission loop polls the children (each poll reads every child's `/proc` stat
/// and waits on it). The loop turns once per burst of messages, ≈ 140 times a second in a
/// 3-observer run, and polled on every turn: `strace -c` counted 21 800 `/proc` opens in 8 s of
/// an `only-a` run, 2 420 with this bound. The gain is small against the router the launcher
/// also runs (its own CPU 10.0 → 9.4 s in an A/B pair of runs, inside the machine's noise).
/// A child's exit is seen at most this much later; its CPU time is then read from the zombie,
/// so it is the final one.
const CHILD_POLL: Duration = Duration::from_millis(50);

/// What this launcher does for the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Duty {
    /// The simulator's host: waits for every process, injects the faults, gathers everything.
    Supervise,
    /// Another host: watches its own nodes, stops its cameras at their dropout time and ends
    /// with the mission (a host running only the router leaves once every process has gone).
    Host,
}

/// Everything the supervisor works with.
pub struct Supervisor<'a> {
    pub bus: &'a mut Bus,
    pub procs: &'a mut [Proc],
    /// The launcher's own handshake identity.
    pub me: &'a handshake::Process,
    pub case: &'a Case,
    pub observers: &'a [ObserverId],
    pub injected: &'a [Injected],
    /// Set by SIGINT/SIGTERM.
    pub stop: &'a AtomicBool,
    /// No progress bar.
    pub quiet: bool,
    /// A recorder takes part (on whichever host).
    pub recorder: bool,
    pub duty: Duty,
    /// `--rss-every-s`: samples every process's resident memory (a measurement only).
    pub rss: Option<RssSampler>,
    /// Where the observers' tracks wait until `observers.json` is written (the run directory).
    pub spool_dir: &'a std::path::Path,
}

/// What a supervised run gathered.
#[derive(Default)]
pub struct Supervised {
    pub gathered: Gathered,
    /// Injected faults with the sim time they took effect, and supervisor interventions.
    pub fault_log: Vec<String>,
    /// Ctrl-C stopped the run.
    pub interrupted: bool,
}

/// A camera to SIGKILL at a sim time.
struct PendingKill {
    observer: ObserverId,
    at_ns: u64,
    done: bool,
}

impl Supervisor<'_> {
    /// Runs until the scheduler's report is in and every child has exited (or a child fails,
    /// or Ctrl-C).
    pub fn run(mut self) -> Result<Supervised> {
        if !self.start_up()? {
            return Ok(Supervised {
                interrupted: true,
                ..Supervised::default()
            });
        }
        let mut fault_log = Vec::new();
        if self.duty == Duty::Supervise {
            fault_log = self.publish_faults()?;
            handshake::declare_ready(self.bus, self.me)?;
        }
        let bar = progress_bar(self.quiet);
        let homes_m: BTreeMap<String, [f64; 3]> = (0..self.case.observers)
            .map(|i| (observer_name(i), observer_home_m(i, self.case.observers)))
            .collect();
        let mut g = Gathered::new(homes_m, self.spool_dir.to_path_buf());
        let outcome = self.mission(&mut g, &mut fault_log, &bar);
        if outcome.is_err() {
            bar.finish_and_clear();
        }
        let interrupted = outcome?;
        self.drain(&mut g, interrupted);
        bar.finish_and_clear();
        Ok(Supervised {
            gathered: g,
            fault_log,
            interrupted,
        })
    }

    /// Waits for every process, checking the children meanwhile; false on Ctrl-C.
    fn start_up(&mut self) -> Result<bool> {
        let mut everyone = handshake::mission_processes(self.case.observers, true);
        if self.recorder {
            everyone.push(handshake::Process::singleton(Role::Recorder));
        }
        let deadline = Instant::now() + STARTUP_TIMEOUT;
        loop {
            if self.stop.load(Ordering::SeqCst) {
                return Ok(false);
            }
            for p in self.procs.iter_mut() {
                p.poll()?;
                if !p.running() {
                    bail!(
                        "{} exited during start-up ({})",
                        p.name,
                        p.exit.as_deref().unwrap_or("?")
                    );
                }
            }
            match handshake::await_everyone(self.bus, &everyone, Duration::from_millis(200)) {
                Ok(()) => return Ok(true),
                Err(BusError::Timeout { what, .. }) if Instant::now() >= deadline => {
                    bail!("start-up timed out: {what}")
                }
                Err(BusError::Timeout { .. }) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Publishes the fault messages before the clock starts; returns their log lines.
    fn publish_faults(&mut self) -> Result<Vec<String>> {
        let keys = self.bus.keys().clone();
        let mut log = Vec::new();
        for f in self.injected {
            if let Injected::Message(fault) = f {
                self.bus.put(&keys.fault(&fault.observer), fault)?;
                log.push(format!(
                    "{:?} on {} from {:.2} s (fault/{} published before the clock started)",
                    fault.kind,
                    fault.observer,
                    ns_s(fault.from_ns),
                    fault.observer
                ));
            }
        }
        Ok(log)
    }

    /// The mission loop; returns whether it was interrupted.
    fn mission(
        &mut self,
        g: &mut Gathered,
        fault_log: &mut Vec<String>,
        bar: &ProgressBar,
    ) -> Result<bool> {
        let keys = self.bus.keys().clone();
        let mut kills: Vec<PendingKill> = self
            .injected
            .iter()
            .filter_map(|f| match f {
                Injected::KillCamera { observer, at_ns } => Some(PendingKill {
                    observer: observer.clone(),
                    at_ns: *at_ns,
                    done: false,
                }),
                Injected::Message(_) => None,
            })
            .collect();
        let mut report_at: Option<Instant> = None;
        let mut last_draw = Instant::now();
        let mut children_polled: Option<Instant> = None;
        loop {
            if self.stop.load(Ordering::SeqCst) {
                for p in self.procs.iter_mut() {
                    p.kill();
                }
                fault_log.push(format!(
                    "interrupted (Ctrl-C) at sim {:.2} s: every child stopped",
                    ns_s(g.now_ns())
                ));
                return Ok(true);
            }
            self.receive(&keys, g)?;
            self.kill_cameras(g, &mut kills, fault_log);
            self.sample_rss(g);
            if children_polled.is_none_or(|t| t.elapsed() >= CHILD_POLL) {
                self.check_children(g)?;
                children_polled = Some(Instant::now());
            }
            if self.duty == Duty::Host && self.host_done(g, report_at) {
                return Ok(false);
            }
            if g.report.is_some() {
                let at = *report_at.get_or_insert_with(Instant::now);
                if self.procs.iter().all(|p| !p.running()) {
                    return Ok(false);
                }
                if at.elapsed() > EXIT_AFTER_REPORT {
                    for p in self.procs.iter_mut().filter(|p| p.running()) {
                        fault_log
                            .push(format!("{} did not exit after the mission: killed", p.name));
                        p.kill();
                    }
                }
            } else if !self.procs.is_empty() && self.procs.iter().all(|p| !p.running()) {
                bail!("every process exited without a mission report");
            }
            if last_draw.elapsed() > Duration::from_millis(100) {
                bar.set_message(g.message(self.observers));
                bar.tick();
                last_draw = Instant::now();
            }
        }
    }

    /// A host's launcher is done when its nodes have all exited, or — running none, only the
    /// router — once the report is in and every other process has left (bounded).
    fn host_done(&self, g: &Gathered, report_at: Option<Instant>) -> bool {
        if !self.procs.is_empty() {
            return self.procs.iter().all(|p| !p.running());
        }
        let Some(at) = report_at else {
            return false;
        };
        let keys = self.bus.keys();
        let mine = self.me.alive_key(keys).unwrap_or_default();
        let others = self.bus.alive_keys().iter().filter(|k| **k != mine).count();
        g.report.is_some() && (others == 0 || at.elapsed() > EXIT_AFTER_REPORT)
    }

    /// Drains what arrived (up to 256 samples; waits up to 20 ms for the first).
    fn receive(&mut self, keys: &Keys, g: &mut Gathered) -> Result<()> {
        let mut budget = 256;
        while let Some(item) =
            self.bus
                .recv(Duration::from_millis(if budget == 256 { 20 } else { 0 }))
        {
            if let Inbound::Data { key, payload } = item {
                g.take(keys, &key, &payload);
            }
            budget -= 1;
            if budget == 0 {
                break;
            }
        }
        Ok(())
    }

    /// Samples the processes' memory when sim time crosses the next multiple of the period;
    /// a file that cannot be written ends the sampling, never the run.
    fn sample_rss(&mut self, g: &Gathered) {
        if g.clock_started.is_none() {
            return;
        }
        if let Some(rss) = self.rss.as_mut()
            && let Err(e) = rss.sample(g.now_ns(), self.procs)
        {
            eprintln!("waggle: {e:#}: no more memory samples");
            self.rss = None;
        }
    }

    /// SIGKILLs each dropout camera once the clock has passed its time.
    fn kill_cameras(&mut self, g: &Gathered, kills: &mut [PendingKill], log: &mut Vec<String>) {
        let now_ns = g.now_ns();
        for k in kills.iter_mut() {
            if k.done || g.clock_started.is_none() || now_ns < k.at_ns {
                continue;
            }
            let name = format!("camera-{}", k.observer);
            if let Some(p) = self.procs.iter_mut().find(|p| p.name == name) {
                p.killed_by_fault = true;
                p.kill();
                log.push(format!(
                    "SIGKILL {name} at sim {:.2} s (asked {:.2} s)",
                    ns_s(now_ns),
                    ns_s(k.at_ns)
                ));
            }
            k.done = true;
        }
    }

    /// Fails the run when a child fails before the mission report.
    fn check_children(&mut self, g: &Gathered) -> Result<()> {
        for p in self.procs.iter_mut() {
            p.poll()?;
            if !p.running() && !p.success && !p.killed_by_fault && g.report.is_none() {
                bail!(
                    "{} failed ({}) at sim {:.2} s",
                    p.name,
                    p.exit.as_deref().unwrap_or("?"),
                    ns_s(g.now_ns())
                );
            }
        }
        Ok(())
    }

    /// Messages published just before the publishers exited may still be queued: read them,
    /// and wait (bounded) for the reject reports not in yet, naming any that never came.
    fn drain(&mut self, g: &mut Gathered, interrupted: bool) {
        let keys = self.bus.keys().clone();
        let expected = if interrupted {
            Vec::new()
        } else {
            self.expected_reports()
        };
        let missing = |g: &Gathered| -> Vec<String> {
            expected
                .iter()
                .filter(|p| !g.reports.contains_key(*p))
                .cloned()
                .collect()
        };
        let start = Instant::now();
        loop {
            let waiting = !missing(g).is_empty();
            if start.elapsed() >= if waiting { REPORTS_WAIT } else { DRAIN } {
                break;
            }
            match self.bus.recv(Duration::from_millis(200)) {
                Some(Inbound::Data { key, payload }) => g.take(&keys, &key, &payload),
                Some(_) => {}
                None if !waiting => break,
                None => {}
            }
        }
        let missing = missing(g);
        if !missing.is_empty() {
            eprintln!(
                "waggle: no reject report from {} within {} s of the mission's end: their \
                 rejects are not in summary.json",
                missing.join(", "),
                REPORTS_WAIT.as_secs()
            );
        }
    }

    /// The processes whose reject report the supervising launcher waits for: every mission
    /// process but a camera killed by a fault and a local child that failed (neither
    /// published one).
    fn expected_reports(&self) -> Vec<String> {
        if self.duty != Duty::Supervise {
            return Vec::new();
        }
        let mut everyone = handshake::mission_processes(self.case.observers, false);
        if self.recorder {
            everyone.push(handshake::Process::singleton(Role::Recorder));
        }
        let killed: Vec<String> = self
            .injected
            .iter()
            .filter_map(|f| match f {
                Injected::KillCamera { observer, .. } => Some(format!("camera-{observer}")),
                Injected::Message(_) => None,
            })
            .collect();
        everyone
            .iter()
            .map(handshake::Process::name)
            .filter(|name| !killed.contains(name))
            .filter(|name| {
                self.procs
                    .iter()
                    .all(|p| p.name != *name || (p.success && !p.killed_by_fault))
            })
            .collect()
    }
}

fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new_spinner();
    b.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    b
}
