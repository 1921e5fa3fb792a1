//! The packetiser: 40 ms packets on a fixed sim-time grid, empty packets, black-input fault,
//! validity and continuity.

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, CameraError, ConvertError, Converter, Event, EventCamera};
use proto::EventPacket;

const W: u16 = 64;
const H: u16 = 48;
const RENDER_NS: u64 = 10_000_000;
const PACKET_NS: u64 = 40_000_000;

/// Renders at `stamps` of the moving-blob scene through a camera; all packets in order.
fn run(config: CameraConfig, stamps: impl IntoIterator<Item = u64>) -> Vec<EventPacket> {
    let scene = MovingBlobScene::new(config.width, config.height);
    let mut camera = EventCamera::new(config).unwrap();
    let mut packets = Vec::new();
    for stamp_ns in stamps {
        packets.extend(camera.push_frame(stamp_ns, &scene.frame(stamp_ns)).unwrap());
    }
    packets
}

fn unpack(packets: &[EventPacket]) -> Vec<Event> {
    packets
        .iter()
        .flat_map(|p| {
            (0..p.len()).map(|i| Event {
                t_ns: p.t_ns(i),
                x: p.xs[i],
                y: p.ys[i],
                polarity: p.polarity(i),
            })
        })
        .collect()
}

#[test]
fn five_seconds_of_renders_make_125_contiguous_packets_holding_every_event() {
    let stamps = (0..=500).map(|k| k * RENDER_NS); // 0 .. 5 s inclusive, 100 Hz
    let packets = run(CameraConfig::paper(W, H), stamps.clone());
    assert_eq!(packets.len(), 125);
    for (k, p) in packets.iter().enumerate() {
        let k = k as u64;
        assert_eq!(p.seq, k);
        assert_eq!((p.start_ns, p.end_ns), (k * PACKET_NS, (k + 1) * PACKET_NS));
        assert_eq!((p.width, p.height), (W, H));
        assert!(p.valid && p.continuous, "packet {k}");
        // Every packet is well-formed on the wire.
        let back: EventPacket = proto::decode(&proto::encode(p)).unwrap();
        assert_eq!(&back, p);
    }
    // Nothing lost or duplicated: the packets hold exactly the converter's stream.
    let scene = MovingBlobScene::new(W, H);
    let mut converter = Converter::new(W, H, event_camera::DEFAULT_THRESHOLD).unwrap();
    let mut want = Vec::new();
    for stamp_ns in stamps {
        converter
            .push(stamp_ns, &scene.frame(stamp_ns), &mut want)
            .unwrap();
    }
    let got = unpack(&packets);
    assert!(
        got.len() > 1_000,
        "the blob must move ({} events)",
        got.len()
    );
    assert_eq!(got, want);
    // And each event sits inside its packet's (start, end] watermarks.
    for p in &packets {
        assert!(
            p.dt_ns
                .iter()
                .all(|&dt| dt >= 1 && u64::from(dt) <= PACKET_NS)
        );
    }
}

#[test]
fn black_input_from_start_up_yields_only_empty_packets() {
    let config = CameraConfig {
        black_input: true,
        ..CameraConfig::paper(W, H)
    };
    let packets = run(config, (0..=500).map(|k| k * RENDER_NS));
    assert_eq!(packets.len(), 125);
    assert!(
        packets
            .iter()
            .all(|p| p.is_empty() && p.valid && p.continuous)
    );
    assert!(packets.iter().enumerate().all(|(k, p)| p.seq == k as u64));
}

#[test]
fn black_input_is_applied_before_conversion() {
    // Switching the fault on mid-run blacks out a lit scene: a burst of OFF events, then quiet.
    let scene = MovingBlobScene::new(W, H);
    let mut camera = EventCamera::new(CameraConfig::paper(W, H)).unwrap();
    let mut packets = Vec::new();
    for k in 0..=40u64 {
        if k == 21 {
            camera.set_black_input(true);
        }
        let t = k * RENDER_NS;
        packets.extend(camera.push_frame(t, &scene.frame(t)).unwrap());
    }
    assert_eq!(packets.len(), 10);
    let blackout = &packets[5]; // (200, 240] ms holds the 200 → 210 ms interval
    assert!(
        blackout.len() >= usize::from(W) * usize::from(H),
        "every lit pixel falls"
    );
    assert!((0..blackout.len()).all(|i| blackout.polarity(i) == proto::Polarity::Off));
    assert!(packets[6..].iter().all(EventPacket::is_empty));
}

#[test]
fn a_still_scene_still_emits_empty_packets() {
    let scene = MovingBlobScene::new(W, H);
    let frame = scene.frame(0);
    let mut camera = EventCamera::new(CameraConfig::paper(W, H)).unwrap();
    let mut packets = Vec::new();
    for k in 0..=100u64 {
        let got = camera.push_frame(k * RENDER_NS, &frame).unwrap();
        // Exactly one packet per four renders, at the 40 ms boundaries.
        assert_eq!(got.len(), usize::from(k > 0 && k % 4 == 0), "render {k}");
        packets.extend(got);
    }
    assert_eq!(packets.len(), 25);
    assert!(
        packets
            .iter()
            .all(|p| p.is_empty() && p.valid && p.continuous)
    );
}

#[test]
fn packets_sit_on_the_sim_time_grid_and_a_late_start_is_invalid() {
    // First render at 10 ms: packet (0, 40] was only partly observed.
    let packets = run(CameraConfig::paper(W, H), (1..=40).map(|k| k * RENDER_NS));
    assert_eq!(packets.len(), 10);
    assert_eq!(
        (packets[0].seq, packets[0].start_ns, packets[0].end_ns),
        (0, 0, PACKET_NS)
    );
    assert!(!packets[0].valid);
    assert!(packets[1..].iter().all(|p| p.valid));
    // First render at 40 ms exactly: the first packet is (40, 80], fully observed, seq 0.
    let packets = run(CameraConfig::paper(W, H), (4..=40).map(|k| k * RENDER_NS));
    assert_eq!(packets.len(), 9);
    assert_eq!((packets[0].seq, packets[0].start_ns), (0, PACKET_NS));
    assert!(packets.iter().all(|p| p.valid && p.continuous));
}

#[test]
fn missing_renders_mark_the_overlapping_packets_discontinuous() {
    // Renders every 10 ms except 50..=150 ms (gap from 40 to 160 ms).
    let stamps: Vec<u64> = (0..=40)
        .map(|k| k * RENDER_NS)
        .filter(|t| !(50_000_000..=150_000_000).contains(t))
        .collect();
    let scene = MovingBlobScene::new(W, H);
    let mut camera = EventCamera::new(CameraConfig::paper(W, H)).unwrap();
    let mut per_push = Vec::new();
    let mut packets = Vec::new();
    for &t in &stamps {
        let got = camera.push_frame(t, &scene.frame(t)).unwrap();
        per_push.push((t, got.len()));
        packets.extend(got);
    }
    // The render at 160 ms completes (40,80], (80,120] and (120,160] at once.
    assert!(per_push.contains(&(160_000_000, 3)));
    assert_eq!(packets.len(), 10);
    let continuity: Vec<bool> = packets.iter().map(|p| p.continuous).collect();
    assert_eq!(
        continuity,
        vec![
            true, false, false, false, true, true, true, true, true, true
        ]
    );
    assert!(packets.iter().all(|p| p.valid));
    assert!(
        packets
            .windows(2)
            .all(|w| w[0].end_ns == w[1].start_ns && w[0].seq + 1 == w[1].seq)
    );
    // Events are still interpolated across the gap, each inside its own packet.
    assert!(packets[1..4].iter().any(|p| !p.is_empty()));
}

#[test]
fn bad_configuration_and_frames_are_rejected_without_side_effects() {
    let bad = |f: fn(&mut CameraConfig)| {
        let mut config = CameraConfig::paper(W, H);
        f(&mut config);
        EventCamera::new(config).unwrap_err()
    };
    assert_eq!(
        bad(|c| c.packet_period_ns = 0),
        CameraError::BadPacketPeriod(0)
    );
    assert!(matches!(
        bad(|c| c.packet_period_ns = 1 << 33),
        CameraError::BadPacketPeriod(_)
    ));
    assert_eq!(
        bad(|c| c.render_period_ns = 0),
        CameraError::BadRenderPeriod
    );
    assert!(matches!(
        bad(|c| c.threshold = 0.0),
        CameraError::Convert(ConvertError::BadThreshold(_))
    ));

    let scene = MovingBlobScene::new(W, H);
    let mut camera = EventCamera::new(CameraConfig::paper(W, H)).unwrap();
    camera.push_frame(0, &scene.frame(0)).unwrap();
    assert!(matches!(
        camera.push_frame(RENDER_NS, &[0; 5]),
        Err(CameraError::Convert(ConvertError::FrameSize { got: 5, .. }))
    ));
    // A wrong-size frame is rejected even while the black fault would have replaced it.
    camera.set_black_input(true);
    assert!(camera.push_frame(RENDER_NS, &[0; 5]).is_err());
    camera.set_black_input(false);
    assert!(matches!(
        camera.push_frame(0, &scene.frame(0)),
        Err(CameraError::Convert(
            ConvertError::StampNotIncreasing { .. }
        ))
    ));
    for k in 1..=4 {
        let t = k * RENDER_NS;
        let got = camera.push_frame(t, &scene.frame(t)).unwrap();
        assert_eq!(got.len(), usize::from(k == 4));
    }
    assert_eq!(camera.next_seq(), 1);
}
