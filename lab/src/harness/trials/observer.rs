//! One trial's observers: each observer's perturbed sensor (event camera or RGB sensor, drawn
//! from the trial's seed) and its receiver behind the perturbed link, fed a camera's renders in
//! order — from a shared render cache ([`observe_cached`]) or straight from the trial's own
//! flight ([`observe_flying`]) — and what each made of them ([`Observed`]).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result};
use event_camera::{CameraConfig, EventCamera};
use perception::{Perception, SensorInput};
use perturb::Perturbation;
use perturb::attitude::{AttitudeError, estimated};
use perturb::link::LinkNoise;
use perturb::rgb::RgbSensor;
use perturb::seed::{Stream, rng, stream_seed};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement};
use proto::{FrameChange, Modality, Rectification, ReleasedFrame, RgbFrame, SegmentToken};
use rand_chacha::ChaCha8Rng;
use sim::sensor::RGB_PERIOD_NS;

use crate::harness::flight::rendered::{FlightSpec, Flown, RenderedFlight, fly_streamed};
use crate::harness::link::{ObserverOut, observer_out};

/// How a trial's observers sense: their modality, their receivers' rectification and the
/// perturbation their sensors and link draw from.
#[derive(Debug, Clone, Copy)]
pub struct Sensing<'a> {
    pub modality: Modality,
    pub rectification: Rectification,
    pub perturbation: &'a Perturbation,
}

/// What one observer's receiver made of a trial's sensor stream.
pub struct Observed {
    pub out: ObserverOut,
    pub messages: u64,
    pub lost: u64,
    pub denoise: Option<perception::events::DenoiseCounts>,
    pub ego_motion: Option<perception::events::ego_motion::EgoMotionCounts>,
}

/// One observer's perturbed sensor and its receiver, fed the camera's renders in order (from
/// the render cache or straight from a flight of the trial's own).
struct Observer {
    perception: Perception,
    link: LinkNoise,
    link_rng: ChaCha8Rng,
    sensor: Sensor,
    tokens: Vec<SegmentToken>,
    frames: Vec<ReleasedFrame>,
    messages: u64,
    lost: u64,
    /// The error of its attitude estimate (`flight.attitude_sigma_deg`; `None`: exact).
    attitude: Option<AttitudeError>,
}

/// What turns an observer's renders into sensor messages.
enum Sensor {
    Events(Box<EventCamera>),
    Rgb {
        sensor: Box<RgbSensor>,
        /// Renders a frame averages (motion blur); 1: none.
        keep: usize,
        /// The last `keep` renders, oldest first (only when `keep > 1`).
        recent: VecDeque<Vec<u8>>,
        seq: u64,
    },
}

impl Observer {
    /// Observer `i` of `placement` under trial `seed`'s perturbation.
    fn new(placement: &Placement, i: usize, opts: &Sensing<'_>, seed: u64) -> Result<Self> {
        let perception =
            Perception::for_camera(opts.modality, placement.camera(), opts.rectification)?;
        let sensor = match opts.modality {
            Modality::Events => {
                let sensor_seed = stream_seed(seed, Stream::EventSensor, i);
                let config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX)
                    .with_model(opts.perturbation.event_sensor(sensor_seed));
                let mut camera = EventCamera::new(config).context("event camera")?;
                if let Some(tiler) =
                    opts.perturbation
                        .real_noise_tiler(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX, sensor_seed)
                {
                    camera = camera.with_real_noise(tiler);
                }
                Sensor::Events(Box::new(camera))
            }
            Modality::Rgb => {
                let noise = opts.perturbation.rgb();
                Sensor::Rgb {
                    sensor: Box::new(noise.sensor(&mut rng(seed, Stream::RgbSensor, i))),
                    keep: noise.blur_renders.max(1) as usize,
                    recent: VecDeque::new(),
                    seq: 0,
                }
            }
        };
        Ok(Self {
            perception,
            link: opts.perturbation.link(),
            link_rng: rng(seed, Stream::Link, i),
            sensor,
            tokens: Vec::new(),
            frames: Vec::new(),
            messages: 0,
            lost: 0,
            attitude: opts.perturbation.attitude_error_of(seed, i),
        })
    }

    /// The camera's next render: `rgb` the whole frame, `change` what differs from the previous.
    fn render(&mut self, t: u64, rgb: &[u8], change: FrameChange) -> Result<()> {
        match &mut self.sensor {
            Sensor::Events(camera) => {
                for packet in camera.push_frame_change(t, rgb, change)? {
                    self.deliver(SensorInput::Events(&packet))?;
                }
            }
            Sensor::Rgb {
                sensor,
                keep,
                recent,
                seq,
            } => {
                if *keep > 1 {
                    if recent.len() == *keep {
                        recent.pop_front();
                    }
                    recent.push_back(rgb.to_vec());
                }
                if !t.is_multiple_of(RGB_PERIOD_NS) {
                    return Ok(());
                }
                let renders: Vec<&[u8]> = if *keep > 1 {
                    recent.iter().map(Vec::as_slice).collect()
                } else {
                    vec![rgb]
                };
                let frame = RgbFrame {
                    seq: *seq,
                    stamp_ns: t,
                    width: IMAGE_WIDTH_PX,
                    height: IMAGE_HEIGHT_PX,
                    valid: true,
                    continuous: true,
                    rgb: sensor.apply(&renders),
                };
                *seq += 1;
                self.deliver(SensorInput::Rgb(&frame))?;
            }
        }
        Ok(())
    }

    /// One sensor message over the perturbed link into the receiver.
    fn deliver(&mut self, input: SensorInput<'_>) -> Result<()> {
        self.messages += 1;
        if !self.link.keeps(&mut self.link_rng) {
            self.lost += 1;
            return Ok(());
        }
        let step = self.perception.push(input)?;
        self.tokens.extend(step.tokens);
        self.frames.extend(step.frames);
        Ok(())
    }

    /// What the receiver released, its instants shifted by the link's delay.
    fn finish(self) -> Observed {
        let mut out = observer_out(&self.tokens, &self.frames);
        let delay_s = self.link.delay_ns() as f64 * 1e-9;
        for f in &mut out.frames {
            f.final_null_s += delay_s;
        }
        for t in &mut out.tokens {
            t.t_s += delay_s;
        }
        Observed {
            out,
            messages: self.messages,
            lost: self.lost,
            denoise: self.perception.denoise_counts(),
            ego_motion: self.perception.ego_motion_counts(),
        }
    }
}

/// Every observer of a trial fed from the render cache, one after another. `None` when `stop`
/// was raised before they finished.
pub fn observe_cached(
    flight: &RenderedFlight,
    opts: &Sensing<'_>,
    seed: u64,
    stop: &AtomicBool,
) -> Result<Option<Vec<Observed>>> {
    let mut observed = Vec::new();
    for (i, placement) in flight.spec.formation.placements().iter().enumerate() {
        let mut observer = Observer::new(placement, i, opts, seed)?;
        let mut finished = true;
        flight.tracks[i].replay(|t, rgb, change, ego| {
            if stop.load(Ordering::Relaxed) {
                finished = false;
                return Ok(false);
            }
            let ego = estimated(observer.attitude.as_mut(), t, ego);
            observer.perception.set_ego_rotation(ego);
            observer.render(t, rgb, change)?;
            Ok(true)
        })?;
        if !finished {
            return Ok(None);
        }
        observed.push(observer.finish());
    }
    Ok(Some(observed))
}

/// Every observer of a trial fed straight from the trial's own flight of `spec`, render by
/// render: nothing is kept (a flight that moves the cameras changes every pixel of every
/// render, gigabytes a flight). Each observer sees the same renders in the same order as from
/// the cache, so it decodes the same. `None` when `stop` was raised before the flight ended.
pub fn observe_flying(
    spec: &FlightSpec,
    opts: &Sensing<'_>,
    seed: u64,
    stop: &AtomicBool,
) -> Result<Option<(Flown, Vec<Observed>)>> {
    let mut observers = spec
        .formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, placement)| Observer::new(placement, i, opts, seed))
        .collect::<Result<Vec<_>>>()?;
    let flown = fly_streamed(spec, |i, t, rgb, change, ego| {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        // The observer's attitude estimate: its receiver undoes the airframe's turn.
        let ego = estimated(observers[i].attitude.as_mut(), t, ego);
        observers[i].perception.set_ego_rotation(ego);
        observers[i].render(t, rgb, change)?;
        Ok(true)
    })?;
    Ok(flown.map(|f| (f, observers.into_iter().map(Observer::finish).collect())))
}
