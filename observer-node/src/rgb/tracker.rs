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
//!   feature set follows the target alone. The camera is stationary: the integrated
//!   displacement *is* the target's image-plane trajectory (no ego-motion compensation).
//! - **Re-detection**: when fewer than `refill_below` features survive, new ones are detected
//!   inside the target box, away from the survivors.
//! - **Loss**: too few surviving or consistent features, or an implausible jump, drop the target
//!   for this frame (no point, unreliable) and acquisition restarts at the next frame. A
//!   blank or black frame has no features, so it never yields a trajectory.

use image::GrayImage;

use crate::rgb::error::RgbReceiverError;
use crate::rgb::features::{FeatureConfig, FeatureDetector, Region};
use crate::rgb::klt::{Klt, KltConfig};

/// Acquisition and tracking settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerConfig {
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
    /// Fewest surviving, mutually consistent features that keep the target.
    pub min_tracked_features: usize,
    /// Fewest consistent features as a fraction of the surviving ones.
    pub min_inlier_fraction: f64,
    /// A feature whose displacement differs from the median by more is an outlier, pixels.
    pub inlier_radius_px: f64,
    /// A larger median displacement between two frames is a tracking failure, pixels.
    pub max_step_px: f64,
}

impl TrackerConfig {
    pub fn paper() -> Self {
        Self {
            search_half_size_px: [96.0, 64.0],
            cluster_half_size_px: [40.0, 20.0],
            box_margin_px: 6.0,
            min_acquire_features: 6,
            max_features: 40,
            refill_below: 20,
            min_tracked_features: 5,
            min_inlier_fraction: 0.5,
            inlier_radius_px: 1.0,
            max_step_px: 30.0,
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
        Ok(())
    }
}

impl Default for TrackerConfig {
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
    config: TrackerConfig,
    feature_config: FeatureConfig,
    klt: Klt,
    detector: FeatureDetector,
    tracking: bool,
    features: Vec<[f32; 2]>,
    position_px: [f64; 2],
    box_half_px: [f64; 2],
    tracked: Vec<Option<[f32; 2]>>,
}

impl TargetTracker {
    pub fn new(
        config: TrackerConfig,
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
            box_half_px: [0.0; 2],
            tracked: Vec::new(),
        })
    }

    pub fn config(&self) -> &TrackerConfig {
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
        Region::around(self.position_px, self.box_half_px, width, height)
    }

    /// Drops the target; the next frame starts a new acquisition (after a gap or fault).
    pub fn reset(&mut self) {
        self.tracking = false;
        self.features.clear();
    }

    /// Consumes the next frame of the stream.
    pub fn step(&mut self, frame: &GrayImage) -> TrackStep {
        self.klt.advance(frame);
        if self.tracking {
            self.track(frame)
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
        let found = self.detector.detect(
            frame,
            region,
            &[],
            self.config.max_features,
            &self.feature_config,
        );
        if found.len() < self.config.min_acquire_features {
            return TrackStep::without_target(TrackEvent::Searching);
        }
        let points: Vec<[f32; 2]> = found.iter().map(|f| f.point_px).collect();
        let m = [
            median(points.iter().map(|p| f64::from(p[0]))),
            median(points.iter().map(|p| f64::from(p[1]))),
        ];
        let half = self.config.cluster_half_size_px;
        let cluster: Vec<[f32; 2]> = points
            .into_iter()
            .filter(|p| {
                (f64::from(p[0]) - m[0]).abs() <= half[0]
                    && (f64::from(p[1]) - m[1]).abs() <= half[1]
            })
            .collect();
        if cluster.len() < self.config.min_acquire_features {
            return TrackStep::without_target(TrackEvent::Searching);
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &cluster {
            for d in 0..2 {
                lo[d] = lo[d].min(f64::from(p[d]));
                hi[d] = hi[d].max(f64::from(p[d]));
            }
        }
        let margin = self.config.box_margin_px;
        self.position_px = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        self.box_half_px = [
            (hi[0] - lo[0]) / 2.0 + margin,
            (hi[1] - lo[1]) / 2.0 + margin,
        ];
        self.features = cluster;
        self.tracking = true;
        TrackStep {
            point_px: Some(self.position_px),
            reliable: true,
            features: self.features.len(),
            flow_px: [0.0; 2],
            event: TrackEvent::Acquired,
        }
    }

    fn track(&mut self, frame: &GrayImage) -> TrackStep {
        self.klt.track(&self.features, &mut self.tracked);
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
        self.position_px = [self.position_px[0] + flow[0], self.position_px[1] + flow[1]];
        // Keep the survivors that still lie on the target (one margin of slack around its box).
        let (p, b, m) = (
            self.position_px,
            self.box_half_px,
            self.config.box_margin_px,
        );
        self.features.clear();
        self.features
            .extend(inliers.iter().map(|&(_, n)| n).filter(|n| {
                (f64::from(n[0]) - p[0]).abs() <= b[0] + m
                    && (f64::from(n[1]) - p[1]).abs() <= b[1] + m
            }));
        if self.features.len() < self.config.refill_below {
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
        let (w, h) = frame.dimensions();
        let Some(region) = Region::around(self.position_px, self.box_half_px, w, h) else {
            return;
        };
        let room = self.config.max_features.saturating_sub(self.features.len());
        let fresh = self
            .detector
            .detect(frame, region, &self.features, room, &self.feature_config);
        self.features.extend(fresh.iter().map(|f| f.point_px));
    }

    fn lose(&mut self, why: LossReason) -> TrackStep {
        self.reset();
        TrackStep::without_target(TrackEvent::Lost(why))
    }
}

/// Median of a non-empty sequence (mean of the middle pair for even lengths); 0 when empty.
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
