//! A test shim that holds back the publications on chosen keys, so tests can show that the
//! lockstep's results do not depend on when the transport delivers a message (issue 30).
//!
//! `WAGGLE_TEST_DELAY="REST=MS[;REST=MS…]"` in a process's environment (a launcher's children
//! inherit it): every message this process publishes on a key matching the key expression
//! `waggle/<session>/REST` (e.g. `observer/*/tokens`) leaves `MS` milliseconds of wall time later
//! than it was put, from a thread of its own, while the process goes on publishing everything
//! else. Each key keeps its own order (one queue, one delay per rule); across keys the order
//! changes, which is the point. Closing the bus first sends what is still held back.
//!
//! Unset (every real deployment), nothing of this runs.

use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use zenoh::Wait;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;

use crate::error::BusError;

/// The environment variable naming the delayed keys.
pub const DELAY_ENV: &str = "WAGGLE_TEST_DELAY";

/// One rule: publications on keys intersecting `expr` wait `delay`.
#[derive(Debug, Clone)]
struct Rule {
    expr: KeyExpr<'static>,
    delay: Duration,
}

/// Parses `REST=MS[;REST=MS…]` for the session whose key prefix is `prefix`.
fn parse(prefix: &str, text: &str) -> Result<Vec<Rule>, BusError> {
    let bad = |why: String| BusError::Config(format!("{DELAY_ENV}={text:?}: {why}"));
    text.split(';')
        .map(str::trim)
        .filter(|r| !r.is_empty())
        .map(|rule| {
            let (rest, ms) = rule
                .rsplit_once('=')
                .ok_or_else(|| bad(format!("{rule:?} is not KEY=MS")))?;
            let ms: u64 = ms
                .trim()
                .parse()
                .map_err(|_| bad(format!("{ms:?} is not a whole number of ms")))?;
            let expr = KeyExpr::try_from(format!("{prefix}/{}", rest.trim()))
                .map_err(|e| bad(format!("{rest:?} is not a key expression: {e}")))?;
            Ok(Rule {
                expr,
                delay: Duration::from_millis(ms),
            })
        })
        .collect()
}

/// A message held back until `due`.
type Held = (Instant, String, Vec<u8>);

/// The delayed keys of one session and the thread that sends what they hold back.
pub(crate) struct Delayer {
    rules: Vec<Rule>,
    tx: Option<mpsc::Sender<Held>>,
    thread: Option<JoinHandle<()>>,
}

impl Delayer {
    /// The shim [`DELAY_ENV`] asks for, or `None` when it is unset.
    pub(crate) fn from_env(
        prefix: &str,
        session: &zenoh::Session,
    ) -> Result<Option<Self>, BusError> {
        let Ok(text) = std::env::var(DELAY_ENV) else {
            return Ok(None);
        };
        let rules = parse(prefix, &text)?;
        if rules.is_empty() {
            return Ok(None);
        }
        tracing::warn!(shim = %text, "test shim: delaying publications on these keys");
        let (tx, rx) = mpsc::channel::<Held>();
        let session = session.clone();
        let thread = std::thread::spawn(move || {
            for (due, key, bytes) in rx {
                std::thread::sleep(due.saturating_duration_since(Instant::now()));
                let sent = session
                    .put(key.clone(), bytes)
                    .congestion_control(CongestionControl::Block)
                    .wait();
                if let Err(e) = sent {
                    tracing::error!(%key, %e, "test shim: a held-back message could not be sent");
                }
            }
        });
        Ok(Some(Self {
            rules,
            tx: Some(tx),
            thread: Some(thread),
        }))
    }

    /// Holds `bytes` back when `key` is delayed; gives them back otherwise.
    pub(crate) fn hold(&self, key: &str, bytes: Vec<u8>) -> Option<Vec<u8>> {
        let Ok(k) = KeyExpr::try_from(key) else {
            return Some(bytes);
        };
        let Some(rule) = self.rules.iter().find(|r| r.expr.intersects(&k)) else {
            return Some(bytes);
        };
        let tx = self.tx.as_ref()?;
        match tx.send((Instant::now() + rule.delay, key.to_string(), bytes)) {
            Ok(()) => None,
            Err(mpsc::SendError((_, _, bytes))) => Some(bytes),
        }
    }

    /// Sends everything still held back (each at its time), then stops the thread.
    pub(crate) fn flush(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Delayer {
    fn drop(&mut self) {
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_parse_relative_to_the_session_and_bad_ones_are_named() {
        let rules = parse("waggle/s1", "observer/*/tokens=200; sched/session = 40").unwrap();
        assert_eq!(rules.len(), 2);
        assert_eq!(rules[0].expr.as_str(), "waggle/s1/observer/*/tokens");
        assert_eq!(rules[0].delay, Duration::from_millis(200));
        assert_eq!(rules[1].expr.as_str(), "waggle/s1/sched/session");
        assert_eq!(rules[1].delay, Duration::from_millis(40));
        let k = KeyExpr::try_from("waggle/s1/observer/O2/tokens").unwrap();
        assert!(rules[0].expr.intersects(&k));
        assert!(!rules[1].expr.intersects(&k));
        for bad in ["observer/O1/tokens", "x=soon", "a//b=3"] {
            let e = parse("waggle/s1", bad).unwrap_err().to_string();
            assert!(e.contains(DELAY_ENV) && e.contains(bad), "{e}");
        }
    }
}
