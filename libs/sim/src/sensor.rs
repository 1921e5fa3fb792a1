//! Observer sensors on top of the renderer: a 25 Hz RGB camera or a 100 Hz-rendered synthetic
//! event camera with 40 ms packets. The black-input fault is applied before anything else (for
//! events: before conversion, from start-up, as in the paper).

use event_camera::{CameraConfig, EventCamera, EventSensorModel};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};
use proto::{EventPacket, FrameChange, RgbFrame};

use crate::render::{CameraRenderer, RenderError};
use crate::world::World;

/// RGB frame period (25 Hz).
pub const RGB_PERIOD_NS: u64 = 40_000_000;
/// Event-source render period (100 Hz).
pub const EVENT_RENDER_PERIOD_NS: u64 = 10_000_000;

/// Which sensor an observer carries.
use proto::Modality;

/// What a sensor delivered at one render instant.
#[derive(Debug, Clone, PartialEq)]
pub enum SensorOutput {
    Rgb(RgbFrame),
    Events(EventPacket),
}

/// Why a sensor failed.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("event camera: {0}")]
    Events(#[from] event_camera::CameraError),
}

/// What an event sensor was fed at one render instant: the render (or the black frame of the
/// black-input fault) and how it differs from the frame fed before it. Fed again, in order, to a
/// sensor of the same model and seed, these make the same packets (a recording keeps them
/// instead of the packets when noise makes the packets large).
#[derive(Debug, Clone, Copy)]
pub struct SensorFeed<'a> {
    pub stamp_ns: u64,
    pub rgb: &'a [u8],
    pub change: FrameChange,
}

/// One observer's sensor.
pub struct ObserverSensor {
    observer: usize,
    black: bool,
    state: State,
}

enum State {
    Rgb {
        next_seq: u64,
        /// Whether the last frame delivered was the black-input frame (`None` before the first).
        last_black: Option<bool>,
        /// How the last frame delivered differs from the one before it.
        change: FrameChange,
    },
    Events {
        camera: Box<EventCamera>,
        /// Whether the last frame fed was the black-input frame (`None` before the first).
        last_black: Option<bool>,
    },
}

impl ObserverSensor {
    /// A sensor for observer index `observer`; `black` blacks its input out from start-up.
    pub fn new(kind: Modality, observer: usize, black: bool) -> Result<Self, SensorError> {
        Self::with_event_sensor(kind, observer, black, EventSensorModel::default())
    }

    /// [`Self::new`] with the event sensor's contrast threshold and non-idealities (ignored by an
    /// RGB sensor).
    pub fn with_event_sensor(
        kind: Modality,
        observer: usize,
        black: bool,
        model: EventSensorModel,
    ) -> Result<Self, SensorError> {
        let state = match kind {
            Modality::Rgb => State::Rgb {
                next_seq: 0,
                last_black: None,
                change: FrameChange::All,
            },
            Modality::Events => {
                let mut config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX);
                config.black_input = black;
                let config = config.with_model(model);
                State::Events {
                    camera: Box::new(EventCamera::new(config)?),
                    last_black: None,
                }
            }
        };
        Ok(Self {
            observer,
            black,
            state,
        })
    }

    /// Switches the black-input fault on or off for subsequent captures (an injected fault).
    pub fn set_black(&mut self, black: bool) {
        self.black = black;
        if let State::Events { camera, .. } = &mut self.state {
            camera.set_black_input(black);
        }
    }

    /// How the last RGB frame delivered differs from the RGB frame delivered before it
    /// ([`FrameChange::All`] for an event sensor).
    pub fn rgb_change(&self) -> FrameChange {
        match self.state {
            State::Rgb { change, .. } => change,
            State::Events { .. } => FrameChange::All,
        }
    }

    /// Time between renders.
    pub fn render_period_ns(&self) -> u64 {
        match self.state {
            State::Rgb { .. } => RGB_PERIOD_NS,
            State::Events { .. } => EVENT_RENDER_PERIOD_NS,
        }
    }

    /// Renders the current state (call at multiples of [`Self::render_period_ns`]) and returns
    /// what the sensor delivers now: one RGB frame, or the event packets this render completes.
    pub fn capture(
        &mut self,
        world: &mut World,
        renderer: &mut CameraRenderer,
    ) -> Result<Vec<SensorOutput>, SensorError> {
        self.capture_observed(world, renderer, &mut |_| {})
    }

    /// [`Self::capture`], handing an event sensor's input to `on_input` before converting it
    /// (an RGB sensor's frame is its output: nothing is handed).
    pub fn capture_observed(
        &mut self,
        world: &mut World,
        renderer: &mut CameraRenderer,
        on_input: &mut dyn FnMut(SensorFeed<'_>),
    ) -> Result<Vec<SensorOutput>, SensorError> {
        let stamp_ns = world.time_ns();
        match &mut self.state {
            State::Rgb {
                next_seq,
                last_black,
                change,
            } => {
                let rgb = if self.black {
                    *change = if *last_black == Some(true) {
                        FrameChange::Nothing
                    } else {
                        FrameChange::All
                    };
                    vec![0; usize::from(IMAGE_WIDTH_PX) * usize::from(IMAGE_HEIGHT_PX) * 3]
                } else {
                    let frame = renderer.render_change(world, self.observer)?;
                    // The render's change is relative to this camera's previous render, which
                    // is the previous frame delivered unless that one was black.
                    *change = if *last_black == Some(false) {
                        frame.change
                    } else {
                        FrameChange::All
                    };
                    frame.rgb.to_vec()
                };
                *last_black = Some(self.black);
                let frame =
                    RgbFrame::rendered(*next_seq, stamp_ns, (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX), rgb);
                *next_seq += 1;
                Ok(vec![SensorOutput::Rgb(frame)])
            }
            State::Events { camera, last_black } => {
                // The camera substitutes black frames itself; skip the render it would discard.
                let packets = if self.black {
                    let black =
                        vec![0; usize::from(IMAGE_WIDTH_PX) * usize::from(IMAGE_HEIGHT_PX) * 3];
                    let change = if *last_black == Some(true) {
                        FrameChange::Nothing
                    } else {
                        FrameChange::All
                    };
                    on_input(SensorFeed {
                        stamp_ns,
                        rgb: &black,
                        change,
                    });
                    camera.push_frame(stamp_ns, &black)?
                } else {
                    let frame = renderer.render_change(world, self.observer)?;
                    // The render's change is relative to this camera's previous render, which
                    // is the previous frame fed unless that one was black.
                    let change = if *last_black == Some(false) {
                        frame.change
                    } else {
                        FrameChange::All
                    };
                    on_input(SensorFeed {
                        stamp_ns,
                        rgb: frame.rgb,
                        change,
                    });
                    camera.push_frame_change(stamp_ns, frame.rgb, frame.change)?
                };
                *last_black = Some(self.black);
                Ok(packets.into_iter().map(SensorOutput::Events).collect())
            }
        }
    }
}
