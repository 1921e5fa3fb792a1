//! Independent seeded trials on a few threads: trial k runs on whichever thread takes it next,
//! results are returned sorted by index, so nothing a trial records depends on `jobs`.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use anyhow::Result;
use perturb::stats::wilson95;
use serde::{Deserialize, Serialize};

/// How a run's trials ended, as every `trials.json` records it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Tally {
    pub requested: u64,
    pub trials: u64,
    pub interrupted: bool,
    pub successes: u64,
    pub success_rate: Option<f64>,
    /// Wilson score interval of the success rate.
    pub ci95: [f64; 2],
}

impl Tally {
    /// The tally of the finished `records` of `requested` trials.
    pub fn of<T: Outcome>(records: &[T], requested: u64) -> Self {
        let trials = records.len() as u64;
        let successes = records.iter().filter(|r| r.success()).count() as u64;
        Self {
            requested,
            trials,
            interrupted: trials < requested,
            successes,
            success_rate: (trials > 0).then(|| successes as f64 / trials as f64),
            ci95: wilson95(successes, trials),
        }
    }
}

/// What the pool needs to know of a finished trial.
pub trait Outcome {
    fn index(&self) -> u64;
    fn success(&self) -> bool;
}

/// Runs trials `0..trials` on `jobs` threads (see [`run_pool_on`]).
pub fn run_pool<T: Outcome + Send>(
    trials: u64,
    jobs: usize,
    stop: &AtomicBool,
    run: impl Fn(u64) -> Result<Option<T>> + Sync,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<Vec<T>> {
    let indices: Vec<u64> = (0..trials).collect();
    run_pool_on(&indices, jobs, stop, run, progress)
}

/// Runs the trials `indices` on `jobs` threads, calling `progress(done, successes)` after each.
/// `run(k)` returns `None` when it saw `stop` and abandoned trial k. When `stop` is raised no
/// trial starts; the first error raises it and is returned once the running trials end.
pub fn run_pool_on<T: Outcome + Send>(
    indices: &[u64],
    jobs: usize,
    stop: &AtomicBool,
    run: impl Fn(u64) -> Result<Option<T>> + Sync,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<Vec<T>> {
    let next = AtomicUsize::new(0);
    let done = Mutex::new(Vec::<T>::new());
    let failure = Mutex::new(None::<anyhow::Error>);
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1).min(indices.len().max(1)) {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::SeqCst);
                    let Some(&index) = indices.get(k) else {
                        return;
                    };
                    if stop.load(Ordering::SeqCst) {
                        return;
                    }
                    match run(index) {
                        Ok(Some(record)) => {
                            let mut done = done.lock().unwrap_or_else(|e| e.into_inner());
                            done.push(record);
                            let successes = done.iter().filter(|r| r.success()).count() as u64;
                            progress(done.len() as u64, successes);
                        }
                        Ok(None) => return,
                        Err(e) => {
                            stop.store(true, Ordering::SeqCst);
                            failure
                                .lock()
                                .unwrap_or_else(|e| e.into_inner())
                                .get_or_insert(e.context(format!("trial {index}")));
                            return;
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    let mut records = done.into_inner().unwrap_or_else(|e| e.into_inner());
    records.sort_by_key(Outcome::index);
    Ok(records)
}
