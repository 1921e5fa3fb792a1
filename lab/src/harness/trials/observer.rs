//! One trial's observers: each observer's perturbed sensor (event camera or RGB sensor, drawn
//! from the trial's seed) and its receiver behind the perturbed link, fed a camera's renders in
//! order — from a shared render cache ([`observe_cached`]) or straight from the trial's own
//! flight ([`observe_flying`]) — and what each made of them ([`Observed`]).
//!
//! The receiver is Waggle's own for the modality, or a Python plug-in (`--receiver
//! python:MODULE:CLASS`) whose instances, one per observer, live in one worker process taken
//! from the run's pool for the trial.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;

use anyhow::{Context, Result};
use event_camera::{CameraConfig, EventCamera};
use perception::{Perception, SensorInput};
use perturb::Perturbation;
use perturb::attitude::{AttitudeError, estimated};
use perturb::link::LinkNoise;
use perturb::rgb::RgbSensor;
use perturb::seed::{Stream, rng, stream_seed};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement};
use proto::scene::{ObserverCamera, observer_name};
use proto::{
    DecodeStep, EgoRotation, EventPacket, FrameChange, Modality, Rectification, ReleasedFrame,
    RgbFrame, SegmentToken, SegmenterConfig,
};
use rand_chacha::ChaCha8Rng;
use receiver_plugin::{ObserverInfo, PluginCounts, PluginReceiver, Worker, WorkerPool};
use sim::sensor::RGB_PERIOD_NS;

use crate::harness::flight::rendered::{
    FlightSpec, Flown, RenderPose, RenderedFlight, fly_streamed,
};
use crate::harness::link::{ObserverOut, observer_out};

/// How a trial's observers sense: their modality, their receivers' rectification, the
/// perturbation their sensors and link draw from, and the plug-in receiver's workers (`None`:
/// Waggle's own receiver).
#[derive(Clone, Copy)]
pub struct Sensing<'a> {
    pub modality: Modality,
    pub rectification: Rectification,
    pub perturbation: &'a Perturbation,
    pub plugin: Option<&'a WorkerPool>,
    /// Instead of decoding, hand every input its receiver would get to this channel (the
    /// Python package's sensor streams).
    pub tap: Option<&'a SyncSender<Tapped>>,
    /// The check every frame carries after its payload.
    pub frame_check: proto::FrameCheck,
}

/// One input as the observer's receiver gets it (after the link), handed out of the trial.
#[derive(Debug, Clone)]
pub struct Tapped {
    pub observer: usize,
    pub input: TappedInput,
    /// How far the airframe has turned from home at this input (`None`: not turned).
    pub ego: Option<EgoRotation>,
    /// The performer's centre projected into the image of the observer's latest render (its
    /// camera turned and moved as the airframe was), `None` outside the image.
    pub performer_px: Option<[f64; 2]>,
}

/// The sensor message itself.
#[derive(Debug, Clone)]
pub enum TappedInput {
    Events(EventPacket),
    Rgb(RgbFrame),
}

/// The consumer of a tapped trial went away: the flight stops there.
#[derive(Debug)]
pub struct TapClosed;

impl std::fmt::Display for TapClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the consumer of the sensor inputs went away")
    }
}

impl std::error::Error for TapClosed {}

/// A tapped observer: where its inputs go and what goes with them.
struct Tap {
    observer: usize,
    sender: SyncSender<Tapped>,
    camera: ObserverCamera,
    ego: Option<EgoRotation>,
    performer_px: Option<[f64; 2]>,
}

/// An observer's receiver in a trial: Waggle's own, or a plug-in on the trial's worker.
enum TrialReceiver {
    Native(Perception),
    Plugin(Box<PluginReceiver>),
    Tap(Box<Tap>),
}

impl TrialReceiver {
    fn set_ego_rotation(&mut self, ego: Option<EgoRotation>) {
        match self {
            Self::Native(p) => p.set_ego_rotation(ego),
            Self::Plugin(p) => p.set_ego_rotation(ego),
            Self::Tap(t) => t.ego = ego,
        }
    }

    /// Where the performer is in the render about to be made (only a tap hands it out).
    fn set_performer(&mut self, pose: &RenderPose) {
        if let Self::Tap(t) = self {
            t.performer_px = pose.performer_px(&t.camera);
        }
    }

    fn push(&mut self, input: SensorInput<'_>) -> Result<DecodeStep> {
        Ok(match (self, input) {
            (Self::Tap(t), input) => {
                let tapped = Tapped {
                    observer: t.observer,
                    input: match input {
                        SensorInput::Events(p) => TappedInput::Events(p.clone()),
                        SensorInput::Rgb(f) => TappedInput::Rgb(f.clone()),
                        SensorInput::Track(_) => anyhow::bail!("a tap is fed a sensor"),
                    },
                    ego: t.ego,
                    performer_px: t.performer_px,
                };
                t.sender.send(tapped).map_err(|_| TapClosed)?;
                DecodeStep::default()
            }
            (Self::Native(p), input) => p.push(input)?,
            (Self::Plugin(p), SensorInput::Events(packet)) => p.push_events(packet)?.0,
            (Self::Plugin(p), SensorInput::Rgb(frame)) => p.push_rgb(frame)?.0,
            (Self::Plugin(_), SensorInput::Track(_)) => {
                anyhow::bail!("a plug-in receiver is fed a sensor, not a track")
            }
        })
    }

    /// What the receiver's front ends saw and removed (a plug-in says it as it closes).
    fn finish(self) -> Result<PluginCounts> {
        Ok(match self {
            Self::Native(p) => {
                let denoise = p.denoise_counts();
                PluginCounts {
                    events_received: denoise.map(|d| d.seen),
                    events_removed: denoise.map(|d| d.removed),
                    events_removed_ego: p.ego_motion_counts().map(|e| e.removed),
                }
            }
            Self::Plugin(p) => p.close()?,
            Self::Tap(_) => PluginCounts::default(),
        })
    }
}

/// The trial's plug-in worker, shared by its observers, given back to the pool when every
/// observer closed cleanly (a worker that failed is dropped, which kills it).
struct TrialWorker<'a> {
    pool: &'a WorkerPool,
    worker: Rc<RefCell<Worker>>,
}

impl<'a> TrialWorker<'a> {
    fn take(sensing: &Sensing<'a>) -> Result<Option<Self>> {
        let Some(pool) = sensing.plugin else {
            return Ok(None);
        };
        Ok(Some(Self {
            pool,
            worker: Rc::new(RefCell::new(pool.take()?)),
        }))
    }

    fn give_back(self) {
        if let Ok(worker) = Rc::try_unwrap(self.worker) {
            self.pool.give(worker.into_inner());
        }
    }
}

/// What one observer's receiver made of a trial's sensor stream.
pub struct Observed {
    pub out: ObserverOut,
    pub messages: u64,
    pub lost: u64,
    /// What the receiver's front ends saw and removed (Waggle's event receiver, or what a
    /// plug-in reports).
    pub counts: PluginCounts,
}

/// One observer's perturbed sensor and its receiver, fed the camera's renders in order (from
/// the render cache or straight from a flight of the trial's own).
struct Observer {
    perception: TrialReceiver,
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
    /// Observer `i` of `placement` under trial `seed`'s perturbation, its receiver a plug-in
    /// instance on `worker` when the trial has one.
    fn new(
        placement: &Placement,
        i: usize,
        opts: &Sensing<'_>,
        seed: u64,
        worker: Option<&TrialWorker<'_>>,
    ) -> Result<Self> {
        let perception = match worker {
            None if let Some(sender) = opts.tap => TrialReceiver::Tap(Box::new(Tap {
                observer: i,
                sender: sender.clone(),
                camera: placement.camera(),
                ego: None,
                performer_px: None,
            })),
            None => {
                let mut p =
                    Perception::for_camera(opts.modality, placement.camera(), opts.rectification)?;
                p.set_frame_check(opts.frame_check);
                TrialReceiver::Native(p)
            }
            Some(w) => {
                let info = ObserverInfo::new(
                    observer_name(i),
                    opts.modality,
                    placement,
                    opts.rectification,
                    seed,
                );
                let segmenter = SegmenterConfig::for_modality(opts.modality)
                    .rectified(placement.camera(), opts.rectification);
                let mut r = PluginReceiver::open(w.worker.clone(), &info, segmenter)?;
                r.set_frame_check(opts.frame_check);
                TrialReceiver::Plugin(Box::new(r))
            }
        };
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

    /// What the receiver released, its instants shifted by the link's delay (a plug-in's
    /// instance is closed first).
    fn finish(self) -> Result<Observed> {
        let mut out = observer_out(&self.tokens, &self.frames);
        let delay_s = self.link.delay_ns() as f64 * 1e-9;
        for f in &mut out.frames {
            f.final_null_s += delay_s;
        }
        for t in &mut out.tokens {
            t.t_s += delay_s;
        }
        Ok(Observed {
            out,
            messages: self.messages,
            lost: self.lost,
            counts: self.perception.finish()?,
        })
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
    let worker = TrialWorker::take(opts)?;
    let mut observed = Vec::new();
    for (i, placement) in flight.spec.formation.placements().iter().enumerate() {
        let mut observer = Observer::new(placement, i, opts, seed, worker.as_ref())?;
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
        observed.push(observer.finish()?);
    }
    if let Some(w) = worker {
        w.give_back();
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
    let worker = TrialWorker::take(opts)?;
    let mut observers = spec
        .formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, placement)| Observer::new(placement, i, opts, seed, worker.as_ref()))
        .collect::<Result<Vec<_>>>()?;
    let flown = fly_streamed(spec, |i, t, rgb, change, pose| {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        observers[i].perception.set_performer(&pose);
        // The observer's attitude estimate: its receiver undoes the airframe's turn.
        let ego = estimated(observers[i].attitude.as_mut(), t, pose.ego);
        observers[i].perception.set_ego_rotation(ego);
        observers[i].render(t, rgb, change)?;
        Ok(true)
    })?;
    let Some(flown) = flown else {
        return Ok(None);
    };
    let observed = observers
        .into_iter()
        .map(Observer::finish)
        .collect::<Result<Vec<_>>>()?;
    if let Some(w) = worker {
        w.give_back();
    }
    Ok(Some((flown, observed)))
}
