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
