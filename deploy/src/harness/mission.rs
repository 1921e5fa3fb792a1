//! `waggle mission`: a whole case in one process (physics, cameras, performer, observers,
//! scheduler), stepped in the lockstep order of docs/DESIGN.md §3. It is the reference the
//! distributed runtime must reproduce, and the fast way to run a case while developing.
//!
//! Per tick k (40 ms): the scheduler consumes the decisions observers made from data up to t_k
//! and emits session controls, a broadcast and flight setpoints; then physics steps to t_{k+1},
//! and at every render instant in (t_k, t_{k+1}] each observer's sensor delivers its own data to
//! its own perception and agent only.
//!
//! Perception is fed at every render instant (several per tick with event cameras) and gated
//! by the agent's reception window, so this harness does not go through the process runtime's
//! per-tick assembly (`perception::tick`); `waggle replay` and `observer-node` do.

pub use crate::harness::mission_options::MissionOptions;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::{Context, Result};
use perception::agent::{AgentFrame, FrameOutcome, ObserverAgent};
use perception::perception::SensorInput;
use perturb::link::LinkNoise;
use perturb::rgb::RgbSensor;
use perturb::seed::{Stream, rng, stream_seed};
use proto::Rectification;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, ObserverCamera, observer_name};
use proto::{ClockTick, Modality, ObserverId, RenderPath, Roster, Site, TICK_NS};
use proto::{DecodeStep, Decoder, Sample, SegmentToken, SegmenterConfig};
use proto::{GestureConfig, Schedule, broadcast};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use scheduler::{DecisionNotice, EndReason, EventKind, Scheduler, SchedulerConfig};
use sim::control::Reference;
use sim::render::CameraRenderer;
use sim::sensor::{ObserverSensor, SensorOutput};
use sim::world::World;

use crate::case::{Case, Receiver};
use crate::eval::summary::{check_expected, decision_label, ns_s};
use crate::harness::air::{Tracking, set_air};
use crate::harness::mission_metrics::{MissionMetrics, Policy, measure};
use crate::harness::performer_flight::performer_reference;
use crate::run_dir::{MissionSummary, ObserverSummary};

/// One observer's perception chain.
enum Perception {
    /// Ground truth projected into the home camera (evaluation baseline).
    Ideal {
        camera: ObserverCamera,
        decoder: Box<Decoder>,
    },
    /// The observer's real receiver, fed only by its own sensor.
    Sensor(Box<perception::perception::Perception>),
}

impl Perception {
    fn reset(&mut self) {
        match self {
            Perception::Ideal { decoder, .. } => decoder.reset(),
            Perception::Sensor(p) => p.reset(),
        }
    }

    /// The sensor stream is gone (dropout): perception must not confirm anything on silence.
    fn missing(&mut self, stamp_ns: u64) -> Result<DecodeStep> {
        match self {
            Perception::Ideal { decoder, .. } => Ok(decoder.interrupt(stamp_ns)?),
            Perception::Sensor(p) => Ok(p.missing(stamp_ns)),
        }
    }
}

struct Slot {
    name: String,
    id: ObserverId,
    agent: ObserverAgent,
    perception: Perception,
    sensor: Option<ObserverSensor>,
    /// RGB read noise / exposure applied to every frame (`None`: the ideal sensor).
    rgb_noise: Option<RgbSensor>,
    /// The sensor link's loss, and the stream it draws from.
    link: (LinkNoise, ChaCha8Rng),
    black: bool,
    dropout_ns: Option<u64>,
    dropped: bool,
    tokens: Vec<SegmentToken>,
    frames: Vec<AgentFrame>,
    pending: Vec<DecisionNotice>,
    decisions: Vec<proto::Decision>,
}

impl Slot {
    /// Observer `i` of `case` on `modality`'s receiver, its sensor perturbed as `opts` says.
    fn new(case: &Case, modality: Receiver, i: usize, opts: &MissionOptions) -> Result<Self> {
        let n = case.observers;
        let name = observer_name(i);
        let id = ObserverId::new(name.clone())?;
        let black = case.black(&name);
        let camera = ObserverCamera::at_home(i, n);
        let rectification = Rectification::default();
        let (perception, sensor) = match modality.sensor() {
            None => (
                Perception::Ideal {
                    camera,
                    decoder: Box::new(Decoder::new(
                        SegmenterConfig::rgb().rectified(camera, rectification),
                    )?),
                },
                None,
            ),
            Some(kind) => (
                Perception::Sensor(Box::new(perception::perception::Perception::for_camera(
                    kind,
                    camera,
                    rectification,
                )?)),
                Some(ObserverSensor::with_event_sensor(
                    kind,
                    i,
                    black,
                    opts.perturbation
                        .event_sensor(stream_seed(opts.seed, Stream::EventSensor, i)),
                )?),
            ),
        };
        Ok(Self {
            agent: ObserverAgent::new(id.clone(), Roster::default_scene(n)),
            dropout_ns: case.dropout_ns(&name),
            name,
            id,
            perception,
            sensor,
            rgb_noise: {
                let noise = opts.perturbation.rgb();
                (!noise.is_ideal()).then(|| noise.sensor(&mut rng(opts.seed, Stream::RgbSensor, i)))
            },
            link: (opts.perturbation.link(), rng(opts.seed, Stream::Link, i)),
            black,
            dropped: false,
            tokens: Vec::new(),
            frames: Vec::new(),
            pending: Vec::new(),
            decisions: Vec::new(),
        })
    }

    /// This observer's line of the summary (a complete message is a cached offer).
    fn summary(&self, services: Vec<String>) -> ObserverSummary {
        ObserverSummary {
            complete_messages: self
                .frames
                .iter()
                .filter(|f| matches!(f.outcome, FrameOutcome::Cached(_)))
                .count(),
            payloads: self
                .frames
                .iter()
                .map(|f| format!("{:06b}", f.frame.payload))
                .collect(),
            final_null_s: self
                .frames
                .iter()
                .map(|f| ns_s(f.frame.final_null_ns()))
                .collect(),
            decisions: self.decisions.iter().map(decision_label).collect(),
            services,
            tokens: self.tokens.len(),
        }
    }

    fn absorb(&mut self, step: DecodeStep, now_ns: u64) {
        self.tokens.extend(step.tokens);
        if step.frames.is_empty() {
            return;
        }
        let (frames, decision) = self.agent.on_frames(&step.frames, now_ns);
        self.frames.extend(frames);
        if let Some(d) = decision {
            self.pending.push(DecisionNotice::from(&d));
            self.decisions.push(d);
        }
    }
}

/// Flies `case` with every observer on `modality`'s receiver, in one process.
pub fn fly_case(case: &Case, modality: Receiver, render: RenderPath) -> Result<MissionSummary> {
    let opts = MissionOptions {
        render,
        ..MissionOptions::default()
    };
    Ok(fly_case_with(case, modality, &opts)?
        .context("the mission was interrupted")?
        .0)
}

/// [`fly_case`] under `opts`; also the mission's outcome measures. `None` when `opts.stop`
/// was raised before the mission ended.
pub fn fly_case_with(
    case: &Case,
    modality: Receiver,
    opts: &MissionOptions,
) -> Result<Option<(MissionSummary, MissionMetrics)>> {
    opts.check()?;
    let started = Instant::now();
    let mut mission = Mission::new(case, modality, opts)?;
    let Some(end_reason) = mission.fly(opts.stop.as_deref())? else {
        return Ok(None);
    };
    let mut metrics = measure(&mission.scheduler, opts.policy, mission.world.time_ns());
    if mission.air {
        metrics.performer_tracking = Some(Tracking::of(&mission.world, 0));
    }
    Ok(Some((
        mission.summarise(case, modality, end_reason, started),
        metrics,
    )))
}

/// The gusts on the performer: σ, hold time, their stream and when the next one is drawn.
struct GustState {
    normal: Normal<f64>,
    period_ns: u64,
    rng: ChaCha8Rng,
    next_ns: u64,
}

/// A mission in flight: physics, cameras, the performer, the observers and the scheduler.
struct Mission {
    world: World,
    scheduler: Scheduler,
    renderer: Option<CameraRenderer>,
    slots: Vec<Slot>,
    alive: BTreeSet<ObserverId>,
    gesture: GestureConfig,
    /// The performer's current broadcast.
    performer: Option<Schedule>,
    /// Render instants are the multiples of this.
    sample_period_ns: u64,
    tick: u64,
    policy: Policy,
    /// Fixed policy: the round whose decisions fall due, and when.
    fixed_due: Option<(u32, u64)>,
    /// Fixed policy: each observer's site, roster order (`None`: no site is offered).
    fixed_sites: Vec<Option<Site>>,
    gusts: Option<GustState>,
    /// Wind or the cascade controller is set: the performer's tracking is measured.
    air: bool,
}

impl Mission {
    fn new(case: &Case, modality: Receiver, opts: &MissionOptions) -> Result<Self> {
        let render = opts.render;
        let n = case.observers;
        let mut world = World::new(n).context("building the scene")?;
        let air = set_air(&mut world, &opts.perturbation, opts.seed)?;
        // The ideal baseline flies the RGB broadcast (no acquisition preamble).
        let sched_modality = modality.sensor().unwrap_or(Modality::Rgb);
        let scheduler = scheduler_for(case, sched_modality)?;
        let renderer = match modality {
            // The fixed policy reads no sensor: nothing to render.
            _ if opts.policy == Policy::Fixed => None,
            Receiver::Ideal => None,
            Receiver::Rgb | Receiver::Events => Some(
                CameraRenderer::new(&world, render).context("creating the offscreen renderer")?,
            ),
        };
        let slots = (0..n)
            .map(|i| Slot::new(case, modality, i, opts))
            .collect::<Result<Vec<_>>>()?;
        let sample_period_ns = slots
            .first()
            .and_then(|s| s.sensor.as_ref())
            .map_or(TICK_NS, ObserverSensor::render_period_ns);
        let alive = slots.iter().map(|s| s.id.clone()).collect();
        let offer_sites = &scheduler.config().offer_sites;
        let fixed_sites = (0..n)
            .map(|i| (!offer_sites.is_empty()).then(|| offer_sites[i % offer_sites.len()]))
            .collect();
        let sigma_n = opts.perturbation.gust_sigma_n();
        let gusts = if sigma_n > 0.0 {
            Some(GustState {
                normal: Normal::new(0.0, sigma_n).context("gust σ")?,
                period_ns: opts.perturbation.gust_period_ns(),
                rng: rng(opts.seed, Stream::Gust, 0),
                next_ns: 0,
            })
        } else {
            None
        };
        Ok(Self {
            policy: opts.policy,
            fixed_due: None,
            fixed_sites,
            gusts,
            air,
            world,
            scheduler,
            renderer,
            slots,
            alive,
            gesture: GestureConfig::default(),
            performer: None,
            sample_period_ns,
            tick: 0,
        })
    }

    /// Runs tick after tick until the scheduler ends the mission (`None`: `stop` was raised).
    fn fly(&mut self, stop: Option<&AtomicBool>) -> Result<Option<EndReason>> {
        loop {
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                return Ok(None);
            }
            if let Some(reason) = self.schedule()? {
                return Ok(Some(reason));
            }
            self.physics_and_sensing()?;
            self.tick += 1;
        }
    }

    /// The scheduler at t_k with the decisions made from data up to t_k: session controls to
    /// the agents, a new broadcast to the performer; the end reason once the mission ends.
    fn schedule(&mut self) -> Result<Option<EndReason>> {
        let positions: BTreeMap<ObserverId, [f64; 3]> = self
            .slots
            .iter()
            .enumerate()
            .map(|(i, s)| (s.id.clone(), self.world.position_m(i + 1)))
            .collect();
        self.fixed_decisions();
        let decisions: Vec<DecisionNotice> = self
            .slots
            .iter_mut()
            .flat_map(|s| s.pending.drain(..))
            .collect();
        let clock = ClockTick::at(self.tick).context("tick overflow")?;
        let out = self.scheduler.step(&scheduler::TickInput {
            clock,
            positions_m: &positions,
            decisions: &decisions,
            alive: &self.alive,
        })?;
        for control in &out.session {
            for slot in &mut self.slots {
                if slot.agent.on_session(control.event) {
                    slot.perception.reset();
                }
            }
        }
        if let Some(plan) = &out.broadcast {
            if self.policy == Policy::Fixed {
                // Decided without reading the broadcast, on the first tick after it started.
                self.fixed_due = Some((plan.round, plan.start_ns + TICK_NS));
            }
            let payloads: Vec<u8> = plan.offers.iter().map(|o| o.to_payload()).collect();
            self.performer = Some(broadcast(
                plan.start_ns,
                &payloads,
                plan.acquisition,
                &self.gesture,
            )?);
        }
        Ok(out.mission_end)
    }

    /// Fixed policy: once a round's decisions fall due, every live observer takes its site.
    fn fixed_decisions(&mut self) {
        let Some((round, due_ns)) = self.fixed_due else {
            return;
        };
        if self.world.time_ns() < due_ns {
            return;
        }
        self.fixed_due = None;
        for (slot, site) in self.slots.iter_mut().zip(&self.fixed_sites) {
            slot.pending.push(DecisionNotice {
                observer: slot.id.clone(),
                round,
                assignment: *site,
                decided_ns: due_ns,
            });
        }
    }

    /// A new gust on the performer when the current one has held its time.
    fn gust(&mut self, t: u64) {
        if let Some(g) = self.gusts.as_mut()
            && t >= g.next_ns
        {
            let force = [
                g.normal.sample(&mut g.rng),
                g.normal.sample(&mut g.rng),
                0.0,
            ];
            self.world.set_disturbance_n(0, force);
            g.next_ns = t + g.period_ns;
        }
    }

    /// Physics and sensing over (t_k, t_{k+1}].
    fn physics_and_sensing(&mut self) -> Result<()> {
        let tick_end = self.world.time_ns() + TICK_NS;
        while self.world.time_ns() < tick_end {
            let t = self.world.time_ns();
            let performer_ref = self.performer.as_ref().map_or(
                Reference::hover(proto::scene::PERFORMER_HOVER_M, 0.0),
                |s| performer_reference(s.state_at(t)),
            );
            self.world.set_reference(0, performer_ref);
            for (i, sp) in self.scheduler.setpoints_at(t).iter().enumerate() {
                self.world
                    .set_reference(i + 1, Reference::new(sp.kinematics(), sp.yaw_rad));
            }
            self.gust(t);
            self.world.step();
            let t = self.world.time_ns();
            if self.policy == Policy::Waggle && t.is_multiple_of(self.sample_period_ns) {
                sense(&mut self.world, self.renderer.as_mut(), &mut self.slots, t)?;
            }
        }
        Ok(())
    }

    /// The mission summary, checked against the case's expected outcome.
    fn summarise(
        &self,
        case: &Case,
        modality: Receiver,
        end_reason: EndReason,
        started: Instant,
    ) -> MissionSummary {
        let stats = self.scheduler.stats();
        let contact = self.world.contact_stats();
        let observers = self
            .slots
            .iter()
            .map(|s| {
                let services = stats.services.get(&s.id).map_or(Vec::new(), |v| {
                    v.iter().map(|(_, site)| site.to_string()).collect()
                });
                (s.name.clone(), s.summary(services))
            })
            .collect();
        let mut summary = MissionSummary {
            case: case.name.clone(),
            modality: format!("{modality:?}").to_lowercase(),
            observers,
            work_units: stats.work_units,
            mission_time_s: ns_s(self.world.time_ns()),
            end_reason: format!("{end_reason:?}"),
            contact_steps: contact.contact_steps,
            min_separation_m: contact.min_separation_m,
            provenance_violations: self.provenance_violations(),
            pass: false,
            reasons: Vec::new(),
            wall_seconds: started.elapsed().as_secs_f64(),
            viewpoints: BTreeMap::new(),
            deaf_observers: Vec::new(),
            flights: proto::FlightMode::default(),
        };
        crate::eval::summary::annotate_case(&mut summary, case);
        summary.reasons = check_expected(case, &summary);
        summary.pass = summary.reasons.is_empty();
        summary
    }

    /// The provenance audit of every accepted assignment against the scheduler's departures.
    fn provenance_violations(&self) -> Vec<String> {
        let departures: BTreeMap<(ObserverId, u32), u64> = self
            .scheduler
            .log()
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Departure {
                    observer, round, ..
                } => Some(((observer.clone(), *round), e.t_ns)),
                _ => None,
            })
            .collect();
        let mut violations = Vec::new();
        for slot in &self.slots {
            for d in slot.decisions.iter().filter(|d| d.assignment.is_some()) {
                if let Some(dep) = departures.get(&(slot.id.clone(), d.round))
                    && let Err(v) = proto::audit_assignment(d, *dep)
                {
                    violations.push(v.to_string());
                }
            }
        }
        violations
    }
}

/// The scheduler configured for `case`.
fn scheduler_for(case: &Case, modality: Modality) -> Result<Scheduler> {
    let sites: Vec<Site> = case
        .offer_sites
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let mut config = SchedulerConfig::new(case.observers, modality).with_offer_sites(&sites);
    config.rounds = case.rounds;
    config.flights = case.flights;
    if let Some(limit) = case.time_limit_s {
        config.time_limit_ns = Some((limit * 1e9).round() as u64);
    }
    Scheduler::new(config).context("configuring the scheduler")
}

fn sense(
    world: &mut World,
    mut renderer: Option<&mut CameraRenderer>,
    slots: &mut [Slot],
    t: u64,
) -> Result<()> {
    let performer_m = world.position_m(0);
    for slot in slots.iter_mut() {
        // The camera keeps running during flights (its events are part of the record); only
        // perception pauses outside reception windows.
        let outputs = match (&mut slot.sensor, renderer.as_deref_mut()) {
            (Some(sensor), Some(renderer)) => sensor.capture(world, renderer)?,
            _ => Vec::new(),
        };
        if slot.dropout_ns.is_some_and(|d| t > d) {
            // The stream is gone: nothing arrives. Perception learns of it once (in the
            // distributed runtime from the camera's liveliness token).
            if !slot.dropped && slot.agent.receiving() {
                let step = slot.perception.missing(t)?;
                slot.absorb(step, t);
            }
            slot.dropped = true;
            continue;
        }
        if !slot.agent.receiving() {
            continue;
        }
        let steps = match &mut slot.perception {
            Perception::Ideal { camera, decoder } => {
                let inside = camera.project_px(performer_m).filter(|p| {
                    p[0] >= 0.0
                        && p[1] >= 0.0
                        && p[0] < f64::from(IMAGE_WIDTH_PX)
                        && p[1] < f64::from(IMAGE_HEIGHT_PX)
                });
                let sample = match inside {
                    Some(p) if !slot.black => Sample::tracked(t, p),
                    _ => Sample::lost(t),
                };
                vec![decoder.push(sample)?]
            }
            Perception::Sensor(p) => {
                let mut steps = Vec::new();
                for output in outputs {
                    let output = match (output, slot.rgb_noise.as_mut()) {
                        (SensorOutput::Rgb(mut f), Some(noise)) => {
                            f.rgb = noise.apply(&[&f.rgb]);
                            SensorOutput::Rgb(f)
                        }
                        (o, _) => o,
                    };
                    if !slot.link.0.keeps(&mut slot.link.1) {
                        continue;
                    }
                    steps.push(match &output {
                        SensorOutput::Rgb(f) => p.push(SensorInput::Rgb(f))?,
                        SensorOutput::Events(e) => p.push(SensorInput::Events(e))?,
                    });
                }
                steps
            }
        };
        for step in steps {
            slot.absorb(step, t);
        }
    }
    Ok(())
}
