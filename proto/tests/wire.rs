//! Wire-level tests of every message type: round trips, strict rejection and decode fuzzing.

use proptest::prelude::*;
use proto::clock::ClockTick;
use proto::frame::{ReleasedFrame, frame_tokens};
use proto::*;
use serde::{Serialize, de::DeserializeOwned};

fn oid(s: &str) -> ObserverId {
    ObserverId::new(s).unwrap()
}

fn event_packet() -> EventPacket {
    EventPacket {
        seq: 7,
        start_ns: 280_000_000,
        end_ns: 320_000_000,
        width: 640,
        height: 480,
        valid: true,
        continuous: true,
        xs: vec![0, 639, 320],
        ys: vec![479, 0, 240],
        dt_ns: vec![0, 40_000_000, 12_345],
        on_bits: EventPacket::pack_polarities([Polarity::On, Polarity::Off, Polarity::On]),
    }
}

fn rgb_frame() -> RgbFrame {
    RgbFrame {
        seq: 1,
        stamp_ns: 40_000_000,
        width: 4,
        height: 2,
        valid: true,
        continuous: false,
        rgb: (0..24).collect(),
    }
}

fn sim_state() -> SimState {
    SimState {
        tick: 2,
        stamp_ns: 70_000_000,
        drones: vec![
            DronePose {
                name: "performer".into(),
                pos_m: [0.0, 0.0, 1.3],
                quat_wxyz: [1.0, 0.0, 0.0, 0.0],
                vel_mps: [0.1, 0.0, 0.0],
                ang_vel_radps: [0.0; 3],
            },
            DronePose {
                name: "O1".into(),
                pos_m: [-0.8, -1.0, 1.3],
                quat_wxyz: [0.0, 0.0, 0.0, 1.0],
                vel_mps: [0.0; 3],
                ang_vel_radps: [0.0, 0.0, 0.5],
            },
        ],
    }
}

fn decision() -> Decision {
    let roster = Roster::default_scene(3);
    let mut cache = OfferCache::new(1);
    cache.insert(CachedOffer {
        offer: "011010".parse().unwrap(),
        frame_seq: 0,
        final_null_ns: 10,
    });
    cache.insert(CachedOffer {
        offer: "100111".parse().unwrap(),
        frame_seq: 1,
        final_null_ns: 20,
    });
    decide(&oid("O2"), &cache, &roster, 30).unwrap()
}

fn broadcast() -> Broadcast {
    Broadcast {
        tick: 125,
        round: 2,
        start_ns: 5_000_000_000,
        offers: vec!["010000".parse().unwrap(), "100111".parse().unwrap()],
        acquisition: true,
    }
}

fn mission_report() -> MissionReport {
    MissionReport {
        tick: 12_345,
        end_ns: 493_800_000_000,
        end_reason: proto::EndReason::RoundsComplete,
        work_units: 2,
        services: [(oid("O1"), vec![(1, Site::A), (2, Site::B)])]
            .into_iter()
            .collect(),
        departures: vec![Departure {
            observer: oid("O1"),
            round: 1,
            site: Site::A,
            t_ns: 200_000_000_000,
        }],
        rejected_decisions: 0,
    }
}

fn frame_event() -> FrameEvent {
    FrameEvent {
        observer: oid("O1"),
        seq: 0,
        round: 1,
        frame: ReleasedFrame {
            payload: 0b011010,
            token_stamps_ns: (0..17).map(|i| i * 1000).collect(),
        },
    }
}

fn sim_contacts() -> SimContacts {
    SimContacts {
        tick: 1,
        contacts: vec![Contact {
            step_ns: 2_000_000,
            body_a: "O1".into(),
            body_b: "floor".into(),
            depth_m: 0.001,
        }],
        contact_steps: 1,
        min_separation_m: 0.35,
    }
}

fn observer_status_receiving() -> ObserverStatus {
    ObserverStatus {
        observer: oid("O1"),
        tick: 5,
        round: 1,
        phase: ObserverPhase::Receiving,
        input: InputState::Missing,
        parser_progress: 16,
        tokens: 40,
        frames: 2,
        assignment: None,
        decision: None,
    }
}

fn observer_status_decided() -> ObserverStatus {
    ObserverStatus {
        observer: oid("O2"),
        tick: 6,
        round: 1,
        phase: ObserverPhase::Decided,
        input: InputState::Received,
        parser_progress: 0,
        tokens: 41,
        frames: 2,
        assignment: Some(Site::A),
        decision: Some(decision()),
    }
}

fn session_tick() -> SessionTick {
    SessionTick {
        tick: 3,
        controls: vec![
            SessionControl {
                tick: 3,
                stamp_ns: 120_000_000,
                event: SessionEvent::RoundReset { round: 1 },
            },
            SessionControl {
                tick: 3,
                stamp_ns: 120_000_000,
                event: SessionEvent::WindowOpen { round: 1 },
            },
        ],
    }
}

/// One valid instance of every message type, encoded.
fn all_encoded() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("EventPacket", encode(&event_packet())),
        ("RgbFrame", encode(&rgb_frame())),
        ("ClockTick", encode(&ClockTick::at(9).unwrap())),
        ("SimState", encode(&sim_state())),
        ("SimContacts", encode(&sim_contacts())),
        (
            "PerformerSetpoint",
            encode(&PerformerSetpoint {
                tick: 3,
                kin: Kinematics {
                    pos_m: [0.0, 0.0, 1.4],
                    vel_mps: [0.0; 3],
                    acc_mps2: [0.5, 0.0, -0.25],
                },
                yaw_rad: 1.0,
            }),
        ),
        (
            "PerformerTruth",
            encode(&PerformerTruth {
                tick: 1,
                stamp_ns: 40_000_000,
                round: 1,
                activity: PerformerActivity::Action(Action::Bit1),
                offer: Some("011010".parse().unwrap()),
                frame_slot: Some(5),
            }),
        ),
        (
            "TokenEvent",
            encode(&TokenEvent {
                observer: oid("O3"),
                seq: 4,
                token: Token::End,
                confirmed_ns: 99,
            }),
        ),
        ("FrameEvent", encode(&frame_event())),
        ("Decision", encode(&decision())),
        ("ObserverStatus", encode(&observer_status_receiving())),
        ("ObserverStatus", encode(&observer_status_decided())),
        (
            "SchedCommand",
            encode(&SchedCommand {
                tick: 5,
                setpoints: vec![ObserverSetpoint {
                    observer: oid("O1"),
                    kin: Kinematics {
                        pos_m: [1.0, 2.0, 1.3],
                        vel_mps: [0.0; 3],
                        acc_mps2: [0.0, 0.1, 0.0],
                    },
                    yaw_rad: 0.0,
                }],
                mission_end: false,
            }),
        ),
        ("Broadcast", encode(&broadcast())),
        (
            "BroadcastTick",
            encode(&BroadcastTick {
                tick: 125,
                broadcast: Some(broadcast()),
            }),
        ),
        ("SessionTick", encode(&session_tick())),
        ("MissionReport", encode(&mission_report())),
        (
            "SessionControl",
            encode(&SessionControl {
                tick: 3,
                stamp_ns: 120_000_000,
                event: SessionEvent::WindowOpen { round: 1 },
            }),
        ),
        (
            "Fault",
            encode(&Fault {
                observer: oid("O2"),
                kind: FaultKind::BlackInput,
                from_ns: 0,
                until_ns: None,
            }),
        ),
    ]
}

/// Decodes `bytes` as the message type `name`, re-encoding on success; never panics.
fn decode_as(name: &str, bytes: &[u8]) -> Result<Vec<u8>, DecodeError> {
    fn go<T: Serialize + DeserializeOwned + Validate>(
        bytes: &[u8],
    ) -> Result<Vec<u8>, DecodeError> {
        decode::<T>(bytes).map(|m| encode(&m))
    }
    match name {
        "EventPacket" => go::<EventPacket>(bytes),
        "RgbFrame" => go::<RgbFrame>(bytes),
        "ClockTick" => go::<ClockTick>(bytes),
        "SimState" => go::<SimState>(bytes),
        "SimContacts" => go::<SimContacts>(bytes),
        "PerformerSetpoint" => go::<PerformerSetpoint>(bytes),
        "PerformerTruth" => go::<PerformerTruth>(bytes),
        "TokenEvent" => go::<TokenEvent>(bytes),
        "FrameEvent" => go::<FrameEvent>(bytes),
        "Decision" => go::<Decision>(bytes),
        "ObserverStatus" => go::<ObserverStatus>(bytes),
        "SchedCommand" => go::<SchedCommand>(bytes),
        "Broadcast" => go::<Broadcast>(bytes),
        "SessionControl" => go::<SessionControl>(bytes),
        "Fault" => go::<Fault>(bytes),
        "BroadcastTick" => go::<BroadcastTick>(bytes),
        "SessionTick" => go::<SessionTick>(bytes),
        "MissionReport" => go::<MissionReport>(bytes),
        other => panic!("test table names unknown type {other}"),
    }
}

const TYPE_COUNT: usize = 19;

#[test]
fn every_message_type_round_trips_byte_identically() {
    let all = all_encoded();
    assert_eq!(all.len(), TYPE_COUNT);
    for (name, bytes) in &all {
        assert_eq!(&bytes[..2], &FORMAT_VERSION.to_le_bytes(), "{name}");
        let again = decode_as(name, bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&again, bytes, "{name}");
    }
}

#[test]
fn every_message_type_rejects_trailing_bytes_unknown_versions_and_truncation() {
    for (name, bytes) in all_encoded() {
        let mut trailing = bytes.clone();
        trailing.push(0);
        assert!(
            matches!(decode_as(name, &trailing), Err(DecodeError::Malformed(_))),
            "{name}"
        );
        let mut future = bytes.clone();
        future[..2].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
        assert_eq!(
            decode_as(name, &future),
            Err(DecodeError::UnknownVersion {
                found: FORMAT_VERSION + 1
            }),
            "{name}"
        );
        assert_eq!(
            decode_as(name, &bytes[..1]),
            Err(DecodeError::MissingVersion { len: 1 }),
            "{name}"
        );
        for cut in 2..bytes.len() {
            assert!(
                decode_as(name, &bytes[..cut]).is_err(),
                "{name} truncated to {cut} bytes decoded"
            );
        }
    }
}

#[test]
fn inconsistent_event_packets_are_rejected() {
    let check = |p: EventPacket| decode::<EventPacket>(&encode(&p));
    assert_eq!(check(event_packet()), Ok(event_packet()));
    let mut short_ys = event_packet();
    short_ys.ys.pop();
    assert!(
        matches!(check(short_ys), Err(DecodeError::Inconsistent(m)) if m.contains("lengths differ"))
    );
    let mut short_dt = event_packet();
    short_dt.dt_ns.push(0);
    assert!(matches!(check(short_dt), Err(DecodeError::Inconsistent(_))));
    let mut x_out = event_packet();
    x_out.xs[1] = 640;
    assert!(matches!(check(x_out), Err(DecodeError::Inconsistent(m)) if m.contains("outside")));
    let mut y_out = event_packet();
    y_out.ys[0] = 480;
    assert!(matches!(check(y_out), Err(DecodeError::Inconsistent(_))));
    let mut late = event_packet();
    late.dt_ns[2] = 40_000_001;
    assert!(matches!(check(late), Err(DecodeError::Inconsistent(_))));
    let mut bits = event_packet();
    bits.on_bits.push(0);
    assert!(matches!(check(bits), Err(DecodeError::Inconsistent(_))));
    let mut backwards = event_packet();
    backwards.end_ns = backwards.start_ns - 1;
    assert!(matches!(
        check(backwards),
        Err(DecodeError::Inconsistent(_))
    ));
    let empty = EventPacket {
        xs: vec![],
        ys: vec![],
        dt_ns: vec![],
        on_bits: vec![],
        ..event_packet()
    };
    assert_eq!(
        check(empty.clone()),
        Ok(empty),
        "an empty packet is a valid packet"
    );
}

#[test]
fn inconsistent_sensor_world_and_frame_messages_are_rejected() {
    let mut rgb = rgb_frame();
    rgb.rgb.pop();
    assert!(matches!(
        decode::<RgbFrame>(&encode(&rgb)),
        Err(DecodeError::Inconsistent(_))
    ));
    let tick = ClockTick {
        tick: 2,
        sim_time_ns: 1,
    };
    assert!(matches!(
        decode::<ClockTick>(&encode(&tick)),
        Err(DecodeError::Inconsistent(_))
    ));
    let mut state = sim_state();
    state.drones[1].name = "performer".into();
    assert!(matches!(
        decode::<SimState>(&encode(&state)),
        Err(DecodeError::Inconsistent(_))
    ));
    let mut state = sim_state();
    state.drones[0].pos_m[2] = f64::NAN;
    assert!(matches!(
        decode::<SimState>(&encode(&state)),
        Err(DecodeError::Inconsistent(_))
    ));
    let state = SimState {
        stamp_ns: 200_000_000,
        ..sim_state()
    };
    assert!(matches!(
        decode::<SimState>(&encode(&state)),
        Err(DecodeError::Inconsistent(_))
    ));
    let mut frame = frame_event();
    frame.frame.token_stamps_ns.pop();
    assert!(matches!(
        decode::<FrameEvent>(&encode(&frame)),
        Err(DecodeError::Inconsistent(_))
    ));
}

#[test]
fn inconsistent_scheduler_fault_and_observer_messages_are_rejected() {
    let bad_offer = Broadcast {
        tick: 0,
        round: 1,
        start_ns: 0,
        offers: vec![Offer {
            site: Site::A,
            quality: 4,
            capacity: 1,
        }],
        acquisition: false,
    };
    assert!(matches!(
        decode::<Broadcast>(&encode(&bad_offer)),
        Err(DecodeError::Inconsistent(_))
    ));
    let late_start = Broadcast {
        start_ns: 5_040_000_000,
        ..broadcast()
    };
    assert!(matches!(
        decode::<Broadcast>(&encode(&late_start)),
        Err(DecodeError::Inconsistent(m)) if m.contains("outside tick")
    ));
    let wrong_tick = BroadcastTick {
        tick: 124,
        broadcast: Some(broadcast()),
    };
    assert!(matches!(
        decode::<BroadcastTick>(&encode(&wrong_tick)),
        Err(DecodeError::Inconsistent(_))
    ));
    let stray = SessionTick {
        tick: 4,
        controls: vec![SessionControl {
            tick: 3,
            stamp_ns: 120_000_000,
            event: SessionEvent::MissionEnd,
        }],
    };
    assert!(matches!(
        decode::<SessionTick>(&encode(&stray)),
        Err(DecodeError::Inconsistent(_))
    ));
    let mut report = mission_report();
    report.work_units = 3;
    assert!(matches!(
        decode::<MissionReport>(&encode(&report)),
        Err(DecodeError::Inconsistent(m)) if m.contains("work units")
    ));
    let report = MissionReport {
        end_ns: 1,
        ..mission_report()
    };
    assert!(matches!(
        decode::<MissionReport>(&encode(&report)),
        Err(DecodeError::Inconsistent(_))
    ));
    let mut contacts = SimContacts {
        tick: 1,
        contacts: vec![],
        contact_steps: 0,
        min_separation_m: f64::NAN,
    };
    assert!(matches!(
        decode::<SimContacts>(&encode(&contacts)),
        Err(DecodeError::Inconsistent(_))
    ));
    contacts.min_separation_m = 0.4;
    assert!(decode::<SimContacts>(&encode(&contacts)).is_ok());
    let throttle = Fault {
        observer: oid("O1"),
        kind: FaultKind::Throttle {
            drop_per_mille: 1001,
            delay_ms: 0,
        },
        from_ns: 0,
        until_ns: None,
    };
    assert!(matches!(
        decode::<Fault>(&encode(&throttle)),
        Err(DecodeError::Inconsistent(_))
    ));
    let foreign = ObserverStatus {
        observer: oid("O1"),
        ..observer_status_decided()
    };
    assert!(matches!(
        decode::<ObserverStatus>(&encode(&foreign)),
        Err(DecodeError::Inconsistent(m)) if m.contains("decision of O2")
    ));
    let mut d = decision();
    d.assignment = Some(Site::B); // O2's own allocation entry says A.
    assert!(matches!(
        decode::<Decision>(&encode(&d)),
        Err(DecodeError::Inconsistent(_))
    ));
}

#[test]
fn an_invalid_observer_id_is_rejected_when_decoding() {
    // Encode the same shape with a raw string in place of the validated id.
    #[derive(Serialize)]
    struct RawToken {
        observer: String,
        seq: u64,
        token: Token,
        confirmed_ns: u64,
    }
    let raw = RawToken {
        observer: "O1/../x".into(),
        seq: 0,
        token: Token::Null,
        confirmed_ns: 0,
    };
    assert!(matches!(
        decode::<TokenEvent>(&encode(&raw)),
        Err(DecodeError::Malformed(_))
    ));
    let raw = RawToken {
        observer: "O1".into(),
        ..raw
    };
    assert_eq!(
        decode::<TokenEvent>(&encode(&raw)).unwrap().observer,
        oid("O1")
    );
}

#[test]
fn a_hostile_length_prefix_is_rejected_without_allocating() {
    let mut bytes = encode(&rgb_frame());
    // The rgb Vec's u64 length prefix follows seq, stamp_ns (8 + 8), width, height (2 + 2) and
    // two bools: offset 2 + 22.
    bytes[24..32].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        decode::<RgbFrame>(&bytes),
        Err(DecodeError::Malformed(_))
    ));
}

#[test]
fn frame_tokens_encode_their_payload() {
    let f = frame_tokens(0b100111);
    assert_eq!(f[3], Token::Bit1);
    assert_eq!(f[5], Token::Bit0);
    assert_eq!(f[13], Token::Bit1);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Arbitrary bytes, with and without a valid version prefix, never panic any decoder.
    #[test]
    fn decode_of_arbitrary_bytes_never_panics(body in prop::collection::vec(any::<u8>(), 0..256)) {
        let mut versioned = FORMAT_VERSION.to_le_bytes().to_vec();
        versioned.extend(&body);
        for (name, _) in all_encoded() {
            let _ = decode_as(name, &body);
            if let Ok(again) = decode_as(name, &versioned) {
                // Whatever is accepted re-encodes to a message that decodes to itself.
                prop_assert_eq!(decode_as(name, &again), Ok(again.clone()));
            }
        }
    }

    /// Valid messages with a few corrupted bytes never panic any decoder.
    #[test]
    fn decode_of_corrupted_messages_never_panics(
        which in 0usize..TYPE_COUNT,
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in any::<prop::sample::Index>(),
    ) {
        let (name, mut bytes) = all_encoded().swap_remove(which);
        for (i, b) in edits {
            let i = i.index(bytes.len());
            bytes[i] = b;
        }
        let _ = decode_as(name, &bytes);
        let _ = decode_as(name, &bytes[..cut.index(bytes.len() + 1)]);
    }
}

/// The setpoints nest their kinematics in one `Kinematics`; bincode adds no framing for a nested
/// struct, so the bytes on the wire (and in every recording) are those of the old flat layout.
#[test]
fn setpoints_keep_the_flat_wire_layout() {
    #[derive(Serialize)]
    struct FlatPerformer {
        tick: u64,
        pos_m: [f64; 3],
        vel_mps: [f64; 3],
        acc_mps2: [f64; 3],
        yaw_rad: f64,
    }
    #[derive(Serialize)]
    struct FlatObserver {
        observer: String,
        pos_m: [f64; 3],
        vel_mps: [f64; 3],
        acc_mps2: [f64; 3],
        yaw_rad: f64,
    }
    let kin = Kinematics {
        pos_m: [0.1, -2.0, 1.3],
        vel_mps: [0.25, 0.0, -1.0],
        acc_mps2: [3.0, 0.5, 0.0],
    };
    let performer = PerformerSetpoint::new(7, kin, 0.75);
    let flat = FlatPerformer {
        tick: 7,
        pos_m: kin.pos_m,
        vel_mps: kin.vel_mps,
        acc_mps2: kin.acc_mps2,
        yaw_rad: 0.75,
    };
    assert_eq!(encode(&performer), encode(&flat));
    let observer = ObserverSetpoint::new(oid("O3"), kin, -1.5);
    let flat = FlatObserver {
        observer: "O3".into(),
        pos_m: kin.pos_m,
        vel_mps: kin.vel_mps,
        acc_mps2: kin.acc_mps2,
        yaw_rad: -1.5,
    };
    assert_eq!(encode(&observer), encode(&flat));
    assert_eq!(
        decode::<PerformerSetpoint>(&encode(&performer)),
        Ok(performer)
    );
}

proptest! {
    /// Packing and selecting against their plain statement: every event's polarity read back,
    /// and a selection holding exactly the selected events, in order, for any packet length
    /// (bytes full, partial and empty) and any selection, into a reused packet.
    #[test]
    fn packed_polarities_and_selections_read_back(
        events in prop::collection::vec((0u16..640, 0u16..480, 1u32..40_000_000, any::<bool>(), any::<bool>()), 0..70),
        stale in prop::collection::vec((0u16..640, 0u16..480, 1u32..40_000_000, any::<bool>()), 0..70),
    ) {
        let polarity = |on: bool| if on { Polarity::On } else { Polarity::Off };
        let all: Vec<_> = events.iter().map(|&(x, y, dt, on, _)| (x, y, dt, polarity(on))).collect();
        let packet = EventPacket::from_events(3, (0, 40_000_000), (640, 480), &all);
        prop_assert_eq!(packet.on_bits.len(), all.len().div_ceil(8));
        for (i, e) in all.iter().enumerate() {
            prop_assert_eq!(packet.polarity(i), e.3);
        }
        let old: Vec<_> = stale.iter().map(|&(x, y, dt, on)| (x, y, dt, polarity(on))).collect();
        let mut out = EventPacket::from_events(9, (0, 1), (2, 2), &old);
        let kept = packet.select_into(&mut out, |i| events[i].4);
        let expected: Vec<_> = events.iter().zip(&all).filter(|(e, _)| e.4).map(|(_, a)| *a).collect();
        prop_assert_eq!(kept, expected.len());
        prop_assert_eq!(&out, &EventPacket::from_events(3, (0, 40_000_000), (640, 480), &expected));
    }
}
