//! The noisy sensor's events pinned to the generator's previous versions: speed-ups of the
//! noise model must give the same events for the same seed, byte for byte. Each case is a
//! camera fed the synthetic moving-blob scene as a trial feeds it (each render with the
//! rectangle that changed, or whole frames), with a set of v2e's terms; the digest covers every
//! event (time, pixel, polarity) of every packet. A digest changes only in a commit that says
//! why the stream changed.

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, EventCamera, EventNoise};
use proto::FrameChange;

const RENDER_NS: u64 = 10_000_000;

/// FNV-1a over the bytes of every event and packet boundary.
fn digest(packets: &[proto::EventPacket]) -> (u64, usize) {
    let mut h = 0xCBF2_9CE4_8422_2325u64;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3);
        }
    };
    let mut events = 0;
    for p in packets {
        eat(&p.start_ns.to_le_bytes());
        eat(&[u8::from(p.valid), u8::from(p.continuous)]);
        for k in 0..p.len() {
            eat(&p.xs[k].to_le_bytes());
            eat(&p.ys[k].to_le_bytes());
            eat(&p.dt_ns[k].to_le_bytes());
        }
        eat(&p.on_bits);
        events += p.len();
    }
    (h, events)
}

/// v2e's shared terms (lin-log knee, leak spread and jitter, shot noise's bright drop).
fn v2e(noise: EventNoise) -> EventNoise {
    EventNoise {
        linlog_dn: 20.0,
        leak_spread_decades: 0.1,
        leak_jitter: 0.1,
        shot_noise_bright_drop: 0.75,
        ..noise
    }
}

fn run(width: u16, height: u16, seconds: u64, noise: EventNoise, whole: bool) -> (u64, usize) {
    let renders = MovingBlobScene::new(width, height).renders(seconds * 1_000_000_000, RENDER_NS);
    let mut camera = EventCamera::new(CameraConfig {
        threshold: 0.2,
        noise,
        ..CameraConfig::paper(width, height)
    })
    .expect("camera");
    let mut packets = Vec::new();
    for (k, (rgb, change)) in renders.iter().enumerate() {
        let change = if whole { FrameChange::All } else { *change };
        packets.extend(
            camera
                .push_frame_change(k as u64 * RENDER_NS, rgb, change)
                .expect("render"),
        );
    }
    digest(&packets)
}

#[test]
fn noisy_streams_equal_the_previous_generators() {
    let noisy = v2e(EventNoise {
        threshold_sigma: 0.05,
        leak_hz: 0.1,
        shot_noise_hz: 5.0,
        cutoff_hz: 30.0,
        seed: 3,
        ..EventNoise::default()
    });
    let cases: [(&str, EventNoise, bool, (u64, usize)); 5] = [
        (
            "v2e-noisy, changed rectangles",
            noisy,
            false,
            (0xc4d2_64da_955d_db31, 783_513),
        ),
        (
            "v2e-default, whole frames",
            v2e(EventNoise {
                threshold_sigma: 0.03,
                refractory_ns: 500_000,
                leak_hz: 0.01,
                shot_noise_hz: 0.001,
                cutoff_hz: 300.0,
                seed: 4,
                ..EventNoise::default()
            }),
            true,
            (0x0229_9624_fe10_f405, 69_429),
        ),
        (
            "dim: 10 Hz shot noise, a fast leak, hot pixels",
            EventNoise {
                shot_noise_hz: 10.0,
                leak_hz: 2.0,
                hot_pixels: 7,
                hot_pixel_hz: 40.0,
                refractory_ns: 1_000_000,
                seed: 5,
                ..noisy
            },
            false,
            (0xb9ab_855a_ce55_d9d2, 1_921_572),
        ),
        (
            "shot noise thinned by brightness, no leak or low-pass, whole frames",
            EventNoise {
                threshold_sigma: 0.05,
                shot_noise_hz: 5.0,
                shot_noise_bright_drop: 0.75,
                seed: 6,
                ..EventNoise::default()
            },
            true,
            (0x0b18_5603_177a_3e90, 773_730),
        ),
        (
            "shot noise thinned by brightness, no leak or low-pass, changed rectangles",
            EventNoise {
                shot_noise_hz: 3.0,
                shot_noise_bright_drop: 0.5,
                linlog_dn: 20.0,
                seed: 8,
                ..EventNoise::default()
            },
            false,
            (0x9b8f_8995_626a_f649, 557_696),
        ),
    ];
    let mut got = Vec::new();
    for (name, noise, whole, _) in &cases {
        got.push((*name, run(320, 240, 3, *noise, *whole)));
    }
    for (name, (digest, events)) in &got {
        println!("{name}: ({digest:#018x}, {events})");
    }
    for ((name, (digest, events)), (_, _, _, want)) in got.iter().zip(&cases) {
        assert!(*events > 1000, "{name}: {events} events");
        assert_eq!((*digest, *events), *want, "{name}");
    }
}
