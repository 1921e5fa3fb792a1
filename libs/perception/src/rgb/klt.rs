//! Pyramidal Lucas–Kanade tracking with a forward–backward check.
//!
//! A thin wrapper around the pure-Rust `optical-flow-lk` crate, adopted after comparing it with
//! OpenCV's `calcOpticalFlowPyrLK` (opencv-python-headless 5.0, a test oracle only) on our own
//! MuJoCo renders and our tracker's own points, with the same window, levels, iteration cap,
//! epsilon and eigenvalue threshold (`tests/klt_oracle.rs`, `benches/klt.rs`,
//! `docs/decisions/rgb-klt.md`): on 2 578 points moving a median 2.9 px per frame the endpoints
//! differ by a median of 0.0011 px (95th percentile 0.0048, maximum 0.0072), every status and
//! round-trip verdict agrees, and it tracks a frame pair in about 0.7 times OpenCV's time on one
//! thread, so we did not write our own. Both use Scharr gradients, bilinear window sampling and
//! 14-bit fixed-point window weights; the pyramids differ (2×2 means here, a 5×5 Gaussian in
//! OpenCV), which the full-resolution refinement absorbs.

use image::GrayImage;
use optical_flow_lk::{TrackParams, TrackStatus, TrackerContext};

use crate::rgb::error::RgbReceiverError;

/// Lucas–Kanade settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KltConfig {
    /// Side of the square integration window, pixels (odd).
    pub window_px: usize,
    /// Pyramid levels including full resolution (OpenCV's `maxLevel + 1`).
    pub pyramid_levels: usize,
    /// Iteration cap per pyramid level.
    pub max_iterations: usize,
    /// Windows flatter than this mean minimum gradient eigenvalue ((grey level / px)²) are not
    /// tracked.
    pub min_eigen: f32,
    /// A point must return within this distance of its start when tracked back, pixels.
    pub fb_threshold_px: f32,
}

impl KltConfig {
    /// 21 px window and 3 levels: the drone is ≈ 48 × 12 px and moves ≤ 6 px per 40 ms frame,
    /// well inside the ≈ 40 px capture range of three levels.
    pub fn paper() -> Self {
        Self {
            window_px: 21,
            pyramid_levels: 3,
            max_iterations: 30,
            min_eigen: optical_flow_lk::DEFAULT_MIN_EIGEN_THRESHOLD,
            fb_threshold_px: 0.7,
        }
    }

    pub fn validate(&self) -> Result<(), RgbReceiverError> {
        let bad = |what: &str| Err(RgbReceiverError::BadConfig(format!("klt: {what}")));
        if self.window_px < 3 || self.window_px.is_multiple_of(2) || self.window_px > 127 {
            return bad("window_px must be odd and in 3..=127");
        }
        if !(1..=6).contains(&self.pyramid_levels) {
            return bad("pyramid_levels must be in 1..=6");
        }
        if self.max_iterations == 0 {
            return bad("max_iterations must be positive");
        }
        if !(self.min_eigen.is_finite() && self.min_eigen > 0.0) {
            return bad("min_eigen must be finite and positive");
        }
        if !(self.fb_threshold_px.is_finite() && self.fb_threshold_px > 0.0) {
            return bad("fb_threshold_px must be finite and positive");
        }
        Ok(())
    }
}

impl Default for KltConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// Frame-to-frame point tracker. [`Klt::advance`] with each new frame, then [`Klt::track`]
/// points of the previous frame into it.
pub struct Klt {
    config: KltConfig,
    ctx: TrackerContext,
    points: Vec<(f32, f32)>,
    predicted: Vec<(f32, f32)>,
}

impl std::fmt::Debug for Klt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Klt")
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl Clone for Klt {
    /// The clone starts without a previous frame (pyramids are scratch state).
    fn clone(&self) -> Self {
        Self {
            config: self.config,
            ctx: TrackerContext::new(),
            points: Vec::new(),
            predicted: Vec::new(),
        }
    }
}

impl Klt {
    pub fn new(config: KltConfig) -> Result<Self, RgbReceiverError> {
        config.validate()?;
        Ok(Self {
            config,
            ctx: TrackerContext::new(),
            points: Vec::new(),
            predicted: Vec::new(),
        })
    }

    pub fn config(&self) -> &KltConfig {
        &self.config
    }

    /// Makes `frame` the current frame; the previous current frame becomes the one points are
    /// tracked from. On the first call (or after a size change) both are `frame`.
    pub fn advance(&mut self, frame: &GrayImage) {
        self.ctx.advance(frame, self.config.pyramid_levels);
    }

    /// Tracks `points` (previous-frame pixel coordinates, origin at the centre of the top-left
    /// pixel) into the current frame. `out[i]` is the new position of point `i`, or `None` when
    /// it left the image, found no texture, did not converge or failed the forward–backward
    /// round trip.
    /// `predicted[i]`, when given, is where the search for point `i` starts (e.g. where the
    /// camera's own turn moved it); otherwise it starts where the point was.
    pub fn track(
        &mut self,
        points: &[[f32; 2]],
        predicted: Option<&[[f32; 2]]>,
        out: &mut Vec<Option<[f32; 2]>>,
    ) {
        out.clear();
        self.points.clear();
        self.points.extend(points.iter().map(|p| (p[0], p[1])));
        self.predicted.clear();
        if let Some(predicted) = predicted {
            self.predicted
                .extend(predicted.iter().map(|p| (p[0], p[1])));
        }
        let params = TrackParams {
            window_size: self.config.window_px,
            max_iterations: self.config.max_iterations,
            min_eigen_threshold: self.config.min_eigen,
        };
        let results = self.ctx.track_fb(
            &self.points,
            predicted.map(|_| self.predicted.as_slice()),
            params,
            self.config.fb_threshold_px,
        );
        out.extend(results.iter().map(|r| {
            (r.status == TrackStatus::Tracked && r.pos.0.is_finite() && r.pos.1.is_finite())
                .then_some([r.pos.0, r.pos.1])
        }));
    }
}
