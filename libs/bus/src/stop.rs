//! A flag that turns true on SIGINT (Ctrl-C) or SIGTERM, so a process's main loop can finish
//! what it is writing — a recording's last chunk, a summary — instead of dying mid-write.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::Poll;

use tokio::signal::unix::{SignalKind, signal};

/// Starts a watcher thread and returns the flag it sets on the first SIGINT or SIGTERM. If the
/// signal handlers cannot be installed the flag never turns true and the process keeps the
/// default behaviour (terminate on the signal), which loses nothing that was already flushed.
pub fn on_stop_signal() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::spawn(move || {
        let Ok(rt) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        else {
            return;
        };
        rt.block_on(async {
            let (Ok(mut int), Ok(mut term)) = (
                signal(SignalKind::interrupt()),
                signal(SignalKind::terminate()),
            ) else {
                return;
            };
            std::future::poll_fn(|cx| {
                if int.poll_recv(cx).is_ready() || term.poll_recv(cx).is_ready() {
                    Poll::Ready(())
                } else {
                    Poll::Pending
                }
            })
            .await;
            set.store(true, Ordering::SeqCst);
        });
    });
    flag
}
