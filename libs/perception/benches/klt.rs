//! Our KLT against OpenCV's `calcOpticalFlowPyrLK`, and the whole RGB receiver, on real
//! rendered frames (the fixture of `tests/fixtures/klt`: 3 observers × 40 consecutive MuJoCo
//! renders of the START stroke, 117 frame pairs, 2 578 of our tracker's own points).
//!
//! Run: `bash deploy/opencv-oracle.sh && cargo bench -p perception --bench klt`.
//!
//! First a summary, all in one run: the agreement with OpenCV (from the golden file the oracle
//! wrote, `tests/fixtures/klt/opencv.json`), then our time per frame pair and OpenCV's on the
//! same frames, points and settings, one thread each, measured the same way (median over passes
//! of the whole fixture), and their ratio. OpenCV is timed by `benches/opencv_oracle.py` in the
//! venv of `deploy/opencv-oracle.sh` (or the interpreter in `WAGGLE_OPENCV_PYTHON`); without it
//! the summary says so and shows ours alone. Then criterion benchmarks:
//! * `klt/fb_pair` — both pyramids, forward pass and forward–backward round trip of one pair
//!   (`prepare` + `track_fb`; OpenCV's counterpart in the summary is two `calcOpticalFlowPyrLK`
//!   calls, and as its Python API takes images only, the second rebuilds both pyramids);
//! * `klt/forward_pair` — both pyramids and the forward pass only (one OpenCV call: the
//!   like-for-like comparison);
//! * `klt/receiver_step` — the receiver's steady state: one new pyramid per frame
//!   (`Klt::advance`) and the tracked points' forward pass plus round trip (`Klt::track`);
//! * `rgb_receiver/frame` — the whole receiver per 640×480 RGB frame: luma, features, KLT,
//!   tracker bookkeeping and the segmenter (`RgbReceiver::push_frame`).
//!
//! Criterion times are per frame pair (`klt/*_pair`, the fixture's middle pair) or per frame
//! (`klt/receiver_step`, `rgb_receiver/frame`). The machine is shared, so the summary times ours
//! before and after OpenCV and reports the better of the two, and prints medians and minima.

#[path = "../tests/support/klt_fixture.rs"]
mod klt_fixture;

use std::hint::black_box;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use image::GrayImage;
use klt_fixture::{Clip, Golden, PointSet};
use optical_flow_lk::{TrackParams, TrackerContext};
use perception::rgb::klt::{Klt, KltConfig};
use perception::rgb::{RgbReceiver, RgbReceiverConfig};
use proto::RgbFrame;

/// Passes over the whole fixture for the summary's medians (each pass ≈ 117 pairs).
const SUMMARY_PASSES: usize = 15;

struct Work<'a> {
    prev: &'a GrayImage,
    next: &'a GrayImage,
    points: Vec<(f32, f32)>,
}

fn work(clips: &[Clip]) -> Vec<Work<'_>> {
    clips
        .iter()
        .flat_map(|c| {
            c.pairs.iter().map(|p| Work {
                prev: &c.frames[p.prev],
                next: &c.frames[p.next],
                points: p.points_px.iter().map(|q| (q[0], q[1])).collect(),
            })
        })
        .collect()
}

fn params(config: &KltConfig) -> TrackParams {
    TrackParams {
        window_size: config.window_px,
        max_iterations: config.max_iterations,
        min_eigen_threshold: config.min_eigen,
    }
}

/// Both pyramids, forward pass and round trip of every pair.
fn fb_pass(ctx: &mut TrackerContext, work: &[Work<'_>], config: &KltConfig) -> usize {
    let mut n = 0;
    for w in work {
        ctx.prepare(w.prev, w.next, config.pyramid_levels);
        n += ctx
            .track_fb(&w.points, None, params(config), config.fb_threshold_px)
            .len();
    }
    n
}

fn forward_pass(ctx: &mut TrackerContext, work: &[Work<'_>], config: &KltConfig) -> usize {
    let mut n = 0;
    for w in work {
        ctx.prepare(w.prev, w.next, config.pyramid_levels);
        n += ctx.track(&w.points, None, params(config)).len();
    }
    n
}

/// Median and minimum of `passes` timings of `f`, per unit of `units` per pass, ms.
fn time_ms(passes: usize, units: usize, mut f: impl FnMut()) -> (f64, f64) {
    f();
    let mut t: Vec<f64> = (0..passes)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3 / units as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

fn opencv_python() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("WAGGLE_OPENCV_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../third_party/opencv-oracle/venv/bin/python");
    p.exists().then_some(p)
}

/// OpenCV's per-pair times from the oracle, ms: (median, minimum) over passes.
struct OpencvTimes {
    version: String,
    forward: (f64, f64),
    fb_two_calls: (f64, f64),
}

fn opencv_times() -> Result<OpencvTimes, String> {
    let python = opencv_python().ok_or(
        "OpenCV oracle not set up (bash deploy/opencv-oracle.sh, or set WAGGLE_OPENCV_PYTHON)",
    )?;
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("benches/opencv_oracle.py");
    let out = Command::new(&python)
        .arg(script)
        .arg(klt_fixture::fixture_dir())
        .args(["time", "--reps", &SUMMARY_PASSES.to_string()])
        .output()
        .map_err(|e| format!("running {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "OpenCV oracle failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("OpenCV oracle output: {e}"))?;
    let get = |k: &str| -> Result<(f64, f64), String> {
        match (v[k]["median_ms"].as_f64(), v[k]["min_ms"].as_f64()) {
            (Some(m), Some(lo)) => Ok((m, lo)),
            _ => Err(format!("OpenCV oracle output lacks {k}")),
        }
    };
    Ok(OpencvTimes {
        version: v["opencv"].as_str().unwrap_or("?").to_string(),
        forward: get("forward_pair")?,
        fb_two_calls: get("fb_pair")?,
    })
}

/// The clips as RGB frames (grey in all three channels: our luma of it is the grey value
/// exactly, as the weights sum to 2^15).
fn rgb_frames(clip: &Clip) -> Vec<RgbFrame> {
    clip.frames
        .iter()
        .enumerate()
        .map(|(k, g)| RgbFrame {
            seq: k as u64,
            stamp_ns: (k as u64 + 1) * 40_000_000,
            width: g.width() as u16,
            height: g.height() as u16,
            valid: true,
            continuous: true,
            rgb: g.as_raw().iter().flat_map(|&v| [v, v, v]).collect(),
        })
        .collect()
}

fn receiver_pass(clips: &[Vec<RgbFrame>]) -> usize {
    let mut tracked = 0;
    for frames in clips {
        let mut rx = RgbReceiver::new(RgbReceiverConfig::paper()).expect("paper settings");
        for f in frames {
            tracked += usize::from(rx.push_frame(f).track.is_some_and(|t| t.reliable));
        }
    }
    tracked
}

fn summary(clips: &[Clip], golden: &Golden) {
    let config = klt_fixture::config_of(golden);
    let c = klt_fixture::compare(clips, golden, PointSet::Features);
    let probes = klt_fixture::compare(clips, golden, PointSet::Probes);
    let work = work(clips);
    println!(
        "KLT vs OpenCV {} on {} rendered frame pairs, {} points (median motion {:.2} px/frame, \
         95th percentile {:.2}); window {} px, {} levels, ≤ {} iterations, eps 0.01 px, \
         min eigenvalue {}, round trip ≤ {} px",
        golden.opencv,
        work.len(),
        c.points,
        c.motion_px.median,
        c.motion_px.p95,
        config.window_px,
        config.pyramid_levels,
        config.max_iterations,
        config.min_eigen,
        config.fb_threshold_px
    );
    println!(
        "  forward pass: status agrees on {:.2}% of points; endpoint disagreement median \
         {:.4} px, 95th percentile {:.4} px, max {:.4} px ({} points tracked by both)",
        c.forward_status_agreement * 100.0,
        c.forward_disagreement_px.median,
        c.forward_disagreement_px.p95,
        c.forward_disagreement_px.max,
        c.forward_both
    );
    println!(
        "  with the round trip: accept/reject agrees on {:.2}% (ours {}, OpenCV {} accepted); \
         median {:.4} px, 95th percentile {:.4} px, max {:.4} px",
        c.fb_status_agreement * 100.0,
        c.fb_ours,
        c.fb_opencv,
        c.fb_disagreement_px.median,
        c.fb_disagreement_px.p95,
        c.fb_disagreement_px.max
    );
    println!(
        "  probes (a 5 × 3 grid over the target and 8 px around it, {} points: flat wall, \
         edges, partial views): forward status agrees on {:.2}% ({} tracked by both: median \
         {:.4} px, 95th percentile {:.4} px, max {:.4} px); round-trip verdict agrees on {:.2}% \
         (ours {}, OpenCV {} accepted)",
        probes.points,
        probes.forward_status_agreement * 100.0,
        probes.forward_both,
        probes.forward_disagreement_px.median,
        probes.forward_disagreement_px.p95,
        probes.forward_disagreement_px.max,
        probes.fb_status_agreement * 100.0,
        probes.fb_ours,
        probes.fb_opencv
    );

    let mut ctx = TrackerContext::new();
    let mut ours = || {
        let fwd = time_ms(SUMMARY_PASSES, work.len(), || {
            black_box(forward_pass(&mut ctx, &work, &config));
        });
        let fb = time_ms(SUMMARY_PASSES, work.len(), || {
            black_box(fb_pass(&mut ctx, &work, &config));
        });
        (fwd, fb)
    };
    // Ours before and after OpenCV (the machine is shared): the better of the two is reported.
    let before = ours();
    let opencv = opencv_times();
    let after = ours();
    let best = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.min(b.1));
    let (ours_fwd, ours_fb) = (best(before.0, after.0), best(before.1, after.1));
    let rgb: Vec<Vec<RgbFrame>> = clips.iter().map(rgb_frames).collect();
    let frames: usize = rgb.iter().map(Vec::len).sum();
    let receiver = time_ms(5, frames, || {
        black_box(receiver_pass(&rgb));
    });
    println!(
        "  ours, one thread, ms per pair (median / min of {SUMMARY_PASSES} passes): forward \
         {:.3} / {:.3}; with round trip {:.3} / {:.3}",
        ours_fwd.0, ours_fwd.1, ours_fb.0, ours_fb.1
    );
    match opencv {
        Ok(o) => {
            println!(
                "  OpenCV {}, one thread, ms per pair (median / min): forward {:.3} / {:.3}; \
                 with round trip (a second call, which rebuilds both pyramids) {:.3} / {:.3}",
                o.version, o.forward.0, o.forward.1, o.fb_two_calls.0, o.fb_two_calls.1
            );
            println!(
                "  ours / OpenCV, forward pass (like for like): {:.2} by medians, {:.2} by \
                 minima; with round trip: {:.2} / {:.2}",
                ours_fwd.0 / o.forward.0,
                ours_fwd.1 / o.forward.1,
                ours_fb.0 / o.fb_two_calls.0,
                ours_fb.1 / o.fb_two_calls.1
            );
        }
        Err(why) => println!("  OpenCV timing skipped: {why}"),
    }
    println!(
        "  whole RGB receiver (luma, features, KLT, tracker, segmenter) on the {frames} fixture \
         frames: {:.3} ms per frame median, {:.3} min",
        receiver.0, receiver.1
    );
}

fn benches(c: &mut Criterion) {
    let dir = klt_fixture::fixture_dir();
    let clips = klt_fixture::load_fixture(&dir);
    let golden = klt_fixture::load_golden(&dir);
    summary(&clips, &golden);

    let config = klt_fixture::config_of(&golden);
    let work = work(&clips);
    let mut g = c.benchmark_group("klt");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let mut ctx = TrackerContext::new();
    let w = &work[work.len() / 2];
    g.bench_function("fb_pair", |b| {
        b.iter(|| {
            ctx.prepare(w.prev, w.next, config.pyramid_levels);
            black_box(
                ctx.track_fb(&w.points, None, params(&config), config.fb_threshold_px)
                    .len(),
            )
        })
    });
    g.bench_function("forward_pair", |b| {
        b.iter(|| {
            ctx.prepare(w.prev, w.next, config.pyramid_levels);
            black_box(ctx.track(&w.points, None, params(&config)).len())
        })
    });
    // Steady state of the receiver: alternate the two frames of the pair, one pyramid per step.
    let mut klt = Klt::new(config).expect("golden settings");
    let points: Vec<[f32; 2]> = w.points.iter().map(|p| [p.0, p.1]).collect();
    let mut out = Vec::new();
    let mut flip = false;
    klt.advance(w.prev);
    g.bench_function("receiver_step", |b| {
        b.iter(|| {
            flip = !flip;
            klt.advance(if flip { w.next } else { w.prev });
            klt.track(&points, None, &mut out);
            black_box(out.len())
        })
    });
    g.finish();

    let frames = rgb_frames(&clips[1]);
    let mut g = c.benchmark_group("rgb_receiver");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let mut rx = RgbReceiver::new(RgbReceiverConfig::paper()).expect("paper settings");
    for f in &frames[..frames.len() / 2] {
        rx.push_frame(f);
    }
    // Replays the clip's second half forwards then backwards (continuous motion), renumbered so
    // the stream stays gap-free.
    let cycle: Vec<&RgbFrame> = frames[frames.len() / 2..]
        .iter()
        .chain(frames[frames.len() / 2..].iter().rev())
        .collect();
    let mut k = frames.len() / 2;
    let mut next = frames[0].clone();
    g.bench_function("frame", |b| {
        b.iter(|| {
            let src = cycle[k % cycle.len()];
            next.rgb.copy_from_slice(&src.rgb);
            next.seq = k as u64;
            next.stamp_ns = (k as u64 + 1) * 40_000_000;
            k += 1;
            black_box(rx.push_frame(&next).track)
        })
    });
    g.finish();
}

criterion_group!(klt, benches);
criterion_main!(klt);
