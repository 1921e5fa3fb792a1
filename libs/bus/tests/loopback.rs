//! Real Zenoh sessions on loopback: typed messages, liveliness and the start-up handshake.

use std::thread;
use std::time::{Duration, Instant};

use bus::{Bus, Endpoints, Inbound, handshake};
use proto::{ClockTick, Keys, Role};

mod common;

fn listening(session: &str, endpoint: &str) -> Bus {
    Bus::open(
        session,
        &Endpoints {
            connect: vec![],
            listen: vec![endpoint.to_string()],
        },
    )
    .unwrap()
}

fn connecting(session: &str, endpoint: &str) -> Bus {
    Bus::open(
        session,
        &Endpoints {
            connect: vec![endpoint.to_string()],
            listen: vec![],
        },
    )
    .unwrap()
}

fn next_data(bus: &mut Bus, deadline: Instant) -> Option<(String, Vec<u8>)> {
    while Instant::now() < deadline {
        if let Some(Inbound::Data { key, payload }) = bus.recv(Duration::from_millis(50)) {
            return Some((key, payload));
        }
    }
    None
}

#[test]
fn typed_messages_arrive_in_order_and_a_closed_peer_disappears() {
    let session = format!("loop-{}", std::process::id());
    let endpoint = common::free_endpoint("tcp");
    let mut a = listening(&session, &endpoint);
    let mut b = connecting(&session, &endpoint);
    let keys = Keys::new(&session).unwrap();
    b.subscribe(&keys.clock()).unwrap();
    b.subscribe(&keys.sched_session()).unwrap();
    // Seeing B's token, A knows B's subscriptions (declared before it on the same link).
    let b_alive = common::await_subscriber(&mut a, &mut b, &keys);
    for tick in 0..200 {
        a.put(&keys.clock(), &ClockTick::at(tick).unwrap()).unwrap();
        if tick % 50 == 0 {
            a.put(
                &keys.sched_session(),
                &proto::SessionTick {
                    tick,
                    controls: vec![],
                },
            )
            .unwrap();
        }
    }
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut clocks = Vec::new();
    let mut sessions = Vec::new();
    while clocks.len() < 200 {
        let (key, payload) = next_data(&mut b, deadline).expect("every message arrives");
        if key == keys.clock() {
            let c: ClockTick = bus::decode(&key, &payload).unwrap();
            clocks.push(c.tick);
        } else {
            let s: proto::SessionTick = bus::decode(&key, &payload).unwrap();
            // Same publisher, same priority: cross-key order is kept.
            assert_eq!(s.tick, clocks.last().copied().unwrap_or(0));
            sessions.push(s.tick);
        }
    }
    assert_eq!(clocks, (0..200).collect::<Vec<_>>());
    assert_eq!(sessions, [0, 50, 100, 150]);
    // A malformed payload is a typed error.
    assert!(matches!(
        bus::decode::<ClockTick>(&keys.clock(), &[1, 0, 9]),
        Err(bus::BusError::Decode { .. })
    ));
    // B goes away: A learns it from the token, not from a timeout of its own.
    b.close().unwrap();
    a.wait_for("B's token to go", Duration::from_secs(20), |k| {
        !k.contains(&b_alive)
    })
    .unwrap();
    assert!(!a.is_alive(&b_alive));
}

#[test]
fn after_the_handshake_nothing_published_by_the_starter_is_lost() {
    // Five processes of a one-observer session (no launcher), each its own session in a thread;
    // the simulator publishes the moment everyone is ready, and everyone must get it.
    let session = format!("hs-{}", std::process::id());
    let endpoint = common::free_endpoint("tcp");
    let everyone = handshake::mission_processes(1, false);
    let keys = Keys::new(&session).unwrap();
    let mut hub = listening(&session, &endpoint);
    let sim = everyone[0].clone();
    assert_eq!(sim.role, Role::Sim);
    let mut handles = Vec::new();
    for me in everyone.clone().into_iter().skip(1) {
        let (session, endpoint, everyone, keys) = (
            session.clone(),
            endpoint.clone(),
            everyone.clone(),
            keys.clone(),
        );
        handles.push(thread::spawn(move || {
            let mut bus = connecting(&session, &endpoint);
            bus.subscribe(&keys.clock()).unwrap();
            handshake::join(&mut bus, &me, &everyone, Duration::from_secs(60)).unwrap();
            let deadline = Instant::now() + Duration::from_secs(30);
            let (key, payload) =
                next_data(&mut bus, deadline).unwrap_or_else(|| panic!("{me} never got tick 0"));
            let c: ClockTick = bus::decode(&key, &payload).unwrap();
            assert_eq!(c.tick, 0, "{me}");
            // Stay until the starter has seen everyone leave (no early token loss).
            thread::sleep(Duration::from_millis(200));
        }));
    }
    handshake::join(&mut hub, &sim, &everyone, Duration::from_secs(60)).unwrap();
    handshake::wait_ready(&mut hub, &everyone, Duration::from_secs(60)).unwrap();
    hub.put(&keys.clock(), &ClockTick::at(0).unwrap()).unwrap();
    for h in handles {
        h.join().unwrap();
    }
}

#[test]
fn the_handshake_times_out_naming_who_is_missing() {
    let session = format!("hs-missing-{}", std::process::id());
    let mut bus = listening(&session, &common::free_endpoint("tcp"));
    let everyone = handshake::mission_processes(1, false);
    let err = handshake::join(
        &mut bus,
        &everyone[0],
        &everyone,
        Duration::from_millis(300),
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(text.contains("timed out"), "{text}");
    let missing = text
        .split("missing: ")
        .nth(1)
        .expect("a list of the missing");
    assert!(missing.contains("alive/camera/O1"), "{text}");
    assert!(missing.contains("alive/scheduler/scheduler"), "{text}");
    // Its own token is there.
    assert!(!missing.contains("alive/sim/sim"), "{text}");
}
