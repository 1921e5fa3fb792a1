//! `lab`: the Waggle lab — what flies the simulator (MuJoCo) in-process, behind the
//! `waggle-lab` binary that `waggle` hands its lab commands to (`waggle mission`, `link`,
//! `trials`, `study`, `viewpoints`, `decode`, `events`, `report`, `sweep`).
//!
//! - [`harness`]: a whole mission in one process, the link bench, the performer's flight,
//!   seeded perturbed trials on a flight rendered once, studies of them with their baselines,
//!   metrics, shards and cluster job files, decoding recorded event streams and the PNG → events
//!   converter.
//! - [`report`]: the session report (`report.md`, its tables and figures; the sensor figure
//!   re-simulates one camera).
//! - [`sweep`]: every case × modality as its own `waggle run`, then the report.
//! - [`cli`]: one small adapter per lab command.
//!
//! The operations (`waggle run`, `compose`, `up`, `router`, `bundle`, the recording's audit and
//! replay) are the `deploy` crate's, which this one builds on and which never links MuJoCo.

#![forbid(unsafe_code)]

pub mod cli;
pub mod harness;
pub mod report;
pub mod sweep;

use std::path::PathBuf;

use anyhow::{Context, Result};

/// The `waggle` binary beside this one (`waggle-lab` is started by it): what a sweep runs each
/// case with and what cluster job files name.
///
/// # Errors
///
/// When this executable cannot be located.
pub fn waggle_binary() -> Result<PathBuf> {
    // Inside a relocatable bundle (deploy/relocatable.sh) this executable is the bare binary in
    // `libexec/`, which needs the wrapper's environment: name the wrapper instead.
    if let Some(root) = std::env::var_os(RELOCATABLE_ENV).filter(|r| !r.is_empty()) {
        return Ok(PathBuf::from(root).join("bin/waggle"));
    }
    let exe = std::env::current_exe().context("locating the waggle-lab binary")?;
    Ok(exe.with_file_name("waggle"))
}

/// Set by a relocatable bundle's wrappers to the bundle's root.
pub const RELOCATABLE_ENV: &str = "WAGGLE_RELOCATABLE";
/// Set by those wrappers to what `LD_LIBRARY_PATH` was before them (for host programs such as
/// `sbatch`, which must not load the bundle's libraries).
pub const HOST_LIBRARY_PATH_ENV: &str = "WAGGLE_HOST_LD_LIBRARY_PATH";

/// A command for a program of the host (not of the bundle): inside a relocatable bundle, with the
/// host's own `LD_LIBRARY_PATH` back.
pub fn host_command(program: impl AsRef<std::ffi::OsStr>) -> std::process::Command {
    let mut cmd = std::process::Command::new(program);
    if std::env::var_os(RELOCATABLE_ENV).is_some() {
        match std::env::var_os(HOST_LIBRARY_PATH_ENV).filter(|p| !p.is_empty()) {
            Some(p) => cmd.env("LD_LIBRARY_PATH", p),
            None => cmd.env_remove("LD_LIBRARY_PATH"),
        };
    }
    cmd
}
