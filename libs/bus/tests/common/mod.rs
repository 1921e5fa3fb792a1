//! What the bus's own integration tests share.

use std::time::Duration;

use bus::Bus;
use proto::{Keys, Role};

/// A loopback endpoint of `protocol` (`tcp` or `quic`) on a port free now: QUIC listens on UDP.
pub fn free_endpoint(protocol: &str) -> String {
    let port = if protocol == "quic" {
        std::net::UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr())
    } else {
        std::net::TcpListener::bind("127.0.0.1:0").and_then(|s| s.local_addr())
    }
    .unwrap()
    .port();
    format!("{protocol}/127.0.0.1:{port}")
}

/// Makes `publisher` know `subscriber`'s subscriptions before it publishes: the subscriber
/// declares O1's liveliness token after them (on the same link, so it arrives after them) and
/// the publisher waits until it sees it — the start-up handshake of `bus::handshake` in small.
/// Returns the token's key.
pub fn await_subscriber(publisher: &mut Bus, subscriber: &mut Bus, keys: &Keys) -> String {
    subscriber.watch_liveliness(&keys.alive_any()).unwrap();
    publisher.watch_liveliness(&keys.alive_any()).unwrap();
    let token = keys.alive(Role::Observer, "O1").unwrap();
    subscriber.declare_token(&token).unwrap();
    publisher
        .wait_for("the subscriber's token", Duration::from_secs(20), |k| {
            k.contains(&token)
        })
        .unwrap();
    token
}
