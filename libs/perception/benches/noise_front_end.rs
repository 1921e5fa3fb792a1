//! What realistic sensor noise costs: generating it (the noisy converter) and removing it (the
//! receiver's front end), in events per second per core, and the receiver's time per packet
//! with its front end against the same receiver with the front end off, on the same stream (a
//! ratio from one invocation).
//!
//! Run: `cargo bench -p perception --bench noise_front_end`. The stream: the synthetic moving-blob
//! scene (`event_camera::synthetic`), 640×480 at 100 Hz, 2 s, through a sensor with v2e's
//! `noisy` shot noise and leak (5 Hz and 0.1 Hz per pixel) — ≈ 3 M noise events. Each figure is
//! the fastest of 5 repetitions (`WAGGLE_BENCH_REPEATS=N` for N) on one thread.

use std::hint::black_box;
use std::time::{Duration, Instant};

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, EventCamera, EventNoise};
use perception::events::{DenoiseConfig, EventReceiver, EventReceiverConfig, NoiseFilter};
use proto::EventPacket;

const W: u16 = 640;
const H: u16 = 480;
const RENDER_NS: u64 = 10_000_000;
const SECONDS: u64 = 2;
/// Repetitions of each measurement; `WAGGLE_BENCH_REPEATS` overrides it.
const REPEATS: usize = 5;

fn repeats() -> usize {
    std::env::var("WAGGLE_BENCH_REPEATS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
        .unwrap_or(REPEATS)
}

fn noisy_camera() -> EventCamera {
    let noise = EventNoise {
        threshold_sigma: 0.05,
        refractory_ns: 500_000,
        leak_hz: 0.1,
        shot_noise_hz: 5.0,
        seed: 1,
        ..EventNoise::default()
    };
    EventCamera::new(CameraConfig {
        noise,
        ..CameraConfig::paper(W, H)
    })
    .expect("camera")
}

/// The fastest repetition: on a shared machine the others measure the neighbours too.
fn best(times: Vec<Duration>) -> Duration {
    times.into_iter().min().expect("at least one repetition")
}

fn main() {
    let scene = MovingBlobScene::new(W, H);
    let frames: Vec<Vec<u8>> = (0..=SECONDS * 1_000_000_000 / RENDER_NS)
        .map(|k| scene.frame(k * RENDER_NS))
        .collect();

    let mut packets = Vec::new();
    let generate = best(
        (0..repeats())
            .map(|_| {
                let mut camera = noisy_camera();
                let start = Instant::now();
                let mut out = Vec::new();
                for (k, rgb) in frames.iter().enumerate() {
                    out.extend(camera.push_frame(k as u64 * RENDER_NS, rgb).expect("frame"));
                }
                let took = start.elapsed();
                packets = out;
                took
            })
            .collect(),
    );
    let events: usize = packets.iter().map(EventPacket::len).sum();

    let filter = best(
        (0..repeats())
            .map(|_| {
                let mut f = NoiseFilter::new(DenoiseConfig::receiver(), W, H).expect("filter");
                let mut out = EventPacket::from_events(0, (0, 0), (W, H), &[]);
                let start = Instant::now();
                for p in &packets {
                    f.filter(p, &mut out);
                    black_box(&out);
                }
                start.elapsed()
            })
            .collect(),
    );

    let receive = |denoise: DenoiseConfig| {
        best(
            (0..repeats())
                .map(|_| {
                    let mut rx = EventReceiver::new(EventReceiverConfig {
                        denoise,
                        ..EventReceiverConfig::paper()
                    })
                    .expect("receiver");
                    let start = Instant::now();
                    for p in &packets {
                        black_box(rx.push_packet(p));
                    }
                    start.elapsed()
                })
                .collect(),
        )
    };
    let with = receive(DenoiseConfig::receiver());
    let without = receive(DenoiseConfig::off());

    let rate = |d: Duration| events as f64 / d.as_secs_f64() / 1e6;
    println!(
        "stream: {events} events in {SECONDS} s of sensor time ({} packets)",
        packets.len()
    );
    println!(
        "noise generation (converter + packets): {:>8.1} M events/s",
        rate(generate)
    );
    println!(
        "front end (correlation filter):         {:>8.1} M events/s",
        rate(filter)
    );
    println!(
        "generation + front end:                  {:>8.1} M events/s",
        rate(generate + filter)
    );
    println!(
        "receiver per packet: {:.1} µs with the front end, {:.1} µs without; ratio {:.2}",
        with.as_secs_f64() * 1e6 / packets.len() as f64,
        without.as_secs_f64() * 1e6 / packets.len() as f64,
        with.as_secs_f64() / without.as_secs_f64()
    );
}
