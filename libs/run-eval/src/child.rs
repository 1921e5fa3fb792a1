//! Child processes as the launcher and a sweep report them: the label of how one ended, and a
//! signal sent to one this process spawned.

use std::process::{Child, ExitStatus};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

/// `exit N` or `signal N`.
pub fn exit_label(status: ExitStatus) -> String {
    match status.code() {
        Some(c) => format!("exit {c}"),
        None => {
            use std::os::unix::process::ExitStatusExt;
            format!("signal {}", status.signal().unwrap_or(0))
        }
    }
}

/// Sends `signal` to a child we spawned; false if it could not be sent.
pub fn signal(child: &Child, signal: Signal) -> bool {
    let Ok(pid) = i32::try_from(child.id()) else {
        return false;
    };
    kill(Pid::from_raw(pid), signal).is_ok()
}
