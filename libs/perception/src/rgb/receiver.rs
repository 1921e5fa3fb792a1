//! The RGB receiving chain of one observer: its own 25 Hz frames in, tokens and frames out.
//!
//! Per frame: structural checks and continuity (sequence number, `valid`, `continuous`), luma,
//! KLT target tracking ([`TargetTracker`]), then one [`Sample`] for the shared segmenter and
//! frame parser ([`Decoder`] with [`SegmenterConfig::rgb`]: 15 px anchor, 3 s NULL).
//!
//! - A NULL needs the target visible and reliably tracked at every frame of the 3 s rest and a
//!   low robust flow at the confirming frame (paper: "visible, reliable low flow").
//! - A sequence gap, a restart, `continuous == false`, `valid == false`, a malformed frame or a
//!   lost target interrupts: the segmenter emits `Unknown`, the parser drops any incomplete
//!   frame, and the tracker re-acquires. A valid frame that follows a gap is used to re-acquire
//!   but feeds no sample at its own stamp (the interruption holds that stamp).
//! - A black or blank frame has no features: no target, no trajectory, nothing released.

use std::collections::{BTreeMap, VecDeque};

use image::GrayImage;
use proto::{ReleasedFrame, RgbFrame, Token};

use crate::rgb::error::RgbReceiverError;
use crate::rgb::features::FeatureConfig;
use crate::rgb::klt::KltConfig;
use crate::rgb::luma::luma_into;
use crate::rgb::tracker::{RgbTrackerConfig, TargetTracker, TrackEvent, TrackStep};
use proto::decoder::{DecodeStep, Decoder};
use proto::segmenter::{Sample, SegmentToken, SegmenterConfig, TokenCause};

/// Smallest frame the receiver accepts (the pyramid and search region need room).
pub const MIN_FRAME_WIDTH_PX: u16 = 64;
pub const MIN_FRAME_HEIGHT_PX: u16 = 48;

/// Most samples kept for the symbol in progress (60 s at 25 Hz).
const MAX_RECENT_SAMPLES: usize = 1_500;

/// Receiver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbReceiverConfig {
    pub klt: KltConfig,
    pub features: FeatureConfig,
    pub tracker: RgbTrackerConfig,
    pub segmenter: SegmenterConfig,
    /// NULL gate: largest robust displacement at the confirming frame, pixels per frame.
    pub null_max_flow_px: f64,
}

impl RgbReceiverConfig {
    /// The paper's RGB receiver (Table "Receiver settings").
    pub fn paper() -> Self {
        Self {
            klt: KltConfig::paper(),
            features: FeatureConfig::paper(),
            tracker: RgbTrackerConfig::paper(),
            segmenter: SegmenterConfig::rgb(),
            null_max_flow_px: 1.5,
        }
    }

    pub fn validate(&self) -> Result<(), RgbReceiverError> {
        self.klt.validate()?;
        self.features.validate()?;
        self.tracker.validate()?;
        self.segmenter.validate()?;
        if !(self.null_max_flow_px.is_finite() && self.null_max_flow_px > 0.0) {
            return Err(RgbReceiverError::BadConfig(
                "null_max_flow_px must be positive".into(),
            ));
        }
        Ok(())
    }
}

impl Default for RgbReceiverConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// Why a frame was not used at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FrameRejection {
    /// `rgb.len()` is not `3 · width · height`.
    BadSize,
    /// Smaller than [`MIN_FRAME_WIDTH_PX`] × [`MIN_FRAME_HEIGHT_PX`].
    TooSmall,
    /// Stamped at or before the previous frame.
    StampNotIncreasing,
}

/// Why tracking was interrupted. Counted per cause.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RgbInterruptCause {
    Rejected(FrameRejection),
    /// Sequence numbers skipped (frames missing).
    SequenceGap,
    /// The sequence number went backwards (the camera restarted).
    Restart,
    /// The frame is flagged invalid.
    Invalid,
    /// The frame is flagged as not following the previous one.
    NotContinuous,
    /// The tracker lost the target.
    TrackingLost,
    /// Reported by the caller ([`RgbReceiver::interrupt`]): a lost publisher, a fault.
    External,
}

/// One frame of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbTrackStep {
    pub stamp_ns: u64,
    pub seq: u64,
    /// Trajectory point, if a target was held.
    pub point_px: Option<[f64; 2]>,
    pub reliable: bool,
    /// Features carried on the target.
    pub features: usize,
}

/// The trajectory behind one decoded symbol: every frame from the previous NULL confirmation
/// to the one that classified it.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbSymbolTrajectory {
    /// The action token, or `Unknown` for a rejected or overlong path.
    pub token: Token,
    pub cause: TokenCause,
    /// Confirmation stamp of the token.
    pub stamp_ns: u64,
    pub samples: Vec<RgbTrackStep>,
}

/// What one frame did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RgbFrameOutcome {
    /// Tokens confirmed and frames released at this frame.
    pub step: DecodeStep,
    /// Set when the frame was not used at all.
    pub rejected: Option<FrameRejection>,
    /// Set when this frame interrupted tracking.
    pub interruption: Option<RgbInterruptCause>,
    /// The tracker's result, when the frame was tracked.
    pub track: Option<TrackStep>,
}

/// A snapshot of the receiver's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbReceiverStatus {
    /// Trajectory point of the last frame, if a target is held.
    pub point_px: Option<[f64; 2]>,
    pub tracking: bool,
    /// Tokens of the incomplete frame held by the parser.
    pub frame_progress: usize,
    /// Frames seen (accepted or not).
    pub frames_seen: u64,
}

/// One observer's RGB receiving chain.
#[derive(Debug, Clone)]
pub struct RgbReceiver {
    config: RgbReceiverConfig,
    tracker: TargetTracker,
    decoder: Decoder,
    luma: GrayImage,
    last_seq: Option<u64>,
    last_stamp_ns: Option<u64>,
    last_point_px: Option<[f64; 2]>,
    tokens: Vec<SegmentToken>,
    frames: Vec<ReleasedFrame>,
    trajectories: Vec<RgbSymbolTrajectory>,
    recent: VecDeque<RgbTrackStep>,
    interruptions: BTreeMap<RgbInterruptCause, u64>,
    segmenter_errors: u64,
    frames_seen: u64,
    /// How far the airframe has turned from home now, and at the previous frame.
    ego: Option<proto::EgoRotation>,
    ego_at_last_frame: Option<proto::EgoRotation>,
    /// Whether tokens, frames and trajectories are kept for the accessors.
    keeps_history: bool,
}

impl RgbReceiver {
    pub fn new(config: RgbReceiverConfig) -> Result<Self, RgbReceiverError> {
        config.validate()?;
        Ok(Self {
            tracker: TargetTracker::new(config.tracker, config.klt, config.features)?,
            decoder: Decoder::new(config.segmenter)?,
            config,
            luma: GrayImage::new(0, 0),
            last_seq: None,
            last_stamp_ns: None,
            last_point_px: None,
            tokens: Vec::new(),
            frames: Vec::new(),
            trajectories: Vec::new(),
            recent: VecDeque::new(),
            interruptions: BTreeMap::new(),
            segmenter_errors: 0,
            frames_seen: 0,
            ego: None,
            ego_at_last_frame: None,
            keeps_history: true,
        })
    }

    /// The same receiver keeping no history: [`Self::tokens`], [`Self::frames`] and
    /// [`Self::trajectories`] stay empty, while each frame's outcome still carries what it
    /// made (a node's receiver: its memory stays flat however long the session).
    #[must_use]
    pub fn without_history(mut self) -> Self {
        self.keeps_history = false;
        self
    }

    /// The paper's receiver.
    pub fn paper() -> Self {
        Self::new(RgbReceiverConfig::paper()).expect("the paper's settings are valid")
    }

    pub fn config(&self) -> &RgbReceiverConfig {
        &self.config
    }

    /// Every token confirmed so far, in order.
    pub fn tokens(&self) -> &[SegmentToken] {
        &self.tokens
    }

    /// Every frame released so far, in order.
    pub fn frames(&self) -> &[ReleasedFrame] {
        &self.frames
    }

    /// The trajectory of every decoded symbol (action or rejected path), in order.
    pub fn trajectories(&self) -> &[RgbSymbolTrajectory] {
        &self.trajectories
    }

    /// The frames since the last NULL confirmation (the symbol in progress), oldest first;
    /// at most the last 60 s.
    pub fn current_trajectory(&self) -> impl Iterator<Item = &RgbTrackStep> {
        self.recent.iter()
    }

    /// Tracking interruptions per cause (rejections included).
    pub fn interruptions(&self) -> &BTreeMap<RgbInterruptCause, u64> {
        &self.interruptions
    }

    /// Segmenter refusals (stamps out of order); always zero for a correct receiver.
    pub fn segmenter_errors(&self) -> u64 {
        self.segmenter_errors
    }

    /// The tracker (features and target box, for visualisation).
    pub fn tracker(&self) -> &TargetTracker {
        &self.tracker
    }

    pub fn status(&self) -> RgbReceiverStatus {
        RgbReceiverStatus {
            point_px: self.last_point_px,
            tracking: self.tracker.is_tracking(),
            frame_progress: self.decoder.parser().progress(),
            frames_seen: self.frames_seen,
        }
    }

    /// Consumes the next frame of this observer's camera.
    pub fn push_frame(&mut self, frame: &RgbFrame) -> RgbFrameOutcome {
        self.frames_seen += 1;
        let mut out = RgbFrameOutcome::default();
        if let Some(reason) = self.reject(frame) {
            out.rejected = Some(reason);
            // The frame's own stamp is not trusted: interrupt at the last good stamp.
            self.interrupt_at(
                self.last_stamp_ns,
                RgbInterruptCause::Rejected(reason),
                &mut out,
            );
            return out;
        }
        let discontinuity = if !frame.valid {
            Some(RgbInterruptCause::Invalid)
        } else if let Some(previous) = self.last_seq
            && frame.seq != previous.wrapping_add(1)
        {
            Some(if frame.seq > previous {
                RgbInterruptCause::SequenceGap
            } else {
                RgbInterruptCause::Restart
            })
        } else if !frame.continuous {
            Some(RgbInterruptCause::NotContinuous)
        } else {
            None
        };
        self.last_seq = Some(frame.seq);
        self.last_stamp_ns = Some(frame.stamp_ns);
        if let Some(cause) = discontinuity {
            self.interrupt_at(Some(frame.stamp_ns), cause, &mut out);
            if cause == RgbInterruptCause::Invalid {
                self.record(frame, None);
                return out;
            }
            // Re-acquire on this frame; its sample would repeat the interruption's stamp.
            let track = self.track(frame);
            self.record(frame, Some(&track));
            out.track = Some(track);
            return out;
        }
        let track = self.track(frame);
        if matches!(track.event, TrackEvent::Lost(_)) {
            *self
                .interruptions
                .entry(RgbInterruptCause::TrackingLost)
                .or_default() += 1;
            out.interruption = Some(RgbInterruptCause::TrackingLost);
        }
        self.record(frame, Some(&track));
        out.track = Some(track);
        let flow_px = track.flow_px[0].hypot(track.flow_px[1]);
        let sample = Sample {
            stamp_ns: frame.stamp_ns,
            point_px: track.point_px,
            reliable: track.reliable,
            null_allowed: track.reliable && flow_px <= self.config.null_max_flow_px,
        };
        match self.decoder.push(sample) {
            Ok(step) => self.absorb(step, &mut out),
            Err(_) => self.segmenter_errors += 1,
        }
        out
    }

    /// The camera stream is known to be missing at `stamp_ns` (publisher gone, grace period
    /// over, a fault): drops the target and any incomplete frame.
    pub fn interrupt(&mut self, stamp_ns: u64) -> RgbFrameOutcome {
        let mut out = RgbFrameOutcome::default();
        let stamp_ns = self
            .last_stamp_ns
            .map_or(stamp_ns, |last| stamp_ns.max(last));
        self.last_stamp_ns = Some(stamp_ns);
        self.interrupt_at(Some(stamp_ns), RgbInterruptCause::External, &mut out);
        out
    }

    /// How far the observer's airframe has turned from its home attitude (its attitude
    /// estimate), undone on the target's track from the next sample on
    /// ([`proto::stabilise`]).
    pub fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>) {
        self.ego = ego;
        self.decoder.set_ego_rotation(ego);
    }

    /// The check the session's frames carry ([`Decoder::set_frame_check`]).
    pub fn set_frame_check(&mut self, check: proto::FrameCheck) {
        self.decoder.set_frame_check(check);
    }

    /// A new round or reception window: forgets target, partial frame and stream continuity
    /// (the history of tokens, frames and trajectories is kept).
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.decoder.reset();
        self.last_seq = None;
        self.last_stamp_ns = None;
        self.last_point_px = None;
        self.recent.clear();
    }

    fn reject(&self, frame: &RgbFrame) -> Option<FrameRejection> {
        if frame.width < MIN_FRAME_WIDTH_PX || frame.height < MIN_FRAME_HEIGHT_PX {
            return Some(FrameRejection::TooSmall);
        }
        if frame.rgb.len() != usize::from(frame.width) * usize::from(frame.height) * 3 {
            return Some(FrameRejection::BadSize);
        }
        if self
            .last_stamp_ns
            .is_some_and(|last| frame.stamp_ns <= last)
        {
            return Some(FrameRejection::StampNotIncreasing);
        }
        None
    }

    fn track(&mut self, frame: &RgbFrame) -> TrackStep {
        luma_into(
            &frame.rgb,
            u32::from(frame.width),
            u32::from(frame.height),
            &mut self.luma,
        );
        // The airframe's turn since the previous frame moves every pixel: each feature's
        // search starts where that turn put it.
        let turned = self.ego != self.ego_at_last_frame;
        let track = match (&self.config.segmenter.home_camera, turned) {
            (Some(home), true) => {
                let (from, to) = (self.ego_at_last_frame, self.ego);
                let predict = move |p: [f32; 2]| {
                    // Pixel centres here, pixel corners in the camera model.
                    let q = [f64::from(p[0]) + 0.5, f64::from(p[1]) + 0.5];
                    proto::stabilise::predicted_px(home, from.as_ref(), to.as_ref(), q)
                        .map_or(p, |r| [(r[0] - 0.5) as f32, (r[1] - 0.5) as f32])
                };
                self.tracker.step_predicted(&self.luma, Some(&predict))
            }
            _ => self.tracker.step(&self.luma),
        };
        self.ego_at_last_frame = self.ego;
        self.last_point_px = track.point_px;
        track
    }

    fn interrupt_at(
        &mut self,
        stamp_ns: Option<u64>,
        cause: RgbInterruptCause,
        out: &mut RgbFrameOutcome,
    ) {
        *self.interruptions.entry(cause).or_default() += 1;
        out.interruption = Some(cause);
        self.tracker.reset();
        self.last_point_px = None;
        self.recent.clear();
        let Some(stamp_ns) = stamp_ns else { return };
        match self.decoder.interrupt(stamp_ns) {
            Ok(step) => self.absorb(step, out),
            Err(_) => self.segmenter_errors += 1,
        }
    }

    fn record(&mut self, frame: &RgbFrame, track: Option<&TrackStep>) {
        if self.recent.len() == MAX_RECENT_SAMPLES {
            self.recent.pop_front();
        }
        self.recent.push_back(RgbTrackStep {
            stamp_ns: frame.stamp_ns,
            seq: frame.seq,
            point_px: track.and_then(|t| t.point_px),
            reliable: track.is_some_and(|t| t.reliable),
            features: track.map_or(0, |t| t.features),
        });
    }

    fn absorb(&mut self, step: DecodeStep, out: &mut RgbFrameOutcome) {
        for t in &step.tokens {
            match t.cause {
                TokenCause::Classified(_)
                | TokenCause::Rejected(_)
                | TokenCause::Overlong { .. } => {
                    if !self.keeps_history {
                        continue;
                    }
                    self.trajectories.push(RgbSymbolTrajectory {
                        token: t.token,
                        cause: t.cause,
                        stamp_ns: t.stamp_ns,
                        samples: self.recent.iter().copied().collect(),
                    });
                }
                TokenCause::Rest => self.recent.clear(),
                TokenCause::Interrupted(_) | TokenCause::External => {}
            }
        }
        if self.keeps_history {
            self.tokens.extend(step.tokens.iter().copied());
            self.frames.extend(step.frames.iter().cloned());
        }
        out.step.tokens.extend(step.tokens);
        out.step.frames.extend(step.frames);
    }
}
