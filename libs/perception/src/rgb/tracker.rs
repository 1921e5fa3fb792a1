//! Target acquisition and KLT tracking: from grey frames to a signed image-plane trajectory.
//!
//! - **Acquisition**: Shi–Tomasi features in a central search region (the performer hovers at
//!   the image centre of every observer); the compact cluster around their median is the
//!   target. Its bounding box (plus a margin) is the target box and its centre the first
//!   trajectory point.
//! - **Tracking**: pyramidal LK with a forward–backward check moves every feature into the new
//!   frame; the robust (component-wise median) displacement of the survivors moves the
//!   trajectory point. Features disagreeing with the median by more than `inlier_radius_px` —
//!   static background corners the target passes, occlusion artefacts — are dropped, so the
//!   feature set follows the target alone. The integrated displacement is the target's
//!   image-plane trajectory as the camera saw it; a camera that turns (an observer leaning in
//!   wind) is undone on the trajectory by the segmenter (`proto::stabilise`), and its turn
//!   since the previous frame seeds each feature's search ([`TargetTracker::step_predicted`]),
//!   so the search range is spent on the target's own motion.
//! - **Re-detection**: when fewer than `refill_below` features survive, and at least every
//!   `redetect_period_frames` frames, new ones are detected inside the target box, away from
//!   the survivors. The same detection re-measures the
//!   target's extent and servoes the box centre towards it by at most `recentre_step_px`, so
//!   the box cannot drift off the drone over a long mission. The integrated trajectory drifts
//!   by a few pixels over minutes (measured on our renders: ≤ 5.4 px after 287 s), which the
//!   relative path matching does not mind; it stays purely integrated.
//! - **Loss**: too few surviving or consistent features, or an implausible jump, drop the target
//!   for this frame (no point, unreliable) and acquisition restarts at the next frame. A
//!   blank or black frame has no features, so it never yields a trajectory.

use image::GrayImage;

use crate::rgb::error::RgbReceiverError;
use crate::rgb::features::{FeatureConfig, FeatureDetector, Region};
use crate::rgb::klt::{Klt, KltConfig};

/// Acquisition and tracking settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbTrackerConfig {
    /// Half-size of the central search region, pixels.
    pub search_half_size_px: [f64; 2],
    /// An acquired cluster holds the features within this half-size of their median (the drone
    /// is ≈ 48 × 12 px).
    pub cluster_half_size_px: [f64; 2],
    /// Added around the acquired cluster's bounding box to form the target box, pixels.
    pub box_margin_px: f64,
    /// Fewest clustered features that acquire a target.
    pub min_acquire_features: usize,
    /// Most features tracked at once.
    pub max_features: usize,
    /// Re-detect inside the target box when fewer features survive.
    pub refill_below: usize,
    /// Re-detect (and re-centre the box) at least this often, frames.
    pub redetect_period_frames: u32,
    /// Fewest surviving, mutually consistent features that keep the target.
    pub min_tracked_features: usize,
    /// Fewest consistent features as a fraction of the surviving ones.
    pub min_inlier_fraction: f64,
    /// A feature whose displacement differs from the median by more is an outlier, pixels.
    pub inlier_radius_px: f64,
    /// A larger median displacement between two frames is a tracking failure, pixels.
    pub max_step_px: f64,
    /// Largest correction of the target box centre per re-detection, pixels.
    pub recentre_step_px: f64,
    /// A re-measured target extent within this fraction (+1 px) of the acquired one may
    /// re-centre the box (a different size means background corners joined the cluster).
    pub recentre_size_tolerance: f64,
}

impl RgbTrackerConfig {
    pub fn paper() -> Self {
        Self {
            search_half_size_px: [96.0, 64.0],
            cluster_half_size_px: [40.0, 20.0],
            box_margin_px: 6.0,
            min_acquire_features: 6,
            max_features: 40,
            refill_below: 20,
            redetect_period_frames: 25,
            min_tracked_features: 5,
            min_inlier_fraction: 0.5,
            inlier_radius_px: 1.0,
            max_step_px: 30.0,
            recentre_step_px: 1.0,
            recentre_size_tolerance: 0.25,
        }
    }

    pub fn validate(&self) -> Result<(), RgbReceiverError> {
        let bad = |what: &str| Err(RgbReceiverError::BadConfig(format!("tracker: {what}")));
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !self
            .search_half_size_px
            .iter()
            .chain(&self.cluster_half_size_px)
            .all(|&v| positive(v))
        {
            return bad("search and cluster half-sizes must be positive");
        }
        if !(self.box_margin_px.is_finite() && self.box_margin_px >= 0.0) {
            return bad("box_margin_px must be non-negative");
        }
        if self.min_tracked_features == 0 || self.min_acquire_features < self.min_tracked_features {
            return bad("need 0 < min_tracked_features <= min_acquire_features");
        }
        if self.max_features < self.min_acquire_features || self.refill_below > self.max_features {
            return bad(
                "need min_acquire_features <= max_features and refill_below <= max_features",
            );
        }
        if !(self.min_inlier_fraction.is_finite()
            && (0.0..=1.0).contains(&self.min_inlier_fraction))
        {
            return bad("min_inlier_fraction must be in [0, 1]");
        }
        if !(positive(self.inlier_radius_px) && positive(self.max_step_px)) {
            return bad("inlier_radius_px and max_step_px must be positive");
        }
        if self.redetect_period_frames == 0 {
            return bad("redetect_period_frames must be positive");
        }
        if !(self.recentre_step_px.is_finite() && self.recentre_step_px >= 0.0) {
            return bad("recentre_step_px must be non-negative");
        }
        if !(self.recentre_size_tolerance.is_finite() && self.recentre_size_tolerance >= 0.0) {
            return bad("recentre_size_tolerance must be non-negative");
        }
        Ok(())
    }
}

impl Default for RgbTrackerConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// Why the target was dropped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LossReason {
    /// Fewer features survived the forward–backward check than needed.
    TooFewFeatures { tracked: usize, needed: usize },
    /// The surviving features do not move together.
    Inconsistent { inliers: usize, tracked: usize },
    /// The median displacement is implausibly large.
    Jump { step_px: f64 },
}

/// What the tracker did with one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackEvent {
    /// No target: nothing acquirable in the search region.
    Searching,
    /// A target was acquired in this frame.
    Acquired,
    /// The target was tracked into this frame.
    Tracked,
    /// The target was lost in this frame.
    Lost(LossReason),
}

/// One frame's tracking result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackStep {
    /// Trajectory point (target box centre), pixels, x right, y down.
    pub point_px: Option<[f64; 2]>,
    /// Enough consistent features and the target visible.
    pub reliable: bool,
    /// Features carried into the next frame.
    pub features: usize,
    /// Robust displacement since the previous frame, pixels (zero unless tracked).
    pub flow_px: [f64; 2],
    pub event: TrackEvent,
}

impl TrackStep {
    fn without_target(event: TrackEvent) -> Self {
        Self {
            point_px: None,
            reliable: false,
            features: 0,
            flow_px: [0.0; 2],
            event,
        }
    }
}

/// Single-target KLT tracker for one stationary camera.
#[derive(Debug, Clone)]
pub struct TargetTracker {
    config: RgbTrackerConfig,
    feature_config: FeatureConfig,
    klt: Klt,
    detector: FeatureDetector,
    tracking: bool,
    features: Vec<[f32; 2]>,
    /// Integrated trajectory point.
    position_px: [f64; 2],
    /// Target box centre and half-size (extent + margin).
    box_centre_px: [f64; 2],
    box_half_px: [f64; 2],
    /// Half-size of the acquired feature cluster's bounding box.
    extent_half_px: [f64; 2],
    /// Frames since the last detection.
    frames_since_detection: u32,
    tracked: Vec<Option<[f32; 2]>>,
}

impl TargetTracker {
    pub fn new(
        config: RgbTrackerConfig,
        klt: KltConfig,
        features: FeatureConfig,
    ) -> Result<Self, RgbReceiverError> {
        config.validate()?;
        features.validate()?;
        Ok(Self {
            config,
            feature_config: features,
            klt: Klt::new(klt)?,
            detector: FeatureDetector::new(),
            tracking: false,
            features: Vec::new(),
            position_px: [0.0; 2],
            box_centre_px: [0.0; 2],
            box_half_px: [0.0; 2],
            extent_half_px: [0.0; 2],
            frames_since_detection: 0,
            tracked: Vec::new(),
        })
    }

    pub fn config(&self) -> &RgbTrackerConfig {
        &self.config
    }

    /// True while a target is held.
    pub fn is_tracking(&self) -> bool {
        self.tracking
    }

    /// Features currently tracked (positions in the last frame).
    pub fn features(&self) -> &[[f32; 2]] {
        &self.features
    }

    /// The target box of the last frame, if a target is held.
    pub fn target_box(&self, width: u32, height: u32) -> Option<Region> {
        if !self.tracking {
            return None;
        }
        Region::around(self.box_centre_px, self.box_half_px, width, height)
    }

    /// Target box centre minus trajectory point, pixels: the integrated trajectory's drift as
    /// far as the re-detections can tell.
    pub fn box_offset_px(&self) -> Option<[f64; 2]> {
        self.tracking.then(|| {
            [
                self.box_centre_px[0] - self.position_px[0],
                self.box_centre_px[1] - self.position_px[1],
            ]
        })
    }

    /// Drops the target; the next frame starts a new acquisition (after a gap or fault).
    pub fn reset(&mut self) {
        self.tracking = false;
        self.features.clear();
    }

    /// Consumes the next frame of the stream.
    pub fn step(&mut self, frame: &GrayImage) -> TrackStep {
        self.step_predicted(frame, None)
    }

    /// Consumes the next frame of a camera that moved since the previous one: `predict` maps a
    /// previous-frame pixel to where the camera's own motion put it, and each feature's search
    /// starts there (the target's own motion is still what tracking measures).
    pub fn step_predicted(
        &mut self,
        frame: &GrayImage,
        predict: Option<&dyn Fn([f32; 2]) -> [f32; 2]>,
    ) -> TrackStep {
        self.klt.advance(frame);
        if self.tracking {
            self.track(frame, predict)
        } else {
            self.acquire(frame)
        }
    }

    fn acquire(&mut self, frame: &GrayImage) -> TrackStep {
        let (w, h) = frame.dimensions();
        let centre = [f64::from(w) / 2.0 - 0.5, f64::from(h) / 2.0 - 0.5];
        let Some(region) = Region::around(centre, self.config.search_half_size_px, w, h) else {
            return TrackStep::without_target(TrackEvent::Searching);
        };
        let points: Vec<[f32; 2]> = self
            .detector
            .detect(
                frame,
                region,
                &[],
                self.config.max_features,
                &self.feature_config,
            )
            .iter()
            .map(|f| f.point_px)
            .collect();
        if points.len() < self.config.min_acquire_features {
            return TrackStep::without_target(TrackEvent::Searching);
        }
        let cluster = cluster_around_median(&points, self.config.cluster_half_size_px);
        if cluster.len() < self.config.min_acquire_features {
            return TrackStep::without_target(TrackEvent::Searching);
        }
        let (centre, extent) = bounding_box(&cluster);
        let margin = self.config.box_margin_px;
        self.position_px = centre;
        self.box_centre_px = centre;
        self.extent_half_px = extent;
        self.box_half_px = [extent[0] + margin, extent[1] + margin];
        self.features = cluster;
        self.frames_since_detection = 0;
        self.tracking = true;
        TrackStep {
            point_px: Some(self.position_px),
            reliable: true,
            features: self.features.len(),
            flow_px: [0.0; 2],
            event: TrackEvent::Acquired,
        }
    }

    fn track(
        &mut self,
        frame: &GrayImage,
        predict: Option<&dyn Fn([f32; 2]) -> [f32; 2]>,
    ) -> TrackStep {
        let predicted: Option<Vec<[f32; 2]>> =
            predict.map(|f| self.features.iter().map(|&p| f(p)).collect());
        self.klt
            .track(&self.features, predicted.as_deref(), &mut self.tracked);
        let moved: Vec<([f32; 2], [f32; 2])> = self
            .features
            .iter()
            .zip(&self.tracked)
            .filter_map(|(&old, new)| new.map(|n| (old, n)))
            .collect();
        let needed = self.config.min_tracked_features;
        if moved.len() < needed {
            return self.lose(LossReason::TooFewFeatures {
                tracked: moved.len(),
                needed,
            });
        }
        let d = |&(o, n): &([f32; 2], [f32; 2])| [f64::from(n[0] - o[0]), f64::from(n[1] - o[1])];
        let rough = median2(moved.iter().map(d));
        let r2 = self.config.inlier_radius_px.powi(2);
        let inliers: Vec<([f32; 2], [f32; 2])> = moved
            .iter()
            .copied()
            .filter(|m| {
                let v = d(m);
                (v[0] - rough[0]).powi(2) + (v[1] - rough[1]).powi(2) <= r2
            })
            .collect();
        if inliers.len() < needed
            || (inliers.len() as f64) < self.config.min_inlier_fraction * moved.len() as f64
        {
            return self.lose(LossReason::Inconsistent {
                inliers: inliers.len(),
                tracked: moved.len(),
            });
        }
        let flow = median2(inliers.iter().map(d));
        let step_px = flow[0].hypot(flow[1]);
        if step_px > self.config.max_step_px {
            return self.lose(LossReason::Jump { step_px });
        }
        for (dim, f) in flow.iter().enumerate() {
            self.position_px[dim] += f;
            self.box_centre_px[dim] += f;
        }
        // Keep the survivors that still lie on the target (one margin of slack around its box).
        let slack = [
            self.box_half_px[0] + self.config.box_margin_px,
            self.box_half_px[1] + self.config.box_margin_px,
        ];
        let c = self.box_centre_px;
        self.features.clear();
        self.features.extend(
            inliers
                .iter()
                .map(|&(_, n)| n)
                .filter(|n| within(*n, c, slack)),
        );
        self.frames_since_detection = self.frames_since_detection.saturating_add(1);
        if self.features.len() < self.config.refill_below
            || self.frames_since_detection >= self.config.redetect_period_frames
        {
            self.refill(frame);
        }
        if self.features.len() < needed {
            return self.lose(LossReason::TooFewFeatures {
                tracked: self.features.len(),
                needed,
            });
        }
        TrackStep {
            point_px: Some(self.position_px),
            reliable: true,
            features: self.features.len(),
            flow_px: flow,
            event: TrackEvent::Tracked,
        }
    }

    fn refill(&mut self, frame: &GrayImage) {
        self.frames_since_detection = 0;
        let (w, h) = frame.dimensions();
        // Look one margin beyond the box so that a box lagging the target still sees all of it.
        let m = self.config.box_margin_px;
        let half = [self.box_half_px[0] + m, self.box_half_px[1] + m];
        let Some(region) = Region::around(self.box_centre_px, half, w, h) else {
            return;
        };
        let found: Vec<[f32; 2]> = self
            .detector
            .detect(
                frame,
                region,
                &[],
                2 * self.config.max_features,
                &self.feature_config,
            )
            .iter()
            .map(|f| f.point_px)
            .collect();
        self.recentre(&found);
        let room = self.config.max_features.saturating_sub(self.features.len());
        let min_d2 = f64::from(self.feature_config.min_distance_px).powi(2);
        let (c, b) = (self.box_centre_px, self.box_half_px);
        let fresh: Vec<[f32; 2]> = found
            .into_iter()
            .filter(|p| within(*p, c, b))
            .filter(|p| {
                self.features.iter().all(|q| {
                    let (dx, dy) = (f64::from(p[0] - q[0]), f64::from(p[1] - q[1]));
                    dx * dx + dy * dy >= min_d2
                })
            })
            .take(room)
            .collect();
        self.features.extend(fresh);
    }

    /// Servoes the box centre towards the centre of the re-measured target extent, when that
    /// extent has the acquired size.
    fn recentre(&mut self, found: &[[f32; 2]]) {
        if found.len() < self.config.min_acquire_features {
            return;
        }
        let cluster = cluster_around_median(found, self.config.cluster_half_size_px);
        if cluster.len() < self.config.min_acquire_features {
            return;
        }
        let (centre, extent) = bounding_box(&cluster);
        let tol = self.config.recentre_size_tolerance;
        let same_size = (0..2).all(|d| {
            (extent[d] - self.extent_half_px[d]).abs() <= tol * self.extent_half_px[d] + 1.0
        });
        if !same_size {
            return;
        }
        let step = self.config.recentre_step_px;
        for d in 0..2 {
            self.box_centre_px[d] += (centre[d] - self.box_centre_px[d]).clamp(-step, step);
        }
    }

    fn lose(&mut self, why: LossReason) -> TrackStep {
        self.reset();
        TrackStep::without_target(TrackEvent::Lost(why))
    }
}

/// True when `p` lies within `half` (per axis) of `centre`.
fn within(p: [f32; 2], centre: [f64; 2], half: [f64; 2]) -> bool {
    (f64::from(p[0]) - centre[0]).abs() <= half[0] && (f64::from(p[1]) - centre[1]).abs() <= half[1]
}

/// The points within `half` (per axis) of the points' component-wise median.
fn cluster_around_median(points: &[[f32; 2]], half: [f64; 2]) -> Vec<[f32; 2]> {
    let m = median2(points.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]));
    points
        .iter()
        .copied()
        .filter(|p| within(*p, m, half))
        .collect()
}

/// Centre and half-size of the bounding box of a non-empty point set.
fn bounding_box(points: &[[f32; 2]]) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for d in 0..2 {
            lo[d] = lo[d].min(f64::from(p[d]));
            hi[d] = hi[d].max(f64::from(p[d]));
        }
    }
    (
        [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
        [(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0],
    )
}

/// Median of a sequence (mean of the middle pair for even lengths); 0 when empty.
fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// Component-wise median of 2-D vectors.
fn median2(values: impl Iterator<Item = [f64; 2]> + Clone) -> [f64; 2] {
    [
        median(values.clone().map(|v| v[0])),
        median(values.map(|v| v[1])),
    ]
}
