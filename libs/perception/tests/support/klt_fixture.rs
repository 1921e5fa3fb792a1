//! The KLT comparison fixture (`tests/fixtures/klt`, recorded by `examples/klt_fixture.rs`):
//! real MuJoCo renders as grey frames, our tracker's points per frame pair, and OpenCV's
//! `calcOpticalFlowPyrLK` results on them (`opencv.json`, written by
//! `bash deploy/opencv-oracle.sh golden`). Shared by `tests/klt_oracle.rs` and
//! `benches/klt.rs`.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use image::GrayImage;
use optical_flow_lk::{TrackParams, TrackStatus, TrackerContext};
use perception::rgb::klt::{Klt, KltConfig};
use serde::Deserialize;

pub fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/klt")
}

#[derive(Debug, Deserialize)]
struct PairJson {
    prev: usize,
    next: usize,
    points_px: Vec<[f32; 2]>,
    probes_px: Vec<[f32; 2]>,
}

#[derive(Debug, Deserialize)]
struct ClipJson {
    observer: String,
    frames: Vec<String>,
    pairs: Vec<PairJson>,
}

#[derive(Debug, Deserialize)]
struct FixtureJson {
    clips: Vec<ClipJson>,
}

/// One frame pair and the points tracked across it.
#[derive(Debug, Clone)]
pub struct Pair {
    pub prev: usize,
    pub next: usize,
    /// Our tracker's features in `prev`: what the receiver tracks.
    pub points_px: Vec<[f32; 2]>,
    /// A grid around the target (flat wall, edges, partial views); not tracked by the receiver.
    pub probes_px: Vec<[f32; 2]>,
}

/// One observer's consecutive frames.
#[derive(Debug, Clone)]
pub struct Clip {
    pub observer: String,
    pub frames: Vec<GrayImage>,
    pub pairs: Vec<Pair>,
}

fn read_grey_png(path: &Path) -> GrayImage {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let decoder = png::Decoder::new(std::io::BufReader::new(file));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Eight),
        "{}: want 8-bit grey",
        path.display()
    );
    buf.truncate(info.buffer_size());
    GrayImage::from_raw(info.width, info.height, buf).unwrap()
}

pub fn load_fixture(dir: &Path) -> Vec<Clip> {
    let text = std::fs::read_to_string(dir.join("fixture.json"))
        .unwrap_or_else(|e| panic!("{}/fixture.json: {e}", dir.display()));
    let json: FixtureJson = serde_json::from_str(&text).unwrap();
    json.clips
        .into_iter()
        .map(|c| Clip {
            observer: c.observer,
            frames: c
                .frames
                .iter()
                .map(|f| read_grey_png(&dir.join(f)))
                .collect(),
            pairs: c
                .pairs
                .into_iter()
                .map(|p| Pair {
                    prev: p.prev,
                    next: p.next,
                    points_px: p.points_px,
                    probes_px: p.probes_px,
                })
                .collect(),
        })
        .collect()
}

#[derive(Debug, Clone, Deserialize)]
pub struct GoldenSettings {
    pub window_px: usize,
    pub max_level: usize,
    pub max_iterations: usize,
    pub epsilon_px: f32,
    pub min_eigen: f32,
    /// `min_eigen` in OpenCV's unit, as passed to `calcOpticalFlowPyrLK`.
    pub opencv_min_eig_threshold: f64,
    pub fb_threshold_px: f32,
}

#[derive(Debug, Clone, Deserialize)]
pub struct GoldenPair {
    pub forward_px: Vec<[f32; 2]>,
    pub forward_ok: Vec<bool>,
    pub fb_ok: Vec<bool>,
    pub probe_forward_px: Vec<[f32; 2]>,
    pub probe_forward_ok: Vec<bool>,
    pub probe_fb_ok: Vec<bool>,
}

/// Which points of each pair to compare.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointSet {
    /// The tracker's features (what the receiver tracks).
    Features,
    /// The probe grid around the target.
    Probes,
}

#[derive(Debug, Clone, Deserialize)]
pub struct GoldenClip {
    pub observer: String,
    pub pairs: Vec<GoldenPair>,
}

/// OpenCV's results on the fixture.
#[derive(Debug, Clone, Deserialize)]
pub struct Golden {
    pub opencv: String,
    pub settings: GoldenSettings,
    pub clips: Vec<GoldenClip>,
}

pub fn load_golden(dir: &Path) -> Golden {
    let text = std::fs::read_to_string(dir.join("opencv.json"))
        .unwrap_or_else(|e| panic!("{}/opencv.json: {e}", dir.display()));
    serde_json::from_str(&text).unwrap()
}

/// The OpenCV settings the golden file was made with, as our configuration.
pub fn config_of(golden: &Golden) -> KltConfig {
    let s = &golden.settings;
    KltConfig {
        window_px: s.window_px,
        pyramid_levels: s.max_level + 1,
        max_iterations: s.max_iterations,
        min_eigen: s.min_eigen,
        fb_threshold_px: s.fb_threshold_px,
    }
}

/// Median, 95th percentile and maximum of a sample (NaN when empty).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub median: f64,
    pub p95: f64,
    pub max: f64,
}

fn spread(mut v: Vec<f64>) -> Spread {
    if v.is_empty() {
        return Spread {
            median: f64::NAN,
            p95: f64::NAN,
            max: f64::NAN,
        };
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    Spread {
        median: at(0.5),
        p95: at(0.95),
        max: v[v.len() - 1],
    }
}

/// Our KLT against OpenCV's on every point of the fixture.
#[derive(Debug, Clone)]
pub struct Comparison {
    pub points: usize,
    /// Forward pass alone (no round trip): both report the point tracked.
    pub forward_both: usize,
    /// Fraction of points whose forward status (tracked or not) agrees.
    pub forward_status_agreement: f64,
    /// Endpoint distance between the two forward results where both track, px.
    pub forward_disagreement_px: Spread,
    /// As the receiver uses it (forward pass plus forward–backward check): both accept.
    pub fb_both: usize,
    pub fb_ours: usize,
    pub fb_opencv: usize,
    /// Fraction of points whose accept/reject verdict agrees.
    pub fb_status_agreement: f64,
    /// Endpoint distance where both accept, px.
    pub fb_disagreement_px: Spread,
    /// Median image motion of the compared points (OpenCV's forward result), px per frame.
    pub motion_px: Spread,
}

fn distance(a: [f32; 2], b: [f32; 2]) -> f64 {
    f64::from(a[0] - b[0]).hypot(f64::from(a[1] - b[1]))
}

pub fn compare(clips: &[Clip], golden: &Golden, set: PointSet) -> Comparison {
    let config = config_of(golden);
    assert_eq!(clips.len(), golden.clips.len(), "fixture and golden differ");
    let params = TrackParams {
        window_size: config.window_px,
        max_iterations: config.max_iterations,
        min_eigen_threshold: config.min_eigen,
    };
    let mut ctx = TrackerContext::new();
    let mut klt = Klt::new(config).unwrap();
    let mut ours_fb = Vec::new();
    let (mut points, mut forward_agree, mut fb_agree) = (0usize, 0usize, 0usize);
    let (mut fb_ours, mut fb_opencv) = (0usize, 0usize);
    let (mut forward_d, mut fb_d, mut motion) = (Vec::new(), Vec::new(), Vec::new());
    for (clip, gclip) in clips.iter().zip(&golden.clips) {
        assert_eq!(clip.observer, gclip.observer);
        assert_eq!(clip.pairs.len(), gclip.pairs.len());
        for (pair, g) in clip.pairs.iter().zip(&gclip.pairs) {
            let (prev, next) = (&clip.frames[pair.prev], &clip.frames[pair.next]);
            let (input, g_forward, g_forward_ok, g_fb_ok) = match set {
                PointSet::Features => (&pair.points_px, &g.forward_px, &g.forward_ok, &g.fb_ok),
                PointSet::Probes => (
                    &pair.probes_px,
                    &g.probe_forward_px,
                    &g.probe_forward_ok,
                    &g.probe_fb_ok,
                ),
            };
            assert_eq!(input.len(), g_forward.len());
            // The receiver's path: the wrapper, forward pass plus round trip.
            klt.advance(prev);
            klt.advance(next);
            klt.track(input, None, &mut ours_fb);
            // The forward pass alone, straight from the crate with the same settings.
            ctx.prepare(prev, next, config.pyramid_levels);
            let pts: Vec<(f32, f32)> = input.iter().map(|p| (p[0], p[1])).collect();
            let forward = ctx.track(&pts, None, params);
            for i in 0..pts.len() {
                points += 1;
                let ocv = g_forward[i];
                let ours_ok = forward[i].status == TrackStatus::Tracked;
                forward_agree += usize::from(ours_ok == g_forward_ok[i]);
                if ours_ok && g_forward_ok[i] {
                    forward_d.push(distance([forward[i].pos.0, forward[i].pos.1], ocv));
                    motion.push(distance(input[i], ocv));
                }
                fb_ours += usize::from(ours_fb[i].is_some());
                fb_opencv += usize::from(g_fb_ok[i]);
                fb_agree += usize::from(ours_fb[i].is_some() == g_fb_ok[i]);
                if let (Some(p), true) = (ours_fb[i], g_fb_ok[i]) {
                    fb_d.push(distance(p, ocv));
                }
            }
        }
    }
    let forward_both = forward_d.len();
    let fb_both = fb_d.len();
    Comparison {
        points,
        forward_both,
        forward_status_agreement: forward_agree as f64 / points as f64,
        forward_disagreement_px: spread(forward_d),
        fb_both,
        fb_ours,
        fb_opencv,
        fb_status_agreement: fb_agree as f64 / points as f64,
        fb_disagreement_px: spread(fb_d),
        motion_px: spread(motion),
    }
}
