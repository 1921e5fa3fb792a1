//! The worker process: `PYTHON -m waggle._worker MODULE:CLASS`, its pipes, a reply awaited no
//! longer than the trial's deadline (then the worker is killed), and a pool that keeps one
//! worker per job between trials.
//!
//! The deadline is the only wall-clock value that can decide anything, and only that a trial
//! ran too long; a trial it ends is recorded as `timed-out`, never as a result.

use std::io::Write;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, sync_channel};
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::error::PluginError;
use crate::spec::PluginSpec;
use crate::wire::{self, FrameError, MAX_REPLY_BYTES};

/// The pipe size asked for the worker's input: a 640×480 RGB frame and its header.
#[cfg(target_os = "linux")]
const PIPE_BYTES: i32 = 1 << 20;

/// How long a worker whose pipe closed is given to end (polls × interval) before it is killed.
const GONE_POLLS: u32 = 400;
const GONE_POLL: Duration = Duration::from_millis(5);

/// The interpreter a worker runs on when `WAGGLE_PYTHON` does not name one.
pub const DEFAULT_PYTHON: &str = "python3";

/// The interpreter workers run on: `WAGGLE_PYTHON`, else `python3` on the `PATH`.
pub fn python() -> String {
    std::env::var("WAGGLE_PYTHON")
        .ok()
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| DEFAULT_PYTHON.to_owned())
}

/// Starts a worker for `spec` on [`python`] and checks the plug-in's class loads in it (then ends
/// it): a plug-in that cannot be imported or built is refused by name before anything runs.
pub fn check_loads(spec: &PluginSpec, limit: Option<Duration>) -> Result<(), PluginError> {
    WorkerPool::new(spec.clone(), python(), limit).check()
}

/// One worker process hosting a plug-in's instances (one per observer).
pub struct Worker {
    spec: PluginSpec,
    child: Child,
    stdin: ChildStdin,
    replies: Receiver<Result<Value, FrameError>>,
    /// When the current trial's time is up (`None`: no limit).
    deadline: Option<Instant>,
    limit_s: f64,
    /// Broken (killed, crashed or out of step): never reused.
    broken: bool,
}

impl Worker {
    /// Starts a worker for `spec` on `python`.
    pub fn spawn(spec: &PluginSpec, python: &str) -> Result<Self, PluginError> {
        let mut child = Command::new(python)
            .args([
                "-m",
                "waggle._worker",
                &format!("{}:{}", spec.module, spec.class),
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|source| PluginError::Spawn {
                python: python.to_owned(),
                spec: spec.to_string(),
                source,
            })?;
        let (Some(stdin), Some(mut stdout)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(PluginError::Spawn {
                python: python.to_owned(),
                spec: spec.to_string(),
                source: std::io::Error::other("no pipes"),
            });
        };
        // A frame of pixels is about a megabyte: a pipe that holds one whole saves the worker and
        // this process a dozen wake-ups each (Linux; elsewhere, or when refused, the default).
        #[cfg(target_os = "linux")]
        {
            use nix::fcntl::{FcntlArg, fcntl};
            let _ = fcntl(&stdin, FcntlArg::F_SETPIPE_SZ(PIPE_BYTES));
        }
        // A reader thread turns the blocking pipe into a channel a deadline can wait on; it ends
        // when the worker closes its output.
        let (tx, replies) = sync_channel(1);
        std::thread::Builder::new()
            .name("plugin-reader".into())
            .spawn(move || {
                loop {
                    let reply = wire::read_reply(&mut stdout, MAX_REPLY_BYTES);
                    let end = reply.is_err();
                    if tx.send(reply).is_err() || end {
                        break;
                    }
                }
            })
            .map_err(|source| PluginError::Spawn {
                python: python.to_owned(),
                spec: spec.to_string(),
                source,
            })?;
        Ok(Self {
            spec: spec.clone(),
            child,
            stdin,
            replies,
            deadline: None,
            limit_s: 0.0,
            broken: false,
        })
    }

    pub fn spec(&self) -> &PluginSpec {
        &self.spec
    }

    /// Starts a trial's clock: every reply from now on must come within `limit` of now.
    pub fn start_trial(&mut self, limit: Option<Duration>) {
        self.deadline = limit.map(|l| Instant::now() + l);
        self.limit_s = limit.map_or(0.0, |l| l.as_secs_f64());
    }

    /// Whether the worker can serve another trial.
    pub fn reusable(&self) -> bool {
        !self.broken
    }

    /// Sends one request and waits for its reply's value (the plug-in's exception and a
    /// malformed reply are errors naming `observer` and `call`).
    pub fn call(
        &mut self,
        observer: &str,
        call: &str,
        header: &Value,
        bulk: &[u8],
    ) -> Result<Value, PluginError> {
        let head = wire::encode_head(header, bulk.len());
        let sent = self
            .stdin
            .write_all(&head)
            .and_then(|()| self.stdin.write_all(bulk))
            .and_then(|()| self.stdin.flush());
        if sent.is_err() {
            return Err(self.gone(observer, call));
        }
        let reply = match self.deadline {
            None => self
                .replies
                .recv()
                .map_err(|_| RecvTimeoutError::Disconnected),
            Some(deadline) => self
                .replies
                .recv_timeout(deadline.saturating_duration_since(Instant::now())),
        };
        let reply = match reply {
            Ok(Ok(reply)) => reply,
            Ok(Err(FrameError::Closed)) | Err(RecvTimeoutError::Disconnected) => {
                return Err(self.gone(observer, call));
            }
            Ok(Err(e)) => {
                self.kill();
                return Err(self.malformed(observer, call, e.to_string()));
            }
            Err(RecvTimeoutError::Timeout) => {
                self.kill();
                return Err(PluginError::TimedOut {
                    spec: self.spec.to_string(),
                    observer: observer.to_owned(),
                    call: call.to_owned(),
                    limit_s: self.limit_s,
                });
            }
        };
        wire::reply_value(reply).map_err(|e| match e {
            Ok(message) => PluginError::Raised {
                spec: self.spec.to_string(),
                observer: observer.to_owned(),
                call: call.to_owned(),
                message,
            },
            Err(why) => self.malformed(observer, call, why),
        })
    }

    pub(crate) fn malformed(&self, observer: &str, call: &str, why: String) -> PluginError {
        PluginError::Malformed {
            spec: self.spec.to_string(),
            observer: observer.to_owned(),
            call: call.to_owned(),
            why,
        }
    }

    /// The worker ended (or its pipe broke): how it ended.
    fn gone(&mut self, observer: &str, call: &str) -> PluginError {
        self.broken = true;
        // Its pipe closes a moment before the process is gone: wait for it (bounded), so the
        // recorded reason is its exit status, not whichever of the two this process saw first.
        let mut status = None;
        for _ in 0..GONE_POLLS {
            if let Ok(Some(s)) = self.child.try_wait() {
                status = Some(s.to_string());
                break;
            }
            std::thread::sleep(GONE_POLL);
        }
        let status = status.unwrap_or_else(|| {
            self.kill();
            "its pipe closed".to_owned()
        });
        PluginError::WorkerGone {
            spec: self.spec.to_string(),
            observer: observer.to_owned(),
            call: call.to_owned(),
            status,
        }
    }

    /// Kills and reaps the worker (its CPU time then counts among the caller's children).
    pub fn kill(&mut self) {
        self.broken = true;
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Workers kept between trials, at most one per job (a trial takes one and gives it back).
pub struct WorkerPool {
    spec: PluginSpec,
    python: String,
    limit: Option<Duration>,
    free: Mutex<Vec<Worker>>,
}

impl WorkerPool {
    /// A pool for `spec` on `python`, each trial limited to `limit` of wall-clock time.
    pub fn new(spec: PluginSpec, python: String, limit: Option<Duration>) -> Self {
        Self {
            spec,
            python,
            limit,
            free: Mutex::new(Vec::new()),
        }
    }

    pub fn spec(&self) -> &PluginSpec {
        &self.spec
    }

    /// Starts a worker and checks the plug-in's class loads in it, before any trial: a plug-in
    /// that cannot be imported fails the run, naming it, instead of every trial.
    pub fn check(&self) -> Result<(), PluginError> {
        let mut worker = Worker::spawn(&self.spec, &self.python)?;
        worker.start_trial(self.limit);
        let header = serde_json::json!({"op": "hello", "observer": "-"});
        worker.call("-", "loading the plug-in", &header, &[])?;
        self.give(worker);
        Ok(())
    }

    /// A worker for one trial, its clock started.
    pub fn take(&self) -> Result<Worker, PluginError> {
        let kept = self.free.lock().map_or(None, |mut f| f.pop());
        let mut worker = match kept {
            Some(w) => w,
            None => Worker::spawn(&self.spec, &self.python)?,
        };
        worker.start_trial(self.limit);
        Ok(worker)
    }

    /// Gives a worker back after its trial; a broken one is dropped (killed).
    pub fn give(&self, worker: Worker) {
        if worker.reusable()
            && let Ok(mut free) = self.free.lock()
        {
            free.push(worker);
        }
    }

    /// Ends every kept worker (their CPU time then counts among the process's children).
    pub fn close(&self) {
        if let Ok(mut free) = self.free.lock() {
            free.clear();
        }
    }
}
