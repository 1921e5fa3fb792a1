//! Waggle's cross-process tests, and the few helpers they share.
//!
//! Every test in `tests/tests/` drives the built binaries (`waggle` and the node processes it
//! launches) as a user would, or checks a property of the whole workspace (its crate layering,
//! its frozen behaviour). Unit and in-process tests stay beside the code they test; what lives
//! here is what only separate processes, or the workspace as a whole, can prove.
//!
//! `cargo test` only builds the binaries of the package under test, and this package has none, so
//! build every binary first, in the profile the tests run in:
//!
//! ```text
//! cargo build --release --workspace --bins
//! cargo test --release -p waggle-tests                  # the default suite
//! cargo test --release -p waggle-tests -- --ignored     # whole missions (`deploy/test.sh --full`)
//! ```
//!
//! `deploy/test.sh` does both. The binaries are found by path with [`bin`].

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The node binaries `waggle run` starts from the directory it lives in.
pub const NODES: [&str; 5] = [
    "sim-node",
    "observer-node",
    "performer-node",
    "scheduler-node",
    "recorder-node",
];

/// The directory holding the workspace's binaries for the profile these tests were built in.
///
/// A test executable lives in `<target>/<profile>/deps/`, so the binaries are in its parent's
/// parent: this follows `CARGO_TARGET_DIR`, `--target <triple>` and the profile without having to
/// know them. Only when the executable is not in a `deps` directory (copied elsewhere, run by
/// another harness) is `$CARGO_TARGET_DIR/release`, else `<workspace>/target/release`, used.
pub fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    if let Some(deps) = exe.parent()
        && deps.file_name().is_some_and(|n| n == "deps")
        && let Some(profile) = deps.parent()
    {
        return profile.to_path_buf();
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"));
    target.join("release")
}

/// The workspace's root directory (the parent of this package).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// The path of the workspace binary `name` (e.g. `"waggle"`, `"sim-node"`).
///
/// # Panics
///
/// If it was not built, naming the command that builds it.
pub fn bin(name: &str) -> PathBuf {
    let path = bin_dir().join(name);
    assert!(
        path.is_file(),
        "{} is missing: build the binaries first: cargo build --release --workspace --bins \
         (in the same profile as these tests)",
        path.display()
    );
    path
}

/// A `waggle` command, for subcommands that run in one process (`mission`, `link`, `payload`…).
pub fn waggle() -> Command {
    Command::new(bin("waggle"))
}

/// `waggle export ros2 RUN --out BAG`: a recording (a run directory or an `.mcap` file) as a
/// ROS 2 bag directory.
pub fn export_ros2(run: &Path, bag: &Path) -> Command {
    let mut cmd = waggle();
    cmd.args(["export", "ros2"]).arg(run).arg("--out").arg(bag);
    cmd
}

/// Runs `cmd` to its end and returns its output, panicking with its stderr unless it succeeded
/// (`what` names it in the message, e.g. `waggle compose`).
pub fn succeed(cmd: &mut Command, what: &str) -> std::process::Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// A `waggle` command for subcommands that launch the node processes (`run`, `sweep`), after
/// checking every node binary is there beside it.
pub fn waggle_with_nodes() -> Command {
    for node in NODES {
        bin(node);
    }
    waggle()
}

/// Starts `waggle run CASE --modality events --quiet --session SESSION --out DIR` in the
/// background, silent, for tests that interrupt a run (kill a child, send Ctrl-C). It leads
/// its own process group (as a command started from a terminal does), so a test can send a
/// signal to the whole group as Ctrl-C would.
pub fn spawn_background_run(case: &str, session: &str, dir: &Path) -> Child {
    use std::os::unix::process::CommandExt;
    waggle_with_nodes()
        .process_group(0)
        .args(["run", case, "--modality", "events", "--quiet", "--session"])
        .arg(session)
        .arg("--out")
        .arg(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start waggle run")
}

/// `node tests/js/SCRIPT ARGS…` (Foxglove's own client libraries, installed by
/// `deploy/setup.sh` into `tests/js/node_modules`).
///
/// # Panics
///
/// If the Node test clients are not installed, naming the command that installs them.
pub fn node_client(script: &str) -> Command {
    let js = workspace_root().join("tests/js");
    assert!(
        js.join("node_modules/@foxglove/ws-protocol").is_dir(),
        "the Node test clients are not installed: run bash deploy/setup.sh"
    );
    let mut c = Command::new("node");
    c.arg(js.join(script));
    c
}

/// The Python of the venv `deploy/setup.sh` makes (`tests/js/.venv`: the pinned PyPI readers
/// and writers the tests compare against).
///
/// # Panics
///
/// If the venv is missing, naming the command that makes it.
pub fn venv_python() -> PathBuf {
    let python = workspace_root().join("tests/js/.venv/bin/python");
    assert!(
        python.is_file(),
        "the Python test readers are not installed: run bash deploy/setup.sh"
    );
    python
}

/// The venv's Python once it can import `modules` (a Python import list, e.g. `"zenoh.ext,
/// rosbags"`); runs `deploy/setup.sh` first when it cannot (a venv of an older setup).
///
/// # Panics
///
/// If the venv still lacks them after setup.
pub fn venv_python_with(modules: &str) -> PathBuf {
    let python = workspace_root().join("tests/js/.venv/bin/python");
    let ready = || {
        Command::new(&python)
            .args(["-c", &format!("import {modules}")])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if !ready() {
        succeed(
            Command::new("bash").arg(workspace_root().join("deploy/setup.sh")),
            "bash deploy/setup.sh (the Python test clients in tests/js/.venv)",
        );
    }
    assert!(ready(), "tests/js/.venv cannot import {modules}");
    python
}

/// A loopback TCP port free at the time of asking.
///
/// # Panics
///
/// If the system has none to give.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free loopback port")
        .port()
}

/// The official Python `mcap` reader (`tests/js/read_mcap.py` in the venv `deploy/setup.sh`
/// makes) on `file`: its JSON report and whether it read the whole file.
///
/// # Panics
///
/// If the venv is missing, naming the command that makes it.
pub fn python_mcap_read(file: &Path) -> (bool, String) {
    let js = workspace_root().join("tests/js");
    let python = js.join(".venv/bin/python");
    assert!(
        python.is_file(),
        "the Python mcap reader is not installed: run bash deploy/setup.sh"
    );
    let out = Command::new(python)
        .arg(js.join("read_mcap.py"))
        .arg(file)
        .output()
        .expect("run read_mcap.py");
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

/// Checks `file` with `@mcap/core` against the official Foxglove schemas
/// (`tests/js/validate_mcap.mjs`) and with the official Python reader; returns the validator's
/// JSON report.
///
/// # Panics
///
/// If either reader fails or a view message does not validate.
pub fn assert_recording_validates(file: &Path) -> serde_json::Value {
    let out = node_client("validate_mcap.mjs")
        .arg(file)
        .output()
        .expect("run validate_mcap.mjs");
    let report = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{} does not validate against the official Foxglove schemas: {report}{}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let (ok, text) = python_mcap_read(file);
    assert!(
        ok,
        "the official Python mcap reader failed on {}: {text}",
        file.display()
    );
    serde_json::from_str(&report).expect("validate_mcap.mjs prints JSON")
}

/// A small link study for the shard and merge tests: two conditions (RGB read noise at two
/// levels, one level of event shot noise) × both modalities, two trials per point, one shared
/// flight (no term re-flies).
pub fn two_condition_study(name: &str, seed: u64) -> String {
    format!(
        r#"
name = "{name}"
modalities = ["rgb", "events"]
link = ["011010"]
observers = 1
trials = 2
seed = {seed}
criterion = "exact-payloads"
[[vary]]
key = "rgb.read_noise_grey"
levels = [0.0, 30.0]
[[vary]]
key = "events.shot_noise_hz"
levels = [0.0003]
"#
    )
}

/// `tools/ros2/publish_events.py publish`: a camera driver on `rmw_zenoh`, written with Eclipse
/// Zenoh's own Python client and `rosbags`, listening on a free loopback port. It publishes
/// once a subscription to its topic appears and reports to a JSON file when it has finished.
pub struct RosCameraDriver {
    child: std::process::Child,
    /// Where the ROS side's router would be: the driver's listener.
    pub endpoint: String,
    report: PathBuf,
}

impl RosCameraDriver {
    /// Starts the driver publishing `source` (an EVT 3.0 file or a bag) on `topic` of
    /// `domain`, with the script's further `args`, reporting into `dir`; returns once it
    /// listens.
    ///
    /// # Panics
    ///
    /// If the script cannot start.
    pub fn start(dir: &Path, domain: u32, topic: &str, source: &Path, args: &[&str]) -> Self {
        use std::io::BufRead;
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let report = dir.join("driver.json");
        let mut child = Command::new(venv_python_with("zenoh.ext, rosbags, evt3"))
            .arg(workspace_root().join("tools/ros2/publish_events.py"))
            .args(["publish", &endpoint, &domain.to_string(), topic])
            .arg(source)
            .arg(&report)
            .args(args)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("starting publish_events.py");
        let mut line = String::new();
        std::io::BufReader::new(child.stdout.take().expect("its stdout"))
            .read_line(&mut line)
            .expect("reading publish_events.py");
        assert_eq!(line.trim(), "ready", "publish_events.py did not start");
        Self {
            child,
            endpoint,
            report,
        }
    }

    /// Waits (at most `limit`) for the driver to finish and returns its report.
    ///
    /// # Panics
    ///
    /// If it fails, or is still running after `limit` (it is killed then).
    pub fn finish(mut self, limit: std::time::Duration) -> serde_json::Value {
        let deadline = std::time::Instant::now() + limit;
        let status = loop {
            if let Some(status) = self
                .child
                .try_wait()
                .expect("waiting for publish_events.py")
            {
                break status;
            }
            if std::time::Instant::now() >= deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!("publish_events.py did not finish in {limit:?}");
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        };
        assert!(status.success(), "publish_events.py failed");
        serde_json::from_slice(&std::fs::read(&self.report).expect("the driver's report"))
            .expect("the driver's JSON")
    }
}
