//! The launcher's own log, `logs/launcher.log` in its run directory: the warnings and errors of
//! its Zenoh session — the session's router, on the router's host — which would otherwise go
//! nowhere (the terminal shows the progress bar and the summary). A router that closes an
//! unresponsive host's transport, for instance, says so here. `RUST_LOG` sets the level
//! (default `warn`), as for the nodes.

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::{Mutex, Once};

use anyhow::{Context, Result};
use tracing_subscriber::EnvFilter;
use tracing_subscriber::Layer;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

/// Where the launcher's log goes: nowhere until a run directory is known.
static TARGET: Mutex<Option<Target>> = Mutex::new(None);
static INSTALL: Once = Once::new();

enum Target {
    File(File),
    Stderr,
}

/// Writes each formatted event to the current target.
struct OwnLog;

impl Write for OwnLog {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut target = TARGET.lock().unwrap_or_else(|e| e.into_inner());
        match target.as_mut() {
            Some(Target::File(f)) => f.write(buf),
            Some(Target::Stderr) => std::io::stderr().write(buf),
            None => Ok(buf.len()),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let mut target = TARGET.lock().unwrap_or_else(|e| e.into_inner());
        match target.as_mut() {
            Some(Target::File(f)) => f.flush(),
            Some(Target::Stderr) => std::io::stderr().flush(),
            None => Ok(()),
        }
    }
}

fn install() {
    INSTALL.call_once(|| {
        let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"));
        let log = tracing_subscriber::fmt::layer()
            .with_ansi(false)
            .with_writer(|| OwnLog)
            .with_filter(filter);
        let refusals = super::refusals::Counter.with_filter(super::refusals::targets());
        // Another global subscriber (a test harness's) wins; the log then goes there.
        let _ = tracing_subscriber::registry()
            .with(log)
            .with(refusals)
            .try_init();
    });
}

fn direct(target: Target) {
    install();
    *TARGET.lock().unwrap_or_else(|e| e.into_inner()) = Some(target);
}

/// From now on the launcher's log is appended to `path`.
pub fn to_file(path: &Path) -> Result<()> {
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("opening the launcher's log {}", path.display()))?;
    direct(Target::File(file));
    Ok(())
}

/// From now on the launcher's log goes to stderr (a router on its own has no run directory).
pub fn to_stderr() {
    direct(Target::Stderr);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_reach_the_file_once_it_is_set() {
        let dir = std::env::temp_dir().join(format!("waggle-own-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("launcher.log");
        tracing::warn!("before any target: dropped");
        to_file(&path).unwrap();
        tracing::warn!(host = "b", "transport closed");
        tracing::debug!("below the default level");
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains("transport closed") && text.contains("host=\"b\""),
            "{text}"
        );
        assert!(
            !text.contains("dropped") && !text.contains("below"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
