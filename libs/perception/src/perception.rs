//! One observer's perception, whichever sensor it carries: its own RGB frames or its own event
//! packets in, tokens and released frames out. This is all an observer process is allowed to
//! see of the world.

use proto::scene::ObserverCamera;
use proto::{EventPacket, Rectification, RgbFrame, SegmenterConfig};

use crate::events::{EventReceiver, EventReceiverConfig, EventReceiverError};
use crate::rgb::{RgbReceiver, RgbReceiverConfig, RgbReceiverError};
use proto::decoder::DecodeStep;

pub use proto::Modality;

/// One input from the observer's own sensor.
#[derive(Debug, Clone, Copy)]
pub enum SensorInput<'a> {
    Rgb(&'a RgbFrame),
    Events(&'a EventPacket),
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
}

/// The receiving chain of one observer.
#[derive(Debug, Clone)]
pub enum Perception {
    Rgb(Box<RgbReceiver>),
    Events(Box<EventReceiver>),
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

    fn build(
        modality: Modality,
        segmenter: impl Fn(SegmenterConfig) -> SegmenterConfig,
    ) -> Result<Self, PerceptionError> {
        match modality {
            Modality::Events => {
                let mut config = EventReceiverConfig::paper();
                config.segmenter = segmenter(config.segmenter);
                Ok(Self::Events(Box::new(EventReceiver::new(config)?)))
            }
            Modality::Rgb => {
                let mut config = RgbReceiverConfig::paper();
                config.segmenter = segmenter(config.segmenter);
                Ok(Self::Rgb(Box::new(RgbReceiver::new(config)?)))
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
            (Self::Rgb(_), SensorInput::Events(_)) => Err(PerceptionError::WrongSensor {
                expected: "rgb",
                got: "events",
            }),
            (Self::Events(_), SensorInput::Rgb(_)) => Err(PerceptionError::WrongSensor {
                expected: "events",
                got: "rgb",
            }),
        }
    }

    /// The sensor stream is known to be missing at `stamp_ns` (publisher gone, grace expired).
    pub fn missing(&mut self, stamp_ns: u64) -> DecodeStep {
        match self {
            Self::Events(r) => r.interrupt(stamp_ns).step,
            Self::Rgb(r) => r.interrupt(stamp_ns).step,
        }
    }

    /// Events seen and removed by the event receiver's noise front end (`None` for RGB).
    pub fn denoise_counts(&self) -> Option<crate::events::DenoiseCounts> {
        match self {
            Self::Events(r) => Some(r.denoise_counts()),
            Self::Rgb(_) => None,
        }
    }

    /// A new round or reception window: forget target, partial frame and stream continuity.
    pub fn reset(&mut self) {
        match self {
            Self::Events(r) => r.reset(),
            Self::Rgb(r) => r.reset(),
        }
    }
}
