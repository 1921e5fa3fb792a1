//! `waggle mission`: a whole case in one process (physics, cameras, performer, observers,
//! scheduler), stepped in exactly the lockstep order of the processes (docs/DESIGN.md §3), so
//! that `waggle mission CASE` and `waggle run CASE` write the same `observers.json`:
//!
//! Per tick k (40 ms): every observer processes tick k through the one observer core
//! (`perception::observer`) — its packet k, or the knowledge that it is missing — and its
//! decision goes to the scheduler; the scheduler steps with the truth at t_k and emits session
//! controls (applied by the observers before packet k+1), a broadcast to the performer and
//! the observers' setpoints; physics steps to t_{k+1} with the performer's and the scheduler's
//! references of t_k extrapolated inside the tick (`sim::lockstep`), and at every render
//! instant the cameras render the published truth mirrored into their own world, as the camera
//! processes do.
//!
//! Its parts: the mission's metrics from the scheduler's log ([`metrics`]), one observer of it
//! ([`observer`]), how a mission is flown beyond its case ([`options`]) and seeded trials of
//! whole missions ([`trials`]).

pub mod metrics;
pub mod observer;
pub mod options;
pub mod trials;

pub use crate::harness::mission::options::MissionOptions;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::{Context, Result};
use perturb::seed::{Stream, rng};
use proto::EndReason;
use proto::clock::EVENT_RENDER_PERIOD_NS;
use proto::{ClockTick, Modality, ObserverId, RenderPath, Site, TICK_NS};
use proto::{GestureConfig, Schedule, broadcast, performer_setpoint};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use scheduler::{DecisionNotice, EventKind, Scheduler, SchedulerConfig, observer_positions};
use sim::lockstep::{TickReferences, mirror, sim_state};
use sim::render::CameraRenderer;
use sim::world::World;

use crate::harness::flight::air::{set_air, tracking_of};
use crate::harness::mission::metrics::{MissionMetrics, measure};
use crate::harness::mission::observer::MissionObserver;
use commands::Policy;
use proto::Receiver;
use run_eval::summary::{check_expected, ns_s, provenance_violations};
use run_format::case::Case;
use run_format::run_dir::{MissionSummary, ObserverRecord, ObserverSummary, OfferReception};

/// What a flown mission gives: its summary, its outcome measures and every observer's record
/// (`observers.json`).
#[derive(Debug, Clone)]
pub struct MissionRun {
    pub summary: MissionSummary,
    pub metrics: MissionMetrics,
    pub observers: BTreeMap<String, ObserverRecord>,
    /// Observers whose plug-in receiver failed, and why (the mission went on with them deaf).
    pub receiver_failures: BTreeMap<String, String>,
    /// What became of the offers flown to each observer.
    pub receptions: BTreeMap<String, OfferReception>,
    /// With [`MissionOptions::keep_events`]: each event camera's events, by observer.
    pub events: BTreeMap<String, Vec<event_camera::Event>>,
}

/// Flies `case` with every observer on `modality`'s receiver, in one process.
pub fn fly_case(case: &Case, modality: Receiver, render: RenderPath) -> Result<MissionSummary> {
    let opts = MissionOptions {
        render,
        ..MissionOptions::default()
    };
    Ok(fly_case_with(case, modality, &opts)?
        .context("the mission was interrupted")?
        .summary)
}

/// [`fly_case`] under `opts`, with the outcome measures and the observers' records. `None`
/// when `opts.stop` was raised before the mission ended.
pub fn fly_case_with(
    case: &Case,
    modality: Receiver,
    opts: &MissionOptions,
) -> Result<Option<MissionRun>> {
    opts.check(modality)?;
    if let Some(r) = opts
        .receivers
        .iter()
        .find(|r| !case.has_observer(r.observer.as_str()))
    {
        anyhow::bail!(
            "a receiver is given to {}, which is not one of the case's {} observers",
            r.observer.as_str(),
            case.observers
        );
    }
    let started = Instant::now();
    let mut mission = Mission::new(case, modality, opts)?;
    let Some(end_reason) = mission.fly(opts.stop.as_deref())? else {
        return Ok(None);
    };
    let mut metrics = measure(&mission.scheduler, opts.policy, mission.world.time_ns());
    if mission.air {
        metrics.performer_tracking = Some(tracking_of(&mission.world, 0));
    }
    let summary = mission.summarise(case, modality, end_reason, started);
    let names: Vec<String> = mission.observers.iter().map(|o| o.name.clone()).collect();
    let receptions = run_eval::summary::offer_receptions(
        &names,
        mission.observers.iter().flat_map(|o| &o.record.frames),
        &mission.flown,
        &summary.false_releases,
    );
    let receiver_failures = mission
        .observers
        .iter()
        .filter_map(|o| Some((o.name.clone(), o.receiver_failure()?)))
        .collect();
    let mut events = BTreeMap::new();
    let mut observers = BTreeMap::new();
    for o in mission.observers {
        if let Some(kept) = o.events {
            events.insert(o.name.clone(), kept);
        }
        observers.insert(o.name, o.record);
    }
    Ok(Some(MissionRun {
        summary,
        metrics,
        observers,
        receiver_failures,
        receptions,
        events,
    }))
}

/// What the scheduler's tick leads to.
enum Scheduled {
    /// Physics steps on with these references.
    Fly(TickReferences),
    /// The mission ended in this tick.
    End(EndReason),
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
    /// The cameras' copy of the world, posed from the published truth at each render instant.
    camera_world: Option<World>,
    scheduler: Scheduler,
    renderer: Option<CameraRenderer>,
    observers: Vec<MissionObserver>,
    alive: BTreeSet<ObserverId>,
    gesture: GestureConfig,
    /// The performer's current broadcast.
    performer: Option<Schedule>,
    /// What it flew, round by round (false releases).
    flown: BTreeMap<u32, Vec<u8>>,
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
        let n = case.observers;
        let mut world = World::new(n).context("building the scene")?;
        let air = set_air(&mut world, &opts.perturbation, opts.seed)?;
        // The ideal baseline flies the RGB broadcast (no acquisition preamble).
        let sched_modality = modality.sensor().unwrap_or(Modality::Rgb);
        let scheduler = scheduler_for(case, sched_modality)?;
        let (camera_world, renderer) = match modality {
            // The fixed policy reads no sensor: nothing to render.
            _ if opts.policy == Policy::Fixed => (None, None),
            Receiver::Ideal => (None, None),
            Receiver::Rgb | Receiver::Events => {
                let camera_world = World::new(n).context("building the cameras' scene")?;
                let renderer = CameraRenderer::new(&camera_world, opts.render)
                    .context("creating the offscreen renderer")?;
                (Some(camera_world), Some(renderer))
            }
        };
        let observers = (0..n)
            .map(|i| MissionObserver::new(case, modality, i, opts, world.body_pose(i + 1).1))
            .collect::<Result<Vec<_>>>()?;
        let alive = observers.iter().map(|o| o.id.clone()).collect();
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
            camera_world,
            scheduler,
            renderer,
            observers,
            alive,
            gesture: GestureConfig::default(),
            performer: None,
            flown: BTreeMap::new(),
            tick: 0,
        })
    }

    /// Runs tick after tick until the scheduler ends the mission (`None`: `stop` was raised).
    fn fly(&mut self, stop: Option<&AtomicBool>) -> Result<Option<EndReason>> {
        loop {
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                return Ok(None);
            }
            let decisions = self.observe()?;
            match self.schedule(decisions)? {
                Scheduled::Fly(references) => self.physics_and_sensing(&references)?,
                Scheduled::End(reason) => return Ok(Some(reason)),
            }
            self.tick += 1;
        }
    }

    /// Every observer processes the current tick; their decisions, sorted as the scheduler
    /// process sorts what the statuses carry.
    fn observe(&mut self) -> Result<Vec<DecisionNotice>> {
        let mut decisions = Vec::new();
        if self.policy == Policy::Waggle {
            for o in &mut self.observers {
                if let Some(d) = o.tick(self.tick)? {
                    decisions.push(DecisionNotice::from(&d));
                }
            }
        }
        self.fixed_decisions(&mut decisions);
        decisions.sort();
        Ok(decisions)
    }

    /// The scheduler at t_k with the tick's decisions: session controls to the observers, a
    /// new broadcast to the performer; the tick's references, or the end of the mission.
    fn schedule(&mut self, decisions: Vec<DecisionNotice>) -> Result<Scheduled> {
        let truth = sim_state(&self.world, self.tick);
        let positions = observer_positions(&truth);
        let clock = ClockTick::at(self.tick).context("tick overflow")?;
        let out = self.scheduler.step(&scheduler::SchedulerInput {
            clock,
            positions_m: &positions,
            decisions: &decisions,
            alive: &self.alive,
        })?;
        for o in &mut self.observers {
            o.session(self.tick, out.session.clone());
        }
        if let Some(plan) = &out.broadcast {
            if self.policy == Policy::Fixed {
                // Decided without reading the broadcast, on the first tick after it started.
                self.fixed_due = Some((plan.round, plan.start_ns + TICK_NS));
            }
            let payloads: Vec<u8> = plan.offers.iter().map(|o| o.to_payload()).collect();
            self.flown.entry(plan.round).or_default().extend(&payloads);
            self.performer = Some(broadcast(
                plan.start_ns,
                &payloads,
                plan.acquisition,
                &self.gesture,
                self.scheduler.config().frame_check,
            )?);
        }
        if let Some(reason) = out.mission_end {
            return Ok(Scheduled::End(reason));
        }
        let setpoint = performer_setpoint(self.performer.as_ref(), self.tick);
        Ok(Scheduled::Fly(TickReferences::new(
            &self.world,
            &setpoint,
            &out.command(),
        )))
    }

    /// Fixed policy: once a round's decisions fall due, every live observer takes its site.
    fn fixed_decisions(&mut self, decisions: &mut Vec<DecisionNotice>) {
        let Some((round, due_ns)) = self.fixed_due else {
            return;
        };
        if self.world.time_ns() < due_ns {
            return;
        }
        self.fixed_due = None;
        for (o, site) in self.observers.iter().zip(&self.fixed_sites) {
            decisions.push(DecisionNotice {
                observer: o.id.clone(),
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
    fn physics_and_sensing(&mut self, references: &TickReferences) -> Result<()> {
        let tick_end = self.world.time_ns() + TICK_NS;
        let next = self.tick + 1;
        while self.world.time_ns() < tick_end {
            references.apply(&mut self.world);
            self.gust(self.world.time_ns());
            self.world.step();
            let t = self.world.time_ns();
            if self.policy == Policy::Waggle && t.is_multiple_of(EVENT_RENDER_PERIOD_NS) {
                self.sense(next)?;
            }
        }
        Ok(())
    }

    /// Every observer's sensor at the current render instant (part of tick `tick`).
    fn sense(&mut self, tick: u64) -> Result<()> {
        let truth = sim_state(&self.world, tick);
        if let Some(camera_world) = self.camera_world.as_mut() {
            mirror(camera_world, &truth)?;
        }
        for o in &mut self.observers {
            match (self.camera_world.as_mut(), self.renderer.as_mut()) {
                (Some(w), Some(r)) => o.sense(&truth, w, Some(r))?,
                _ => {
                    // The ideal baseline renders nothing; it reads the truth alone.
                    let w = &mut self.world;
                    o.sense(&truth, w, None)?
                }
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
            .observers
            .iter()
            .map(|o| {
                let services = stats.services.get(&o.id).cloned().unwrap_or_default();
                let summary = ObserverSummary::from_record(
                    &o.record.frames,
                    &o.record.decisions,
                    &services,
                    o.record.tokens.len(),
                );
                (o.name.clone(), summary)
            })
            .collect();
        let mut summary = MissionSummary {
            case: case.name.clone(),
            modality: Some(modality),
            observers,
            work_units: stats.work_units,
            mission_time_s: ns_s(self.world.time_ns()),
            end_reason: Some(end_reason),
            contact_steps: contact.contact_steps,
            min_separation_m: contact.min_separation_m,
            provenance_violations: self.provenance_violations(),
            pass: false,
            reasons: Vec::new(),
            wall_seconds: started.elapsed().as_secs_f64(),
            viewpoints: BTreeMap::new(),
            deaf_observers: Vec::new(),
            flights: proto::FlightMode::default(),
            false_releases: run_eval::summary::false_releases(
                self.observers.iter().flat_map(|o| &o.record.frames),
                &self.flown,
            ),
        };
        run_eval::summary::annotate_case(&mut summary, case);
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
        self.observers
            .iter()
            .flat_map(|o| provenance_violations(&o.record.decisions, &departures))
            .collect()
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
    config.work = case.work_units()?;
    config.max_broadcasts = case.max_broadcasts;
    config.frame_check = case.frame_check;
    config.flights = case.flights;
    if let Some(limit) = case.time_limit_s {
        config.time_limit_ns = Some((limit * 1e9).round() as u64);
    }
    Scheduler::new(config).context("configuring the scheduler")
}
