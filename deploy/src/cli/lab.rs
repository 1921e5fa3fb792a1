//! The lab commands (`waggle mission`, `trials`, `study`, `link`, `decode`…) fly the simulator,
//! which `waggle` does not link: they are the `lab` crate's, served by the `waggle-lab` binary
//! built beside `waggle`. `waggle LABCMD ARGS…` runs `waggle-lab LABCMD ARGS…` with the same
//! arguments, untouched; on Unix it replaces this process (`exec`), so standard streams, signals
//! and the exit code are the lab command's own. `waggle help LABCMD` is forwarded the same way.

use std::ffi::OsString;
use std::path::PathBuf;

use anyhow::{Context, Result};

/// The binary serving the lab commands, beside `waggle`.
pub const LAB_BINARY: &str = "waggle-lab";

/// Every command `waggle-lab` serves (each also listed, with its description, by
/// `waggle --help`).
pub const LAB_COMMANDS: [&str; 9] = [
    "link",
    "mission",
    "decode",
    "events",
    "sweep",
    "viewpoints",
    "trials",
    "study",
    "report",
];

/// A lab command's arguments as `waggle` sees them: everything after the command's name, passed
/// on unparsed (`waggle-lab` parses them).
#[derive(Debug, Clone, clap::Args)]
#[command(disable_help_flag = true)]
pub struct LabArgs {
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, hide = true)]
    pub args: Vec<OsString>,
}

/// The lab command that `args` (the command line after `waggle`) runs: `LABCMD …`, or
/// `help LABCMD …`.
pub fn lab_command(args: &[OsString]) -> Option<&'static str> {
    let named = |a: Option<&OsString>| {
        a.and_then(|a| a.to_str())
            .and_then(|a| LAB_COMMANDS.iter().copied().find(|c| *c == a))
    };
    match args.first().and_then(|a| a.to_str()) {
        Some("help") => named(args.get(1)),
        _ => named(args.first()),
    }
}

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
    let lab = lab_binary(lab_command(args).unwrap_or(LAB_BINARY))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &[&str]) -> Vec<OsString> {
        s.iter().map(OsString::from).collect()
    }

    #[test]
    fn only_lab_commands_are_forwarded() {
        assert_eq!(lab_command(&args(&["trials", "--help"])), Some("trials"));
        assert_eq!(lab_command(&args(&["help", "study"])), Some("study"));
        assert_eq!(lab_command(&args(&["mission"])), Some("mission"));
        assert_eq!(lab_command(&args(&["run", "mission"])), None);
        assert_eq!(lab_command(&args(&["help", "run"])), None);
        assert_eq!(lab_command(&args(&["help"])), None);
        assert_eq!(lab_command(&args(&["--help"])), None);
        assert_eq!(lab_command(&[]), None);
    }
}
