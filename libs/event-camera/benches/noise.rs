//! What sensor noise costs to generate, per core, against baselines in the same run.
//!
//! Run: `cargo bench -p event-camera --bench noise`. The stream: the synthetic moving-blob
//! scene (`event_camera::synthetic`), 640×480 at 100 Hz for 4 s of sensor time, fed as the
//! trials feed renders (each with the rectangle that changed since the previous one, so the
//! camera converts only what moved), through three sensors: the ideal one, v2e's `default`
//! and v2e's `noisy` parameters (`perturb::preset`'s values). Each path is timed in this
//! thread's CPU time (Linux scheduler statistics, so time spent waiting for a core that other
//! work holds is not counted) and repeated five times, interleaved; the figures are medians.
//!
//! Two baselines make the figures comparable across machines and loads: `memcpy`, copying the
//! noisy sensor's events (16 bytes each) once, the least any generator must spend on its
//! output; and the ideal sensor's time, the cost of the renders' own events without noise.
//! Printed: events per sensor second, CPU per sensor second, events per second per core, and
//! the noisy generator's time per event as a multiple of the memcpy's.

use std::hint::black_box;

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, EventCamera, EventNoise, Polarity};
use proto::FrameChange;

const W: u16 = 640;
const H: u16 = 480;
const RENDER_NS: u64 = 10_000_000;
const SECONDS: u64 = 4;
const REPEATS: usize = 5;

/// This thread's CPU time, ns; wall time where the scheduler statistics are not readable.
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| {
            static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
            START
                .get_or_init(std::time::Instant::now)
                .elapsed()
                .as_nanos() as u64
        })
}

/// v2e's parameter sets in Waggle's terms (the values of `perturb::preset`).
fn v2e(name: &str) -> (f64, EventNoise) {
    let shared = EventNoise {
        linlog_dn: 20.0,
        leak_spread_decades: 0.1,
        leak_jitter: 0.1,
        shot_noise_bright_drop: 0.75,
        seed: 7,
        ..EventNoise::default()
    };
    let noise = match name {
        "default" => EventNoise {
            threshold_sigma: 0.03,
            leak_hz: 0.01,
            shot_noise_hz: 0.001,
            refractory_ns: 500_000,
            cutoff_hz: 300.0,
            ..shared
        },
        _ => EventNoise {
            threshold_sigma: 0.05,
            leak_hz: 0.1,
            shot_noise_hz: 5.0,
            cutoff_hz: 30.0,
            ..shared
        },
    };
    (0.2, noise)
}

/// (events, CPU ns) of one camera over every render.
fn generate(threshold: f64, noise: EventNoise, renders: &[(Vec<u8>, FrameChange)]) -> (u64, u64) {
    let start = cpu_ns();
    let mut camera = EventCamera::new(CameraConfig {
        threshold,
        noise,
        ..CameraConfig::paper(W, H)
    })
    .expect("camera");
    let mut events = 0u64;
    for (k, (rgb, change)) in renders.iter().enumerate() {
        let packets = camera
            .push_frame_change(k as u64 * RENDER_NS, rgb, *change)
            .expect("render");
        events += packets.iter().map(|p| p.len() as u64).sum::<u64>();
        black_box(packets);
    }
    (events, cpu_ns() - start)
}

/// CPU ns to copy `events` events (16 bytes each) once, between buffers already in memory.
fn memcpy(events: u64) -> u64 {
    let from = vec![
        event_camera::Event {
            t_ns: 1,
            x: 2,
            y: 3,
            polarity: Polarity::On,
        };
        events as usize
    ];
    // Both buffers already touched: the copy, not the kernel's first-touch page faults.
    let mut to = from.clone();
    let start = cpu_ns();
    to.copy_from_slice(black_box(&from));
    black_box(&to);
    cpu_ns() - start
}

fn median(mut v: Vec<u64>) -> u64 {
    v.sort_unstable();
    v[v.len() / 2]
}

fn main() {
    let renders = MovingBlobScene::new(W, H).renders(SECONDS * 1_000_000_000, RENDER_NS);
    let paths = [
        (
            "ideal",
            (event_camera::DEFAULT_THRESHOLD, EventNoise::default()),
        ),
        ("v2e-default", v2e("default")),
        ("v2e-noisy", v2e("noisy")),
    ];
    let mut times = vec![Vec::new(); paths.len() + 1];
    let mut counts = vec![0u64; paths.len()];
    for _ in 0..REPEATS {
        for (k, (_, (threshold, noise))) in paths.iter().enumerate() {
            let (events, ns) = generate(*threshold, *noise, &renders);
            counts[k] = events;
            times[k].push(ns);
        }
        times[paths.len()].push(memcpy(counts[paths.len() - 1]));
    }
    let times: Vec<u64> = times.into_iter().map(median).collect();
    println!(
        "{SECONDS} s of a {W}×{H} sensor at 100 Hz renders, CPU time of one thread (median of {REPEATS}):"
    );
    for (k, (name, _)) in paths.iter().enumerate() {
        let per_s = times[k] as f64 * 1e-9 / SECONDS as f64;
        println!(
            "  {name:<12} {:>10.0} events/s of sensor time, {:>7.1} ms CPU per sensor second, {:>6.1} M events/s per core",
            counts[k] as f64 / SECONDS as f64,
            per_s * 1e3,
            counts[k] as f64 / (times[k] as f64 * 1e-9) / 1e6
        );
    }
    let noisy = paths.len() - 1;
    let (gen_ns, copy_ns) = (times[noisy] as f64, times[paths.len()] as f64);
    println!(
        "  memcpy of the noisy events: {:.1} ns per event; the noisy generator {:.1} ns per event = {:.1}× memcpy; noise adds {:.1}× the ideal sensor's time",
        copy_ns / counts[noisy] as f64,
        gen_ns / counts[noisy] as f64,
        gen_ns / copy_ns,
        gen_ns / times[0] as f64
    );
}
