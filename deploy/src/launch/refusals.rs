//! What the router hosted in this process refused, counted from its Zenoh session's own
//! reports (Zenoh 1.10.2 offers no callback for a refused link; its log events are the one
//! place it says so). Three events, each at the level Zenoh gives it:
//! - a `quic/` connection whose TLS handshake failed: `QUIC acceptor failed` (warn,
//!   `zenoh_link_commons::quic`; or `Cannot accept QUIC connection`, error, when it fails just
//!   after the handshake);
//! - a link whose Zenoh handshake failed, a missing or wrong password among others: the accept
//!   step's error (debug, `zenoh_transport::unicast::establishment::accept`);
//! - an authenticated link that matched no access rule: `did not match any configured ACL
//!   subject` (info, `zenoh::net::routing::interceptor::access_control`).
//!
//! Messages of an admitted link that a rule denies are not counted: Zenoh logs each decision at
//! trace level, but in the same words when it fills its per-key cache — for every kind of
//! message (queries, replies, liveliness, …), sent or not — as when it denies one that was sent
//! (a healthy one-observer run logged 72 such `unauthorized to Put (ingress)` lines and denied
//! nothing), so the log cannot count them. The access-control target is read at info level
//! only.
//!
//! `tests/tests/hostile.rs` provokes each, so a Zenoh upgrade that rewords them fails a test
//! instead of silently counting nothing.

use std::sync::atomic::{AtomicU64, Ordering};

use run_format::run_dir::RouterRefusals;
use tracing::field::{Field, Visit};
use tracing_subscriber::filter::Targets;
use tracing_subscriber::layer::Context;

static CERTIFICATE: AtomicU64 = AtomicU64::new(0);
static HANDSHAKE: AtomicU64 = AtomicU64::new(0);
static NO_ACCESS_RULE: AtomicU64 = AtomicU64::new(0);

const QUIC_TARGET: &str = "zenoh_link_commons::quic";
const ACCEPT_TARGET: &str = "zenoh_transport::unicast::establishment::accept";
const ACL_TARGET: &str = "zenoh::net::routing::interceptor::access_control";

/// The events the counter looks at, and no others (the accept step logs at debug, which the
/// launcher's log does not show by default).
pub fn targets() -> Targets {
    Targets::new()
        .with_target(QUIC_TARGET, tracing::Level::WARN)
        .with_target(ACCEPT_TARGET, tracing::Level::DEBUG)
        .with_target(ACL_TARGET, tracing::Level::INFO)
}

/// The counting layer.
pub struct Counter;

/// An event's message.
#[derive(Default)]
struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

fn message_of(event: &tracing::Event<'_>) -> String {
    let mut message = Message::default();
    event.record(&mut message);
    message.0
}

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Counter {
    fn on_event(&self, event: &tracing::Event<'_>, _: Context<'_, S>) {
        let target = event.metadata().target();
        let counter = if target.starts_with(ACL_TARGET) {
            if !message_of(event).contains("did not match any configured ACL subject") {
                return;
            }
            &NO_ACCESS_RULE
        } else if target.starts_with(QUIC_TARGET) {
            let text = message_of(event);
            if !(text.contains("QUIC acceptor failed")
                || text.contains("Cannot accept QUIC connection"))
            {
                return;
            }
            &CERTIFICATE
        } else if target.starts_with(ACCEPT_TARGET)
            && *event.metadata().level() == tracing::Level::DEBUG
            && !message_of(event).contains("New transport link accepted")
        {
            // One debug event per failed accept step (an error event may precede it: not
            // counted twice).
            &HANDSHAKE
        } else {
            return;
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }
}

/// What this process's router has refused so far.
pub fn counted() -> RouterRefusals {
    RouterRefusals {
        certificate: CERTIFICATE.load(Ordering::Relaxed),
        handshake: HANDSHAKE.load(Ordering::Relaxed),
        no_access_rule: NO_ACCESS_RULE.load(Ordering::Relaxed),
    }
}
