//! What realistic sensor noise costs: generating it (the noisy converter) and removing it (the
//! receiver's front end), in events per second per core, and the receiver's time per packet
//! with its front end against the same receiver with the front end off, on the same stream (a
//! ratio from one invocation).
//!
//! Run: `cargo bench -p perception --bench noise_front_end`. The stream: the synthetic
//! moving-blob scene (`event_camera::synthetic`), 640×480 at 100 Hz, 4 s, each render with the
//! rectangle that changed (as a trial feeds its camera), through the event sensor a trial builds
//! for the preset `v2e-noisy` (`perturb::Perturbation::with_preset`: every term of v2e's model —
//! shot noise scaled by brightness, leak with spread and jitter, the photoreceptor cutoff,
//! linlog, threshold mismatch), ≈ 4 M events. `WAGGLE_BENCH_PRESET=NAME` picks another preset.
//! Each figure is the fastest of 5 repetitions (`WAGGLE_BENCH_REPEATS=N` for N) on one thread.
//!
//! Beside them, in the same run, the floor the aim of 50 M events per second per core meets:
//! the simplest published correlation filter (the causal STCF of Guo & Delbruck, TPAMI 2023,
//! one time per pixel, over the whole map, no bands) on the same packets, and the simplest
//! shot-noise generator (uniform pixels and times from SplitMix64, sorted by a counting sort
//! per 10 ms render) making as many events. Neither is what the receiver or the sensor could
//! use (the receiver's filter is two-sided with two times per pixel and borders; v2e's shot
//! noise has a per-pixel rate map): they measure what is left for everything else.

use std::hint::black_box;
use std::time::{Duration, Instant};

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, EventCamera};
use perception::events::{DenoiseConfig, EventReceiver, EventReceiverConfig, NoiseFilter};
use proto::EventPacket;

#[path = "../tests/support/causal_stcf.rs"]
mod causal_stcf;
use causal_stcf::causal_stcf;
#[path = "../tests/support/rng.rs"]
mod rng;
use rng::Rng;

const W: u16 = 640;
const H: u16 = 480;
const RENDER_NS: u64 = 10_000_000;
const SECONDS: u64 = 4;
/// Renders before generation is timed: one second.
const WARMUP_RENDERS: usize = 100;
/// Repetitions of each measurement; `WAGGLE_BENCH_REPEATS` overrides it.
const REPEATS: usize = 5;

fn repeats() -> usize {
    std::env::var("WAGGLE_BENCH_REPEATS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
        .unwrap_or(REPEATS)
}

/// The sensor preset the stream is generated with.
fn preset() -> String {
    std::env::var("WAGGLE_BENCH_PRESET").unwrap_or_else(|_| "v2e-noisy".to_owned())
}

/// A camera with the preset's sensor, as a trial builds it (noise seed 1).
fn noisy_camera(preset: &str) -> EventCamera {
    let sensor = perturb::Perturbation::with_preset(Some(preset), &[] as &[&str])
        .expect("a known preset")
        .event_sensor(1);
    EventCamera::new(CameraConfig::paper(W, H).with_model(sensor)).expect("camera")
}

/// The fastest repetition: on a shared machine the others measure the neighbours too.
fn best(times: Vec<Duration>) -> Duration {
    times.into_iter().min().expect("at least one repetition")
}

/// The causal STCF over `packets` (module `causal_stcf`, the ROC's definition): the events kept
/// (so the work cannot be dropped) and the time taken.
fn time_causal_stcf(packets: &[EventPacket]) -> (u64, Duration) {
    let start = Instant::now();
    let (_, kept) = causal_stcf(packets, (W, H), 15_000, 2);
    (kept, start.elapsed())
}

/// The simplest shot noise: `events` events spread evenly over `renders` renders of 10 ms, each
/// at a uniform pixel and microsecond from one draw, each render's keys sorted by time with a
/// counting sort (as the sensor sorts its shot events). Returns a checksum and the time taken.
fn uniform_shot_noise(events: usize, renders: usize) -> (u64, Duration) {
    let pixels = u64::from(W) * u64::from(H);
    let render_us = RENDER_NS / 1_000;
    let per_render = events.div_ceil(renders.max(1));
    let (mut keys, mut sorted) = (Vec::with_capacity(per_render), vec![0u64; per_render]);
    let mut counts = vec![0u32; render_us as usize + 1];
    let (mut rng, mut checksum) = (Rng(1), 0u64);
    let start = Instant::now();
    for _ in 0..renders {
        keys.clear();
        for _ in 0..per_render {
            let a = rng.next();
            let t_us = ((a >> 32) * render_us) >> 32;
            let pixel = ((a & 0xFFFF_FFFF) * pixels) >> 32;
            keys.push((t_us << 32) | pixel);
        }
        counts.fill(0);
        for &k in &keys {
            counts[(k >> 32) as usize + 1] += 1;
        }
        let mut total = 0;
        for c in &mut counts {
            total += *c;
            *c = total;
        }
        for &k in &keys {
            let slot = &mut counts[(k >> 32) as usize];
            sorted[*slot as usize] = k;
            *slot += 1;
        }
        checksum = checksum.wrapping_add(sorted[per_render / 2]);
    }
    (checksum, start.elapsed())
}

fn main() {
    let renders = MovingBlobScene::new(W, H).renders(SECONDS * 1_000_000_000, RENDER_NS);

    let preset = preset();
    // Generation is timed after a warm-up second: the first render judges every pixel of the
    // sensor with every term of the model, a start-up cost a 97 s trial spreads thin.
    let (mut generated, mut packets): (usize, Vec<EventPacket>) = (0, Vec::new());
    let generate = best(
        (0..repeats())
            .map(|_| {
                let mut camera = noisy_camera(&preset);
                let mut out = Vec::new();
                let mut push = |k: usize, out: &mut Vec<EventPacket>| {
                    let (rgb, change) = &renders[k];
                    let t_ns = k as u64 * RENDER_NS;
                    out.extend(camera.push_frame_change(t_ns, rgb, *change).expect("frame"));
                };
                (0..WARMUP_RENDERS).for_each(|k| push(k, &mut out));
                let before = out.len();
                let start = Instant::now();
                (WARMUP_RENDERS..renders.len()).for_each(|k| push(k, &mut out));
                let took = start.elapsed();
                generated = out[before..].iter().map(EventPacket::len).sum();
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
    let (floor_kept, floor_filter) = {
        let runs: Vec<_> = (0..repeats()).map(|_| time_causal_stcf(&packets)).collect();
        (runs[0].0, best(runs.into_iter().map(|(_, d)| d).collect()))
    };
    let floor_generate = best(
        (0..repeats())
            .map(|_| {
                let (checksum, took) =
                    uniform_shot_noise(generated, renders.len() - WARMUP_RENDERS);
                black_box(checksum);
                took
            })
            .collect(),
    );

    let with = receive(DenoiseConfig::receiver());
    let without = receive(DenoiseConfig::off());

    let rate = |d: Duration| events as f64 / d.as_secs_f64() / 1e6;
    println!(
        "stream: {events} events in {SECONDS} s of sensor time ({} packets), sensor {preset}",
        packets.len()
    );
    let generation = generated as f64 / generate.as_secs_f64() / 1e6;
    println!(
        "noise generation (converter + packets): {generation:>8.1} M events/s (after {} s)",
        WARMUP_RENDERS as u64 * RENDER_NS / 1_000_000_000
    );
    println!(
        "front end (correlation filter):         {:>8.1} M events/s",
        rate(filter)
    );
    let per_event = |mega_per_s: f64| 1e-6 / mega_per_s;
    println!(
        "generation + front end:                  {:>8.1} M events/s",
        1e-6 / (per_event(generation) + per_event(rate(filter)))
    );
    let floor_generation = generated as f64 / floor_generate.as_secs_f64() / 1e6;
    println!(
        "floor: uniform shot noise (SplitMix64, counting sort): {floor_generation:>6.1} M events/s ({:.1}× the sensor's)",
        floor_generation / generation
    );
    println!(
        "floor: causal STCF, one time per pixel (kept {floor_kept}): {:>8.1} M events/s ({:.1}× the front end's)",
        rate(floor_filter),
        rate(floor_filter) / rate(filter)
    );
    println!(
        "floor: generation + filter together:     {:>8.1} M events/s",
        1e-6 / (per_event(floor_generation) + per_event(rate(floor_filter)))
    );
    println!(
        "receiver per packet: {:.1} µs with the front end, {:.1} µs without; ratio {:.2}",
        with.as_secs_f64() * 1e6 / packets.len() as f64,
        without.as_secs_f64() * 1e6 / packets.len() as f64,
        with.as_secs_f64() / without.as_secs_f64()
    );
}
