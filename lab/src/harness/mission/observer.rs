//! One observer of the in-process mission: its own sensor (or the ideal baseline's projection
//! of the truth), the sensor's perturbations, and the one observer core
//! ([`perception::observer::ObserverCore`]) that `observer-node` and `waggle replay` run too.
//! Everything it publishes is kept as the process's would be in `observers.json`.

use anyhow::{Context, Result};
use evaluation::ideal_receiver::ideal_sample;
use perception::observer::{ObserverCore, Processed};
use perception::runtime::ObserverRuntime;
use perception::tick::{MissingReason, SensorPacket};
use perception::{Perception, Receiving};
use perturb::attitude::{AttitudeError, estimated};
use perturb::link::LinkNoise;
use perturb::rgb::RgbSensor;
use perturb::seed::{Stream, rng, stream_seed};
use proto::scene::{ObserverCamera, Placement, observer_name};
use proto::{
    Fault, FaultKind, Modality, ObserverId, Rectification, Roster, SegmenterConfig, SimState,
    TICK_NS,
};
use rand_chacha::ChaCha8Rng;
use receiver_plugin::{ObserverInfo, PluginChain, PluginSpec};
use sim::render::CameraRenderer;
use sim::sensor::{ObserverSensor, SensorOutput};
use sim::world::World;

use crate::harness::mission::options::MissionOptions;
use proto::Receiver;
use run_format::case::Case;
use run_format::run_dir::ObserverRecord;

/// Where an observer's input comes from.
enum Source {
    /// Its own camera, rendered from the mirrored truth (the process's camera).
    Sensor(Box<ObserverSensor>),
    /// Ground truth projected into its home camera (the evaluation baseline).
    Ideal(ObserverCamera),
}

/// One observer of the mission.
pub struct MissionObserver {
    pub name: String,
    pub id: ObserverId,
    core: ObserverCore,
    source: Source,
    black: bool,
    /// The stream stops for good from this instant on (the case's dropout fault).
    dropout: Option<Fault>,
    /// RGB read noise / exposure applied to every frame (`None`: the ideal sensor).
    rgb_noise: Option<RgbSensor>,
    /// The sensor link's loss, and the stream it draws from.
    link: (LinkNoise, ChaCha8Rng),
    /// Why the packet of the tick being sensed did not arrive, if it did not.
    gap: Option<MissingReason>,
    /// Its airframe's attitude at home (as the scene was built): its receiver undoes the turn
    /// from it that each packet was made with, as in link trials.
    home_wxyz: [f64; 4],
    /// The error of its attitude estimate (`flight.attitude_sigma_deg`; `None`: exact).
    attitude: Option<AttitudeError>,
    /// What it published, as `observers.json` holds it.
    pub record: ObserverRecord,
    /// Every event its camera produced, when the mission keeps them (`--events-raw`).
    pub events: Option<Vec<event_camera::Event>>,
}

impl MissionObserver {
    /// Observer `i` of `case` on `modality`'s receiver, its sensor perturbed as `opts` says.
    pub fn new(
        case: &Case,
        modality: Receiver,
        i: usize,
        opts: &MissionOptions,
        home_wxyz: [f64; 4],
    ) -> Result<Self> {
        let n = case.observers;
        let name = observer_name(i);
        let id = ObserverId::new(name.clone())?;
        let roster = Roster::default_scene(n);
        let camera = ObserverRuntime::home_camera(&id, &roster)
            .with_context(|| format!("{name} is not on the roster"))?;
        let black = case.black(&name);
        let plugin = opts.receivers.iter().find(|r| r.observer == id);
        let (perception, source): (Box<dyn Receiving>, _) = match modality.sensor() {
            None if plugin.is_some() => anyhow::bail!(
                "{name}'s plug-in receiver needs a sensor (events or rgb), not the ideal receiver"
            ),
            None => (
                Box::new(Perception::tracked(camera, Rectification::default())?),
                Source::Ideal(camera),
            ),
            Some(kind) => (
                match plugin {
                    Some(p) => {
                        Box::new(plugin_chain(&p.plugin, &name, kind, camera, &roster, opts)?)
                    }
                    None => Box::new(Perception::for_camera(
                        kind,
                        camera,
                        Rectification::default(),
                    )?),
                },
                Source::Sensor(Box::new(ObserverSensor::with_event_sensor(
                    kind,
                    i,
                    black,
                    opts.perturbation
                        .event_sensor(stream_seed(opts.seed, Stream::EventSensor, i)),
                )?)),
            ),
        };
        let rgb = opts.perturbation.rgb();
        Ok(Self {
            core: ObserverCore::new(
                ObserverRuntime::with_receiver(id.clone(), roster, perception)
                    .with_frame_check(case.frame_check),
            ),
            dropout: case.dropout_ns(&name).map(|from_ns| Fault {
                observer: id.clone(),
                kind: FaultKind::StreamDropout,
                from_ns,
                until_ns: None,
            }),
            rgb_noise: (modality == Receiver::Rgb && !rgb.is_ideal())
                .then(|| rgb.sensor(&mut rng(opts.seed, Stream::RgbSensor, i))),
            link: (opts.perturbation.link(), rng(opts.seed, Stream::Link, i)),
            name,
            id,
            source,
            black,
            gap: None,
            home_wxyz,
            attitude: opts.perturbation.attitude_error_of(opts.seed, i),
            record: ObserverRecord::default(),
            events: (opts.keep_events && modality == Receiver::Events).then(Vec::new),
        })
    }

    /// Why its plug-in receiver stopped working, once it has.
    pub fn receiver_failure(&self) -> Option<String> {
        self.core.receiver_failure()
    }

    /// The render period of its sensor (`None`: the ideal baseline, sampled every tick).
    pub fn render_period_ns(&self) -> Option<u64> {
        match &self.source {
            Source::Sensor(s) => Some(s.render_period_ns()),
            Source::Ideal(_) => None,
        }
    }

    /// Senses at the render instant of `state` (the truth as published; `camera_world` is
    /// posed from it): the camera renders and delivers, or the truth is projected at tick
    /// boundaries. What arrives goes to the core; what does not is remembered as the gap.
    pub fn sense(
        &mut self,
        state: &SimState,
        camera_world: &mut World,
        renderer: Option<&mut CameraRenderer>,
    ) -> Result<()> {
        let t = state.stamp_ns;
        let outputs = match (&mut self.source, renderer) {
            (Source::Sensor(sensor), Some(renderer)) => {
                if t == 0 || !t.is_multiple_of(sensor.render_period_ns()) {
                    return Ok(());
                }
                // A dropped-out camera renders nothing more, as its killed process would.
                if self.dropout.as_ref().is_some_and(|f| f.active_at(t)) {
                    self.gap = Some(MissingReason::Dropout);
                    return Ok(());
                }
                sensor.capture(camera_world, renderer)?
            }
            (Source::Sensor(_), None) => return Ok(()),
            (Source::Ideal(camera), _) => {
                if !t.is_multiple_of(TICK_NS) {
                    return Ok(());
                }
                if self.dropout.as_ref().is_some_and(|f| f.active_at(t)) {
                    self.gap = Some(MissingReason::Dropout);
                    return Ok(());
                }
                let performer_m = state
                    .drone("performer")
                    .context("the truth lacks the performer")?
                    .pos_m;
                let mut sample = ideal_sample(camera, t, performer_m);
                if self.black {
                    sample = proto::Sample::lost(t);
                }
                self.core.packet(sample);
                return Ok(());
            }
        };
        // The attitude estimate of the render that made these outputs, with its error if any.
        // Bitwise equal to home on a still airframe with an exact estimate: nothing to undo.
        let turn = state
            .drone(&self.name)
            .and_then(|d| proto::EgoRotation::between(self.home_wxyz, d.quat_wxyz));
        let ego = estimated(self.attitude.as_mut(), t, turn);
        for output in outputs {
            let packet: SensorPacket = match output {
                SensorOutput::Rgb(mut f) => {
                    if let Some(noise) = self.rgb_noise.as_mut() {
                        f.rgb = noise.apply(&[&f.rgb]);
                    }
                    f.into()
                }
                SensorOutput::Events(p) => {
                    if let Some(events) = self.events.as_mut() {
                        crate::harness::flight::raw::packet_events(&p, events);
                    }
                    p.into()
                }
            };
            if self.link.0.keeps(&mut self.link.1) {
                let (tick, _) = self.core.packet(packet);
                self.core.attitude(tick, ego);
            } else {
                self.gap = Some(MissingReason::Lost);
            }
        }
        Ok(())
    }

    /// Processes tick `tick` (everything for it has been delivered: a packet not in hand is
    /// missing) and returns its decision, if any.
    pub fn tick(&mut self, tick: u64) -> Result<Option<proto::Decision>> {
        self.core.clocks_through(tick);
        let gap = self.gap.take().unwrap_or(MissingReason::Lost);
        let mut decision = None;
        while let Some(Processed { report, .. }) = self
            .core
            .next(|_| Some(gap))
            .with_context(|| format!("{} at tick {tick}", self.name))?
        {
            let rec = &mut self.record;
            rec.tokens.extend(report.tokens);
            rec.frames.extend(report.frames);
            rec.track
                .extend(report.track.into_iter().flat_map(|t| t.samples));
            if let Some(d) = report.decision {
                rec.decisions.push(d.clone());
                decision = Some(d);
            }
        }
        Ok(decision)
    }

    /// The scheduler's session controls of tick `tick`.
    pub fn session(&mut self, tick: u64, controls: Vec<proto::SessionControl>) {
        self.core.session(tick, controls);
    }
}

/// Observer `name`'s plug-in receiver on a worker of its own: told where the observer sits and
/// looks, the mission's seed, and the mission's time limit.
fn plugin_chain(
    spec: &PluginSpec,
    name: &str,
    kind: Modality,
    camera: ObserverCamera,
    roster: &Roster,
    opts: &MissionOptions,
) -> Result<PluginChain> {
    let home_m = roster
        .entries()
        .iter()
        .find(|e| e.observer.as_str() == name)
        .map(|e| e.home_m)
        .with_context(|| format!("{name} is not on the roster"))?;
    let mode = Rectification::default();
    let info = ObserverInfo::new(
        name.to_owned(),
        kind,
        &Placement::aimed_from(home_m),
        mode,
        opts.seed,
    );
    let segmenter = SegmenterConfig::for_modality(kind).rectified(camera, mode);
    PluginChain::open(
        spec,
        &receiver_plugin::worker::python(),
        &info,
        segmenter,
        opts.plugin_time_limit,
    )
    .with_context(|| format!("{name}'s receiver {spec}"))
}
