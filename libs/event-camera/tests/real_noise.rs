//! A recording's background replayed into a sensor: its per-pixel rate kept at any sensor
//! size, scaled by the copies, and the same packets for the same seed.

use std::sync::Arc;

use event_camera::fit::{Background, fit};
use event_camera::real_noise::{RealNoise, RealNoiseTiler};
use event_camera::{CameraConfig, Event, EventCamera, EventNoise, NoisyConverter};

const RENDER_NS: u64 = 10_000_000;

/// `seconds` of a static scene through a sensor of shot noise `hz` per pixel.
fn recording(width: u16, height: u16, seconds: u64, hz: f64) -> Vec<Event> {
    let noise = EventNoise {
        shot_noise_hz: hz,
        seed: 17,
        ..EventNoise::default()
    };
    let mut sensor = NoisyConverter::new(width, height, 0.2, &noise).expect("sensor");
    let grey = vec![128u8; usize::from(width) * usize::from(height) * 3];
    let mut events = Vec::new();
    for k in 0..=seconds * 1_000_000_000 / RENDER_NS {
        sensor
            .push(k * RENDER_NS, &grey, &mut events)
            .expect("frame");
    }
    events
}

fn source(hz: f64) -> Arc<RealNoise> {
    let events = recording(64, 48, 10, hz);
    let whole = Background::Static {
        start_ns: 0,
        end_ns: 10_000_000_000,
    };
    Arc::new(RealNoise::from_recording("test", "", &events, 64, 48, whole).expect("source"))
}

/// Events per pixel per second a tiler gives a `w`×`h` sensor over `seconds`.
fn rate(tiler: &mut RealNoiseTiler, w: u16, h: u16, seconds: u64) -> f64 {
    tiler.start(0);
    let mut events = Vec::new();
    for k in 1..=seconds * 100 {
        tiler.fill(k * RENDER_NS, &mut events);
    }
    assert!(events.windows(2).all(|p| p[0].t_ns <= p[1].t_ns));
    assert!(events.iter().all(|e| e.x < w && e.y < h));
    events.len() as f64 / (f64::from(w) * f64::from(h) * seconds as f64)
}

#[test]
fn the_per_pixel_rate_is_kept_at_any_sensor_size_and_scales_with_the_copies() {
    let source = source(2.0);
    assert!(
        (source.fitted.shot_noise_hz - 2.0).abs() < 0.2,
        "{:?}",
        source.fitted
    );
    // Larger than the recording (tiled), smaller (cropped), and looped past its 10 s.
    for (w, h) in [(160, 120), (40, 30)] {
        let one = rate(
            &mut RealNoiseTiler::new(source.clone(), 1, w, h, 5),
            w,
            h,
            25,
        );
        assert!((one - 2.0).abs() < 0.2, "{w}×{h}: {one} Hz");
        let five = rate(
            &mut RealNoiseTiler::new(source.clone(), 5, w, h, 5),
            w,
            h,
            25,
        );
        assert!((five - 10.0).abs() < 1.0, "{w}×{h}, 5 copies: {five} Hz");
    }
    // The replayed stream fits as the recording did.
    let mut tiler = RealNoiseTiler::new(source, 1, 160, 120, 8);
    tiler.start(0);
    let mut events = Vec::new();
    tiler.fill(20_000_000_000, &mut events);
    let whole = Background::Static {
        start_ns: 0,
        end_ns: 20_000_000_000,
    };
    let refit = fit(&events, 160, 120, whole).expect("fit");
    assert!((refit.shot_noise_hz - 2.0).abs() < 0.2, "{refit:?}");
}

#[test]
fn a_camera_adds_the_replay_to_what_it_converts_the_same_for_the_same_seed() {
    let source = source(1.0);
    let (w, h) = (80u16, 60u16);
    let run = |seed: Option<u64>| {
        let mut camera = EventCamera::new(CameraConfig::paper(w, h)).expect("camera");
        if let Some(seed) = seed {
            camera = camera.with_real_noise(RealNoiseTiler::new(source.clone(), 2, w, h, seed));
        }
        let mut packets = Vec::new();
        for k in 0..=200u64 {
            // A bright square moving across a grey field: the converted signal.
            let mut rgb = vec![90u8; usize::from(w) * usize::from(h) * 3];
            let left = (k % 60) as usize;
            for y in 20..30 {
                for x in left..left + 10 {
                    rgb[3 * (y * usize::from(w) + x)..][..3].fill(200);
                }
            }
            packets.extend(camera.push_frame(k * RENDER_NS, &rgb).expect("frame"));
        }
        packets
    };
    let clean = run(None);
    let noisy = run(Some(3));
    assert_eq!(noisy, run(Some(3)));
    assert_ne!(noisy, run(Some(4)));
    let count = |p: &[proto::EventPacket]| p.iter().map(|p| p.xs.len()).sum::<usize>();
    // 2 copies of 1 Hz per pixel over 2 s on 80×60 px: ≈ 19 200 events beside the signal.
    let added = count(&noisy) - count(&clean);
    assert!((17_000..21_500).contains(&added), "{added}");
    assert!(
        noisy
            .iter()
            .all(|p| p.dt_ns.windows(2).all(|d| d[0] <= d[1]))
    );
}
