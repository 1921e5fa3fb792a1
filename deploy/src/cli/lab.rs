//! The lab commands (`waggle mission`, `trials`, `study`, `link`, `decode`…) fly the simulator,
//! which `waggle` does not link: they are the `lab` crate's, served by the `waggle-lab` binary
//! built beside `waggle`. Once `waggle` has parsed a lab command line (with the one definition
//! both binaries share), it runs `waggle-lab` with the same arguments, untouched; on Unix it
//! replaces this process (`exec`), so standard streams, signals and the exit code are the lab
//! command's own.

use std::ffi::OsString;
use std::path::PathBuf;

use anyhow::{Context, Result};

/// The binary serving the lab commands, beside `waggle`.
pub const LAB_BINARY: &str = "waggle-lab";

/// The `waggle-lab` binary beside the running `waggle`.
///
/// # Errors
///
/// When it is missing, naming the file and how to build it.
pub fn lab_binary(command: &str) -> Result<PathBuf> {
    let exe = std::env::current_exe().context("locating the waggle binary")?;
    let lab = exe.with_file_name(LAB_BINARY);
    anyhow::ensure!(
        lab.is_file(),
        "`waggle {command}` runs in {LAB_BINARY}, and {} is missing: build it beside waggle \
         (cargo build --release --workspace --bins, or -p lab)",
        lab.display()
    );
    Ok(lab)
}

/// Runs `waggle-lab` with `args` (the command line after `waggle`). On Unix this process
/// becomes it and this returns only if that failed; elsewhere it waits and exits with its code.
pub fn run(args: &[OsString]) -> Result<()> {
    let command = args.first().and_then(|a| a.to_str()).unwrap_or(LAB_BINARY);
    let lab = lab_binary(command)?;
    let mut cmd = std::process::Command::new(&lab);
    cmd.args(args);
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        let e = cmd.exec();
        Err(e).with_context(|| format!("running {}", lab.display()))
    }
    #[cfg(not(unix))]
    {
        let status = cmd
            .status()
            .with_context(|| format!("running {}", lab.display()))?;
        std::process::exit(status.code().unwrap_or(1));
    }
}
