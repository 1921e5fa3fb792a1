//! A flag that turns true on SIGINT (Ctrl-C) or SIGTERM, so a process's main loop can finish
//! what it is writing — a recording's last chunk, a summary — instead of dying mid-write.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use signal_hook::consts::{SIGINT, SIGTERM};

/// Returns the flag that the first SIGINT or SIGTERM sets (`signal_hook::flag`: the handler
/// only stores `true`, so it is async-signal-safe). Once installed, the handlers replace the
/// default action for the rest of the process. If a handler cannot be installed, that signal
/// keeps its default behaviour (terminate), which loses nothing that was already flushed.
pub fn on_stop_signal() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        if let Err(e) = signal_hook::flag::register(signal, Arc::clone(&flag)) {
            tracing::warn!(signal, error = %e, "cannot install the stop-signal handler");
        }
    }
    flag
}
