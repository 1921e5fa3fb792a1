//! One observer's perception, whichever sensor it carries: its own RGB frames or its own event
//! packets in, tokens and released frames out. This is all an observer process is allowed to
//! see of the world.
//!
//! A third kind of input, [`SensorInput::Track`], is a sensor that already delivers the
//! target's image position: the evaluation's ideal baseline (ground truth projected into the
//! camera, `evaluation::ideal_receiver`) feeds it, so the baseline runs through the very
//! segmenter, parser and observer loop the real receivers do. No observer process builds one.

use proto::scene::ObserverCamera;
use proto::{
    Decoder, EventPacket, Rectification, RgbFrame, Sample, SegmenterConfig, SegmenterError,
};

use crate::events::{EventReceiver, EventReceiverConfig, EventReceiverError};
use crate::rgb::{RgbReceiver, RgbReceiverConfig, RgbReceiverError};
use proto::decoder::DecodeStep;

use proto::Modality;

/// One input from the observer's own sensor.
#[derive(Debug, Clone, Copy)]
pub enum SensorInput<'a> {
    Rgb(&'a RgbFrame),
    Events(&'a EventPacket),
    /// The target's image position as already tracked (the ideal baseline's input).
    Track(&'a Sample),
}

impl SensorInput<'_> {
    /// The input's kind, for errors.
    pub fn kind(&self) -> &'static str {
        match self {
            SensorInput::Rgb(_) => "rgb",
            SensorInput::Events(_) => "events",
            SensorInput::Track(_) => "track",
        }
    }

    /// False when the sensor marked the input as not to be trusted.
    pub fn valid(&self) -> bool {
        match self {
            SensorInput::Rgb(f) => f.valid,
            SensorInput::Events(e) => e.valid,
            SensorInput::Track(_) => true,
        }
    }
}

/// Why perception could not be built or fed.
#[derive(Debug, thiserror::Error)]
pub enum PerceptionError {
    #[error("a {got} input reached a {expected} receiver")]
    WrongSensor {
        expected: &'static str,
        got: &'static str,
    },
    #[error(transparent)]
    Rgb(#[from] RgbReceiverError),
    #[error(transparent)]
    Events(#[from] EventReceiverError),
    #[error(transparent)]
    Segmenter(#[from] SegmenterError),
}

/// What an observer's runtime needs of a receiving chain: Waggle's own [`Perception`], or a
/// receiver that lives elsewhere (a Python plug-in in a worker process, `receiver-plugin`).
/// The runtime feeds it exactly as it feeds Waggle's receivers, so a plug-in meets the same
/// windows, interruptions and resets.
pub trait Receiving: std::fmt::Debug {
    /// Feeds the next input of this observer's sensor; the step and the image-plane estimate of
    /// the target for this input (`None` when the receiver has none).
    fn push_tracked(
        &mut self,
        input: SensorInput<'_>,
    ) -> Result<(DecodeStep, Option<[f64; 2]>), PerceptionError>;

    /// The sensor stream is known to be missing at `stamp_ns`.
    fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep, PerceptionError>;

    /// A new round or reception window: forget target, partial frame and stream continuity.
    fn reset(&mut self);

    /// The observer's turn from its home attitude, undone from the next input on.
    fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>);

    /// The check the session's frames carry (set once, before the first input).
    fn set_frame_check(&mut self, check: proto::FrameCheck);

    /// Why the receiver stopped working, once it has (a plug-in that raised, returned
    /// malformed output or ran past its time limit); Waggle's own receivers never do.
    fn failure(&self) -> Option<String> {
        None
    }
}

impl Receiving for Perception {
    fn push_tracked(
        &mut self,
        input: SensorInput<'_>,
    ) -> Result<(DecodeStep, Option<[f64; 2]>), PerceptionError> {
        Perception::push_tracked(self, input)
    }

    fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep, PerceptionError> {
        Perception::missing(self, stamp_ns)
    }

    fn reset(&mut self) {
        Perception::reset(self);
    }

    fn set_frame_check(&mut self, check: proto::FrameCheck) {
        Perception::set_frame_check(self, check);
    }

    fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>) {
        Perception::set_ego_rotation(self, ego);
    }
}

/// The receiving chain of one observer.
#[derive(Debug, Clone)]
pub enum Perception {
    Rgb(Box<RgbReceiver>),
    Events(Box<EventReceiver>),
    /// Segmenter and parser only, fed [`SensorInput::Track`] (the ideal baseline).
    Tracked(Box<Decoder>),
}

impl Perception {
    /// The paper's receiver for `modality`, matching the raw image trajectory.
    pub fn new(modality: Modality) -> Result<Self, PerceptionError> {
        Self::build(modality, |s| s)
    }

    /// The paper's receiver for `modality` on an observer whose camera is `camera` (its home
    /// pose, from the map), with the trajectory rectified by `mode` before template matching.
    pub fn for_camera(
        modality: Modality,
        camera: ObserverCamera,
        mode: Rectification,
    ) -> Result<Self, PerceptionError> {
        Self::build(modality, |s| s.rectified(camera, mode))
    }

    /// Segmenter and parser only, for an already tracked target seen by `camera` (the ideal
    /// baseline's chain: the RGB receiver's segmenter settings, as the baseline always used).
    pub fn tracked(camera: ObserverCamera, mode: Rectification) -> Result<Self, PerceptionError> {
        let config = SegmenterConfig::rgb().rectified(camera, mode);
        Ok(Self::Tracked(Box::new(Decoder::new(config)?)))
    }

    /// The sensor input this chain reads.
    pub fn expects(&self) -> &'static str {
        match self {
            Self::Rgb(_) => "rgb",
            Self::Events(_) => "events",
            Self::Tracked(_) => "track",
        }
    }

    fn build(
        modality: Modality,
        segmenter: impl Fn(SegmenterConfig) -> SegmenterConfig,
    ) -> Result<Self, PerceptionError> {
        match modality {
            Modality::Events => {
                let mut config = EventReceiverConfig::paper();
                config.segmenter = segmenter(config.segmenter);
                Ok(Self::Events(Box::new(
                    EventReceiver::new(config)?.without_history(),
                )))
            }
            Modality::Rgb => {
                let mut config = RgbReceiverConfig::paper();
                config.segmenter = segmenter(config.segmenter);
                Ok(Self::Rgb(Box::new(
                    RgbReceiver::new(config)?.without_history(),
                )))
            }
        }
    }

    /// Feeds the next input of this observer's sensor.
    pub fn push(&mut self, input: SensorInput<'_>) -> Result<DecodeStep, PerceptionError> {
        self.push_tracked(input).map(|(step, _)| step)
    }

    /// Like [`Self::push`], also returning the image-plane estimate the receiver placed the
    /// target at for this input (`None` when it has no target).
    pub fn push_tracked(
        &mut self,
        input: SensorInput<'_>,
    ) -> Result<(DecodeStep, Option<[f64; 2]>), PerceptionError> {
        match (self, input) {
            (Self::Events(r), SensorInput::Events(p)) => {
                let out = r.push_packet(p);
                Ok((out.step, out.point_px))
            }
            (Self::Rgb(r), SensorInput::Rgb(f)) => {
                let out = r.push_frame(f);
                Ok((out.step, out.track.and_then(|t| t.point_px)))
            }
            (Self::Tracked(d), SensorInput::Track(s)) => Ok((d.push(*s)?, s.point_px)),
            (chain, input) => Err(PerceptionError::WrongSensor {
                expected: chain.expects(),
                got: input.kind(),
            }),
        }
    }

    /// The sensor stream is known to be missing at `stamp_ns` (publisher gone, grace expired).
    pub fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep, PerceptionError> {
        Ok(match self {
            Self::Events(r) => r.interrupt(stamp_ns).step,
            Self::Rgb(r) => r.interrupt(stamp_ns).step,
            Self::Tracked(d) => d.interrupt(stamp_ns)?,
        })
    }

    /// Events seen and removed by the event receiver's noise front end (`None` for RGB).
    pub fn denoise_counts(&self) -> Option<crate::events::DenoiseCounts> {
        match self {
            Self::Events(r) => Some(r.denoise_counts()),
            Self::Rgb(_) | Self::Tracked(_) => None,
        }
    }

    /// Events seen and removed by the event receiver's ego-motion front end: `None` for RGB and
    /// while no turn has switched it on.
    pub fn ego_motion_counts(&self) -> Option<crate::events::ego_motion::EgoMotionCounts> {
        match self {
            Self::Events(r) => Some(r.ego_motion_counts()).filter(|c| c.seen > 0),
            Self::Rgb(_) | Self::Tracked(_) => None,
        }
    }

    /// How far the observer's airframe has turned from its home attitude, from the next input
    /// on: its attitude estimate, which the receiver undoes on the target's track
    /// ([`proto::stabilise`]). `None`: not turned.
    pub fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>) {
        match self {
            Self::Events(r) => r.set_ego_rotation(ego),
            Self::Rgb(r) => r.set_ego_rotation(ego),
            Self::Tracked(d) => d.set_ego_rotation(ego),
        }
    }

    /// The check the session's frames carry: frames that fail it are never released.
    pub fn set_frame_check(&mut self, check: proto::FrameCheck) {
        match self {
            Self::Events(r) => r.set_frame_check(check),
            Self::Rgb(r) => r.set_frame_check(check),
            Self::Tracked(d) => d.set_frame_check(check),
        }
    }

    /// A new round or reception window: forget target, partial frame and stream continuity.
    pub fn reset(&mut self) {
        match self {
            Self::Events(r) => r.reset(),
            Self::Rgb(r) => r.reset(),
            Self::Tracked(d) => d.reset(),
        }
    }
}
