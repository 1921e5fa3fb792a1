//! The files that make a study or trials directory resumable and mergeable: `run.json` (what
//! the directory is a run of: kind, definition, trials per point, shard) and `run-cost.json`
//! (what its runs cost, added to by every run that ends, interrupted or not).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

use crate::harness::runs::records::{MANIFEST_FILE, read_json, write_json};
use crate::harness::trials::TrialsCost;

/// Where a run's costs accumulate (beside its records; merged into `cost.json`).
pub const RUN_COST_FILE: &str = "run-cost.json";

/// What a run directory holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunKind {
    /// `waggle study`: one subdirectory of records per point.
    Study,
    /// `waggle trials`: the records of one condition at the top.
    Trials,
    /// `waggle study` of a baselines study: one subdirectory of mission records per case × arm
    /// (× level).
    Baselines,
    /// `waggle trials --case`: the mission records of one case at the top.
    Missions,
}

/// `run.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunManifest {
    pub kind: RunKind,
    /// The study file as run (TOML, `--trials` applied) or the trials' condition.
    pub definition: String,
    /// Trials per point.
    pub requested: u64,
    /// `K/N`, or none for the whole run.
    pub shard: Option<String>,
}

impl RunManifest {
    /// Records this run in `dir`, or checks that `dir` holds a run of the same thing (a rerun,
    /// which resumes it).
    pub fn claim(&self, dir: &Path) -> Result<()> {
        let path = dir.join(MANIFEST_FILE);
        if !path.exists() {
            for old in ["trials.json", "report.md"] {
                if dir.join(old).exists() {
                    bail!(
                        "{} holds {old} but no {MANIFEST_FILE} (a run without per-trial \
                         records): choose another --out",
                        dir.display()
                    );
                }
            }
            return write_json(&path, self);
        }
        let was: Self = read_json(&path)?;
        let what = if was.kind != self.kind {
            format!("a {:?} run, not a {:?} run", was.kind, self.kind)
        } else if was.shard != self.shard {
            format!(
                "shard {}, not {}",
                was.shard.as_deref().unwrap_or("(whole run)"),
                self.shard.as_deref().unwrap_or("(whole run)")
            )
        } else if was.requested != self.requested {
            format!("{} trials per point, not {}", was.requested, self.requested)
        } else if was.definition != self.definition {
            format!(
                "another definition:\n{}\nnot:\n{}",
                was.definition, self.definition
            )
        } else {
            return Ok(());
        };
        bail!(
            "{} holds {what} ({}): resume it with the same arguments, or choose another --out",
            dir.display(),
            path.display()
        )
    }

    /// Reads `dir/run.json`.
    pub fn read(dir: &Path) -> Result<Self> {
        read_json(&dir.join(MANIFEST_FILE))
    }
}

/// What one point's trials cost, summed over runs and shards (a point's `cost.json`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCostSum {
    /// Trials run (not those found recorded).
    pub trials_run: u64,
    pub flights: u64,
    /// Of them, read from the render cache on disk (`--render-cache`).
    #[serde(default)]
    pub flights_from_cache: u64,
    pub fly_and_render_s: f64,
    pub trials_s: f64,
    /// The largest render cache any run held, MB.
    pub render_cache_mb: f64,
    /// CPU time of the trials (user + system, all threads), s.
    pub cpu_s: f64,
}

impl PointCostSum {
    /// One run's cost of `trials_run` trials.
    pub fn of(cost: &TrialsCost, trials_run: u64, cpu_s: f64) -> Self {
        Self {
            trials_run,
            flights: cost.flights,
            flights_from_cache: cost.flights_from_cache,
            fly_and_render_s: cost.fly_and_render_s,
            trials_s: cost.trials_s,
            render_cache_mb: cost.render_cache_mb,
            cpu_s,
        }
    }

    pub fn add(&mut self, o: &Self) {
        self.trials_run += o.trials_run;
        self.flights += o.flights;
        self.flights_from_cache += o.flights_from_cache;
        self.fly_and_render_s += o.fly_and_render_s;
        self.trials_s += o.trials_s;
        self.render_cache_mb = self.render_cache_mb.max(o.render_cache_mb);
        self.cpu_s += o.cpu_s;
    }
}

/// What runs cost: `run-cost.json` of one directory, or `cost.json` of a study (the sum of its
/// shards' and resumed runs').
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunCost {
    pub runs: u64,
    pub wall_s: f64,
    /// CPU time of the processes (flights, trials, writing), s.
    pub cpu_s: f64,
    pub trials_run: u64,
    /// Flights flown and rendered once for several points (a study's shared flights), and
    /// their wall time, s.
    #[serde(default)]
    pub shared_flights: u64,
    #[serde(default)]
    pub shared_fly_s: f64,
    /// Of the shared flights, read from the render cache on disk (`--render-cache`).
    #[serde(default)]
    pub shared_flights_from_cache: u64,
    /// By point directory (`.` for `waggle trials`).
    pub points: BTreeMap<String, PointCostSum>,
}

impl RunCost {
    pub fn add(&mut self, o: &Self) {
        self.runs += o.runs;
        self.wall_s += o.wall_s;
        self.cpu_s += o.cpu_s;
        self.trials_run += o.trials_run;
        self.shared_flights += o.shared_flights;
        self.shared_fly_s += o.shared_fly_s;
        self.shared_flights_from_cache += o.shared_flights_from_cache;
        for (k, v) in &o.points {
            self.points.entry(k.clone()).or_default().add(v);
        }
    }

    /// `dir/run-cost.json`, or nothing yet.
    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join(RUN_COST_FILE);
        if path.exists() {
            read_json(&path)
        } else {
            Ok(Self::default())
        }
    }

    /// Adds this run's cost to `dir/run-cost.json`.
    pub fn add_to(&self, dir: &Path) -> Result<()> {
        let mut total = Self::read(dir)?;
        total.add(self);
        write_json(&dir.join(RUN_COST_FILE), &total)
    }
}

/// The process's CPU time so far (user + system, every thread), with that of its children
/// already reaped (plug-in workers, a mission's processes), s.
pub fn cpu_s() -> f64 {
    use nix::sys::resource::{UsageWho, getrusage};
    [UsageWho::RUSAGE_SELF, UsageWho::RUSAGE_CHILDREN]
        .into_iter()
        .map(|who| {
            getrusage(who).map_or(0.0, |u| {
                let t =
                    |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 * 1e-6;
                t(u.user_time()) + t(u.system_time())
            })
        })
        .sum()
}
