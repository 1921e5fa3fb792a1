//! What the router hosted in this process refused, counted from its Zenoh session's own
//! reports (Zenoh 1.10.2 offers no callback for a refused link; its log events are the one
//! place it says so). Four events, each at the level Zenoh gives it:
//! - a `quic/` connection whose TLS handshake failed: `QUIC acceptor failed` (warn,
//!   `zenoh_link_commons::quic`; or `Cannot accept QUIC connection`, error, when it fails just
//!   after the handshake);
//! - a link whose Zenoh handshake failed, a missing or wrong password among others: the accept
//!   step's error (debug, `zenoh_transport::unicast::establishment::accept`);
//! - an authenticated link that matched no access rule: `did not match any configured ACL
//!   subject` (info, `zenoh::net::routing::interceptor::access_control`);
//! - a data message (put or delete) of an admitted link, either way, that a rule denies:
//!   `… is unauthorized to Put (ingress) on KEY` (trace, same target).
//!
//! The last needs care: Zenoh writes the same words when it fills its per-key cache of
//! decisions, for every kind of message (queries, replies, liveliness, …) whether or not one
//! is ever sent (a healthy one-observer run wrote 72 such `Put (ingress)` lines and denied
//! nothing). A fill starts with `caching permissions for` and evaluates the kinds in a fixed
//! order ending with `Declare Liveliness Subscriber`, all on the announcing thread; so each
//! thread tracks whether it is inside a fill, and only denials outside one count. Decisions from
//! the cache (`Using cached result: …`) are always messages. A fill on a link that matches no
//! subject logs no decision and so ends only at that thread's next cached decision or fill: a
//! denial in between is missed, so the count is a lower bound.
//!
//! Every message's access-control event, allowed ones too, reaches the counter; it tells their
//! call sites apart once (the deciding words are in the call site's format string) and
//! formats an allowed event only inside a fill.
//!
//! `tests/tests/hostile.rs` provokes each, so a Zenoh upgrade that rewords them fails a test
//! instead of silently counting nothing.

use std::cell::Cell;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{OnceLock, RwLock};

use run_format::run_dir::RouterRefusals;
use tracing::callsite::Identifier;
use tracing::field::{Field, Visit};
use tracing_subscriber::filter::Targets;
use tracing_subscriber::layer::Context;

static CERTIFICATE: AtomicU64 = AtomicU64::new(0);
static HANDSHAKE: AtomicU64 = AtomicU64::new(0);
static NO_ACCESS_RULE: AtomicU64 = AtomicU64::new(0);
static DENIED: AtomicU64 = AtomicU64::new(0);

const QUIC_TARGET: &str = "zenoh_link_commons::quic";
const ACCEPT_TARGET: &str = "zenoh_transport::unicast::establishment::accept";
const ACL_TARGET: &str = "zenoh::net::routing::interceptor::access_control";

/// The events the counter looks at, and no others (the accept step logs at debug and the
/// access control's decisions at trace, which the launcher's log does not show by default).
pub fn targets() -> Targets {
    Targets::new()
        .with_target(QUIC_TARGET, tracing::Level::WARN)
        .with_target(ACCEPT_TARGET, tracing::Level::DEBUG)
        .with_target(ACL_TARGET, tracing::Level::TRACE)
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

/// What an access-control call site reports (its format string decides).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AclSite {
    NoSubject,
    FillStarts,
    CachedAllow,
    CachedDeny,
    Allow,
    Deny,
    Other,
}

fn acl_site(event: &tracing::Event<'_>) -> AclSite {
    static SITES: OnceLock<RwLock<HashMap<Identifier, AclSite>>> = OnceLock::new();
    let sites = SITES.get_or_init(|| RwLock::new(HashMap::new()));
    let id = event.metadata().callsite();
    if let Some(site) = sites.read().unwrap_or_else(|e| e.into_inner()).get(&id) {
        return *site;
    }
    let text = message_of(event);
    let cached = text.starts_with("Using cached result:");
    let site = if text.contains("did not match any configured ACL subject") {
        AclSite::NoSubject
    } else if text.contains("caching permissions for") {
        AclSite::FillStarts
    } else if text.contains(" is unauthorized to ") {
        if cached {
            AclSite::CachedDeny
        } else {
            AclSite::Deny
        }
    } else if text.contains(" is authorized to ") {
        if cached {
            AclSite::CachedAllow
        } else {
            AclSite::Allow
        }
    } else {
        AclSite::Other
    };
    sites
        .write()
        .unwrap_or_else(|e| e.into_inner())
        .insert(id, site);
    site
}

thread_local! {
    /// This thread is filling Zenoh's decision cache for a key.
    static FILLING: Cell<bool> = const { Cell::new(false) };
}

/// A data message's decision (`… to Put (ingress) on …`, `Delete (egress)`).
fn is_data(text: &str) -> bool {
    [" to Put (", " to Delete ("]
        .iter()
        .any(|m| text.contains(m))
}

/// Counts a denied data message outside a fill; ends a fill at its last kind.
fn acl_event(event: &tracing::Event<'_>) {
    let filling = FILLING.with(Cell::get);
    match acl_site(event) {
        AclSite::NoSubject => {
            NO_ACCESS_RULE.fetch_add(1, Ordering::Relaxed);
        }
        AclSite::FillStarts => FILLING.with(|f| f.set(true)),
        AclSite::CachedAllow => FILLING.with(|f| f.set(false)),
        AclSite::CachedDeny => {
            FILLING.with(|f| f.set(false));
            if is_data(&message_of(event)) {
                DENIED.fetch_add(1, Ordering::Relaxed);
            }
        }
        AclSite::Allow | AclSite::Deny if filling => {
            if message_of(event).contains(" to Declare Liveliness Subscriber (") {
                FILLING.with(|f| f.set(false));
            }
        }
        AclSite::Deny => {
            if is_data(&message_of(event)) {
                DENIED.fetch_add(1, Ordering::Relaxed);
            }
        }
        AclSite::Allow | AclSite::Other => {}
    }
}

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Counter {
    fn on_event(&self, event: &tracing::Event<'_>, _: Context<'_, S>) {
        let target = event.metadata().target();
        let counter = if target.starts_with(ACL_TARGET) {
            acl_event(event);
            return;
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
        denied_messages: DENIED.load(Ordering::Relaxed),
    }
}

#[cfg(test)]
mod tests {
    use tracing_subscriber::Layer;
    use tracing_subscriber::layer::SubscriberExt;

    use super::*;

    /// Zenoh's access-control events, as it words them (the target and format strings of
    /// zenoh 1.10.2's `access_control.rs`), one call site each.
    fn fill(key: &str, deny_all: bool) {
        tracing::trace!(target: "zenoh::net::routing::interceptor::access_control",
            "ACL (ingress): caching permissions for `{}` ...", key);
        for kind in [
            "Query (ingress)",
            "Reply (ingress)",
            "Put (ingress)",
            "Delete (ingress)",
            "Declare/Undeclare Subscriber (ingress)",
            "Declare Liveliness Subscriber (ingress)",
        ] {
            decide(kind, key, !deny_all);
        }
    }

    fn decide(kind: &str, key: &str, allow: bool) {
        if allow {
            tracing::trace!(target: "zenoh::net::routing::interceptor::access_control",
                "{} on {} is authorized to {} on {}", "zid", "s1-tcp", kind, key);
        } else {
            tracing::trace!(target: "zenoh::net::routing::interceptor::access_control",
                "{} on {} is unauthorized to {} on {}", "zid", "s1-tcp", kind, key);
        }
    }

    fn cached(kind: &str, key: &str, allow: bool) {
        if allow {
            tracing::trace!(target: "zenoh::net::routing::interceptor::access_control",
                "Using cached result: {} is authorized to {} on {}", "zid", kind, key);
        } else {
            tracing::trace!(target: "zenoh::net::routing::interceptor::access_control",
                "Using cached result: {} is unauthorized to {} on {}", "zid", kind, key);
        }
    }

    #[test]
    fn denied_data_messages_count_and_cache_fills_do_not() {
        let subscriber = tracing_subscriber::registry().with(Counter.with_filter(targets()));
        let before = counted();
        tracing::subscriber::with_default(subscriber, || {
            // Fills deny every kind of a key nobody may touch: no message was sent.
            fill("waggle/s/alive/sim/sim", true);
            fill("waggle/s/clock", true);
            // A denied put outside a fill (Zenoh's uncached path), then two from the cache.
            decide("Put (ingress)", "waggle/s/clock", false);
            cached("Put (ingress)", "waggle/s/clock", false);
            cached("Delete (egress)", "waggle/s/clock", false);
            // Allowed messages and a denied query are not denied data.
            cached("Put (ingress)", "waggle/s/sim/state", true);
            decide("Put (ingress)", "waggle/s/sim/state", true);
            decide("Query (ingress)", "waggle/s/clock", false);
            // A fill interrupted by nothing: its denials stay uncounted.
            fill("waggle/s/fault/O1", true);
            tracing::info!(target: "zenoh::net::routing::interceptor::access_control",
                "{} did not match any configured ACL subject. Default permission `{:?}` will \
                 be applied on all messages", "zid", "Deny");
        });
        let after = counted();
        assert_eq!(after.denied_messages - before.denied_messages, 3);
        assert_eq!(after.no_access_rule - before.no_access_rule, 1);
    }
}
