//! Event conversion cost per 640×480 frame (docs/DESIGN.md §14 target: ≤ 0.35 ms, one core).
//!
//! Run: `cargo bench -p event-camera --bench convert`. Criterion reports time per frame and,
//! as "elem/s", pixels per second. Frames: the rendered fixtures in
//! `tests/fixtures/frames/*.png` when present, and the synthetic moving-blob scene. Frames are
//! played forwards then backwards so every interval is between neighbouring renders, as in
//! the camera; the reference converter runs on the same frames for the speed ratio. The
//! `noisy_*` groups time [`NoisyConverter`] on the same frames: `noisy` without leak (same scan
//! as the exact converter), `noisy_leak` with leak (every pixel's `d` evaluated every frame).

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use event_camera::reference::ReferenceConverter;
use event_camera::synthetic::MovingBlobScene;
use event_camera::{Converter, DEFAULT_THRESHOLD, EventNoise, NoisyConverter};

const RENDER_PERIOD_NS: u64 = 10_000_000;

fn rendered_frames() -> Option<(u16, u16, Vec<Vec<u8>>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/frames");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    paths.sort();
    let images: Vec<_> = paths
        .iter()
        .map(|p| event_camera::picture::decode_png(&std::fs::read(p).ok()?).ok())
        .collect::<Option<_>>()?;
    let first = images.first()?;
    let (w, h) = (first.width() as u16, first.height() as u16);
    Some((
        w,
        h,
        images.into_iter().map(image::RgbImage::into_raw).collect(),
    ))
}

fn synthetic_frames(count: u64) -> (u16, u16, Vec<Vec<u8>>) {
    let scene = MovingBlobScene::new(640, 480);
    (
        640,
        480,
        (0..count)
            .map(|k| scene.frame(k * RENDER_PERIOD_NS))
            .collect(),
    )
}

/// Indices 0, 1, …, n−1, n−2, …, 1 repeated: neighbouring frames only.
fn ping_pong(n: usize) -> Vec<usize> {
    (0..n).chain((1..n.saturating_sub(1)).rev()).collect()
}

fn bench_set(c: &mut Criterion, name: &str, (w, h, frames): (u16, u16, Vec<Vec<u8>>)) {
    let order = ping_pong(frames.len());
    let mut group = c.benchmark_group(format!("convert_{name}_{w}x{h}"));
    group.throughput(Throughput::Elements(u64::from(w) * u64::from(h)));

    let mut fast = Converter::new(w, h, DEFAULT_THRESHOLD).unwrap();
    let mut out = Vec::new();
    let (mut stamp_ns, mut k) = (0u64, 0usize);
    fast.push(stamp_ns, &frames[0], &mut out).unwrap();
    let mut events = 0usize;
    let mut pushed = 0usize;
    group.bench_function(BenchmarkId::new("fast", frames.len()), |b| {
        b.iter(|| {
            k = (k + 1) % order.len();
            stamp_ns += RENDER_PERIOD_NS;
            out.clear();
            fast.push(stamp_ns, black_box(&frames[order[k]]), &mut out)
                .unwrap();
            events += out.len();
            pushed += 1;
        })
    });
    println!(
        "  ({name}: {:.1} events per frame on average)",
        events as f64 / pushed.max(1) as f64
    );

    // Scan cost alone: the same frame again and again (no pixel leaves its bounds).
    group.bench_function(BenchmarkId::new("fast_static", 1), |b| {
        b.iter(|| {
            stamp_ns += RENDER_PERIOD_NS;
            out.clear();
            fast.push(stamp_ns, black_box(&frames[order[k]]), &mut out)
                .unwrap();
            assert!(out.is_empty());
        })
    });

    // Start-up: the first frame computes every pixel's bounds.
    group.sample_size(20);
    group.bench_function(BenchmarkId::new("first_frame", 1), |b| {
        b.iter(|| {
            let mut fresh = Converter::new(w, h, DEFAULT_THRESHOLD).unwrap();
            fresh.push(0, black_box(&frames[0]), &mut out).unwrap();
            fresh
        })
    });

    let mut reference = ReferenceConverter::new(w, h, DEFAULT_THRESHOLD).unwrap();
    let (mut stamp_ns, mut k) = (0u64, 0usize);
    reference.push(stamp_ns, &frames[0]).unwrap();
    group.sample_size(10);
    group.bench_function(BenchmarkId::new("reference", frames.len()), |b| {
        b.iter(|| {
            k = (k + 1) % order.len();
            stamp_ns += RENDER_PERIOD_NS;
            black_box(
                reference
                    .push(stamp_ns, black_box(&frames[order[k]]))
                    .unwrap(),
            );
        })
    });
    group.finish();
}

/// Realistic noise: 3 % threshold mismatch, 1 ms refractory, 0.1 Hz shot noise, 10 hot pixels.
fn bench_noisy(c: &mut Criterion, name: &str, (w, h, frames): &(u16, u16, Vec<Vec<u8>>)) {
    let order = ping_pong(frames.len());
    let mut group = c.benchmark_group(format!("noisy_{name}_{w}x{h}"));
    group.throughput(Throughput::Elements(u64::from(*w) * u64::from(*h)));
    let base = EventNoise {
        threshold_sigma: 0.03,
        refractory_ns: 1_000_000,
        shot_noise_hz: 0.1,
        hot_pixels: 10,
        hot_pixel_hz: 100.0,
        seed: 1,
        ..EventNoise::default()
    };
    let leaky = EventNoise {
        leak_hz: 0.1,
        ..base
    };
    for (label, noise) in [("noisy", base), ("noisy_leak", leaky)] {
        let mut converter = NoisyConverter::new(*w, *h, DEFAULT_THRESHOLD, &noise).unwrap();
        let mut out = Vec::new();
        let (mut stamp_ns, mut k) = (0u64, 0usize);
        converter.push(stamp_ns, &frames[0], &mut out).unwrap();
        group.bench_function(BenchmarkId::new(label, frames.len()), |b| {
            b.iter(|| {
                k = (k + 1) % order.len();
                stamp_ns += RENDER_PERIOD_NS;
                out.clear();
                converter
                    .push(stamp_ns, black_box(&frames[order[k]]), &mut out)
                    .unwrap();
            })
        });
    }
    group.finish();
}

fn convert(c: &mut Criterion) {
    if let Some(rendered) = rendered_frames() {
        bench_noisy(c, "rendered", &rendered);
        bench_set(c, "rendered", rendered);
    } else {
        println!("no rendered fixtures; synthetic frames only");
    }
    let synthetic = synthetic_frames(50);
    bench_noisy(c, "synthetic", &synthetic);
    bench_set(c, "synthetic", synthetic);
}

criterion_group!(benches, convert);
criterion_main!(benches);
