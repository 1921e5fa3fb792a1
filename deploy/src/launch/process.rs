//! Process control: starting a node binary with its logs in the run directory, polling it
//! (exit status and CPU time from `/proc` through `procfs`), stopping it gracefully (SIGTERM
//! through `nix`) or at once.

use std::fs::File;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use bus::{NodeArgs, SessionSecrets};
use nix::sys::signal::Signal;

/// How long a graceful child (the recorder closing its file) gets after SIGTERM.
const GRACE: Duration = Duration::from_secs(15);

/// One supervised child process.
pub struct Proc {
    pub name: String,
    pub child: Child,
    /// CPU time (user + system) last read from /proc, seconds.
    pub cpu_s: f64,
    pub exit: Option<String>,
    pub success: bool,
    pub killed_by_fault: bool,
    /// Stopped by the launcher (end of run, failure elsewhere or Ctrl-C).
    pub stopped: bool,
    /// Stopped with SIGTERM and given time to finish (the recorder closes its file).
    pub graceful: bool,
    pub stdout_path: PathBuf,
    pub stderr_path: PathBuf,
}

/// User + system CPU seconds of a live or zombie process.
fn cpu_seconds(pid: u32) -> Option<f64> {
    let stat = procfs::process::Process::new(i32::try_from(pid).ok()?)
        .ok()?
        .stat()
        .ok()?;
    Some((stat.utime + stat.stime) as f64 / procfs::ticks_per_second() as f64)
}

pub use run_eval::child::{exit_label, signal};

/// Sends SIGTERM and waits up to `timeout` for the child to exit; true if it did.
pub fn terminate(child: &mut Child, timeout: Duration) -> bool {
    if !signal(child, Signal::SIGTERM) {
        return false;
    }
    let until = Instant::now() + timeout;
    while Instant::now() < until {
        if let Ok(Some(_)) = child.try_wait() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

impl Proc {
    /// Reads the CPU time (the final one once the process is a zombie) and reaps it if done.
    pub fn poll(&mut self) -> Result<()> {
        if self.exit.is_some() {
            return Ok(());
        }
        if let Some(cpu_s) = cpu_seconds(self.child.id()) {
            self.cpu_s = cpu_s;
        }
        if let Some(status) = self.child.try_wait()? {
            self.success = status.success();
            self.exit = Some(exit_label(status));
        }
        Ok(())
    }

    pub fn running(&self) -> bool {
        self.exit.is_none()
    }

    /// Stops the process (SIGTERM first when graceful, then SIGKILL).
    pub fn kill(&mut self) {
        if self.running() {
            self.stopped = true;
            if self.graceful && terminate(&mut self.child, GRACE) {
                return;
            }
            let _ = self.child.kill();
        }
    }

    /// True if it ended on its own and not well (not a fault, not stopped by the launcher).
    pub fn failed_on_its_own(&self) -> bool {
        !self.success && !self.killed_by_fault && !self.stopped
    }

    /// Its figures for `summary.json` / `host.json`.
    pub fn figures(&self) -> crate::run_dir::ProcessFigures {
        crate::run_dir::ProcessFigures {
            cpu_s: self.cpu_s,
            exit: self.exit.clone().unwrap_or_else(|| "running".into()),
            killed_by_fault: self.killed_by_fault,
        }
    }

    /// The last lines of its stderr log.
    pub fn tail(&self) -> String {
        let text = std::fs::read_to_string(&self.stderr_path).unwrap_or_default();
        // The error, not the frames of a backtrace (RUST_BACKTRACE set by the user).
        let text = text.split("\nStack backtrace:").next().unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(5)..].join("\n")
    }
}

/// Mesa llvmpipe's rasteriser thread count.
const LLVMPIPE_THREADS: &str = "LP_NUM_THREADS";

/// Starts node binaries of one run: from one directory, with the run's node arguments, logs
/// in the run's log directory.
pub struct Spawner<'a> {
    pub bin_dir: &'a Path,
    pub log_dir: &'a Path,
    pub node: NodeArgs,
    /// Per-process credentials (authenticated sessions): each child gets the path of its own.
    pub secrets: Option<&'a SessionSecrets>,
}

impl Spawner<'_> {
    /// Starts `binary args… <node args>` as the process `name`.
    pub fn spawn(&self, name: &str, binary: &str, args: &[String]) -> Result<Proc> {
        let bin = self.bin_dir.join(binary);
        if !bin.exists() {
            bail!(
                "{} not found: build the node binaries first (cargo build --release -p deploy \
                 -p sim-node -p observer-node -p performer-node -p scheduler-node -p recorder-node) \
                 or pass --bin-dir",
                bin.display()
            );
        }
        let stdout_path = self.log_dir.join(format!("{name}.out"));
        let stderr_path = self.log_dir.join(format!("{name}.log"));
        let mut cmd = Command::new(&bin);
        if std::env::var_os(LLVMPIPE_THREADS).is_none() {
            // Mesa's CPU rasteriser hands each draw to worker threads by default. With several
            // camera processes on two cores the hand-off costs more than it saves: rasterising
            // on the calling thread measured 0.90 against 1.17 ms per damage render and 2.68
            // against 3.27 ms per full render (`cargo bench -p sim`), with identical pixels (the
            // same tile code runs either way). A value the user set is kept.
            cmd.env(LLVMPIPE_THREADS, "0");
        }
        // Each child leads its own process group, so a Ctrl-C in the terminal (SIGINT to the
        // foreground group) reaches only the launcher, which then stops every child in order —
        // the recorder with SIGTERM so that it finalises its file — and writes the summary.
        cmd.process_group(0);
        let mut node = self.node.clone();
        if let Some(secrets) = self.secrets {
            let file = secrets
                .file_of(name)
                .with_context(|| format!("no credentials for process {name}"))?;
            node.credentials = Some(file.to_path_buf());
        }
        cmd.args(args)
            .args(node.to_args())
            .stdin(Stdio::null())
            .stdout(File::create(&stdout_path)?)
            .stderr(File::create(&stderr_path)?);
        if std::env::var_os("RUST_LOG").is_none() {
            cmd.env("RUST_LOG", "info,zenoh=warn");
        }
        // Backup for binaries built without the rpath to MuJoCo: the checkout's copy, after what
        // the environment names (a relocatable bundle's wrapper names its own libraries, which
        // must win; see deploy/relocatable.sh).
        let mujoco = Path::new(env!("CARGO_MANIFEST_DIR")).join("../third_party/mujoco/lib");
        let mut paths: Vec<std::path::PathBuf> = std::env::var_os("LD_LIBRARY_PATH")
            .map(|old| std::env::split_paths(&old).collect())
            .unwrap_or_default();
        paths.push(mujoco);
        cmd.env("LD_LIBRARY_PATH", std::env::join_paths(paths)?);
        let child = cmd
            .spawn()
            .with_context(|| format!("starting {}", bin.display()))?;
        Ok(Proc {
            name: name.to_string(),
            child,
            cpu_s: 0.0,
            exit: None,
            success: false,
            killed_by_fault: false,
            stopped: false,
            graceful: false,
            stdout_path,
            stderr_path,
        })
    }
}
