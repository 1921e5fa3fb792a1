//! `waggle mission`: a whole case in one process (physics, cameras, performer, observers,
//! scheduler), stepped in the lockstep order of DESIGN.md §3. It is the reference the
//! distributed runtime must reproduce, and the fast way to run a case while developing.
//!
//! Per tick k (40 ms): the scheduler consumes the decisions observers made from data up to t_k
//! and emits session controls, a broadcast and flight setpoints; then physics steps to t_{k+1},
//! and at every render instant in (t_k, t_{k+1}] each observer's sensor delivers its own data to
//! its own perception and agent only.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use perception::agent::{AgentFrame, FrameOutcome, ObserverAgent};
use perception::perception::SensorInput;
use proto::{DecodeStep, Decoder, Sample, SegmentToken, SegmenterConfig};
use proto::{GestureConfig, Schedule, broadcast};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, LevelCamera, observer_name};
use proto::{ClockTick, Modality, ObserverId, Roster, Site, TICK_NS};
use scheduler::{DecisionNotice, EventKind, Scheduler, SchedulerConfig};
use sim::control::Reference;
use sim::render::CameraRenderer;
use sim::sensor::{ObserverSensor, SensorOutput};
use sim::world::World;

use crate::case::{Case, Receiver};
use crate::performer_flight::performer_reference;
use crate::summary::{MissionSummary, ObserverSummary, check_expected, ns_s, print_summary};

#[derive(Debug, Args)]
pub struct MissionArgs {
    /// Built-in case name (one-observer, two-observers, nominal-3, black-o2, no-broadcast,
    /// only-a, dropout-o2) or a path to a case TOML file.
    case: String,
    /// Observer sensor modality (`ideal` is the ground-truth baseline).
    #[arg(long, value_enum, default_value_t = Receiver::Events)]
    modality: Receiver,
    /// Write DIR/summary.json here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// One observer's perception chain.
enum Perception {
    /// Ground truth projected into the home camera (evaluation baseline).
    Ideal {
        camera: LevelCamera,
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
    black: bool,
    dropout_ns: Option<u64>,
    dropped: bool,
    tokens: Vec<SegmentToken>,
    frames: Vec<AgentFrame>,
    pending: Vec<DecisionNotice>,
    decisions: Vec<proto::Decision>,
}

impl Slot {
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

pub fn run(args: MissionArgs) -> Result<()> {
    let case = Case::load(&args.case)?;
    if !case.modalities.contains(&args.modality) && args.modality != Receiver::Ideal {
        bail!(
            "case {} does not apply to the {:?} modality (it lists {:?})",
            case.name,
            args.modality,
            case.modalities
        );
    }
    let summary = fly_case(&case, args.modality)?;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join("summary.json");
        std::fs::write(&path, serde_json::to_string_pretty(&summary)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary);
    }
    if !summary.pass {
        bail!(
            "case {} did not meet its expected outcome: {}",
            summary.case,
            summary.reasons.join("; ")
        );
    }
    Ok(())
}

pub fn fly_case(case: &Case, modality: Receiver) -> Result<MissionSummary> {
    let started = Instant::now();
    let n = case.observers;
    let mut world = World::new(n).context("building the scene")?;
    // The ideal baseline flies the RGB broadcast (no acquisition preamble).
    let sched_modality = modality.sensor().unwrap_or(Modality::Rgb);
    let sites: Vec<Site> = case
        .offer_sites
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let mut config = SchedulerConfig::new(n, sched_modality).with_offer_sites(&sites);
    config.rounds = case.rounds;
    if let Some(limit) = case.time_limit_s {
        config.time_limit_ns = Some((limit * 1e9).round() as u64);
    }
    let mut scheduler = Scheduler::new(config).context("configuring the scheduler")?;
    let gesture = GestureConfig::default();
    let roster = Roster::default_scene(n);

    let mut renderer = match modality {
        Receiver::Ideal => None,
        Receiver::Rgb | Receiver::Events => {
            Some(CameraRenderer::new(&world).context("creating the offscreen renderer")?)
        }
    };
    let mut slots = Vec::with_capacity(n);
    for i in 0..n {
        let name = observer_name(i);
        let id = ObserverId::new(name.clone())?;
        let black = case.black(&name);
        let (perception, sensor) = match modality {
            Receiver::Ideal => (
                Perception::Ideal {
                    camera: LevelCamera::at_home(i, n),
                    decoder: Box::new(Decoder::new(SegmenterConfig::rgb())?),
                },
                None,
            ),
            Receiver::Rgb | Receiver::Events => {
                let kind = sched_modality;
                let m = kind;
                (
                    Perception::Sensor(Box::new(perception::perception::Perception::new(m)?)),
                    Some(kind),
                )
            }
        };
        slots.push(Slot {
            agent: ObserverAgent::new(id.clone(), roster.clone()),
            dropout_ns: case.dropout_ns(&name),
            name,
            id,
            perception,
            sensor: sensor
                .map(|k| ObserverSensor::new(k, i, black))
                .transpose()?,
            black,
            dropped: false,
            tokens: Vec::new(),
            frames: Vec::new(),
            pending: Vec::new(),
            decisions: Vec::new(),
        });
    }
    let sample_period_ns = slots
        .first()
        .and_then(|s| s.sensor.as_ref())
        .map_or(TICK_NS, ObserverSensor::render_period_ns);
    let alive: BTreeSet<ObserverId> = slots.iter().map(|s| s.id.clone()).collect();

    let mut performer: Option<Schedule> = None;
    let mut tick = 0u64;
    let end_reason = loop {
        // Scheduler at t_k with the decisions made from data up to t_k.
        let now = world.time_ns();
        let positions: BTreeMap<ObserverId, [f64; 3]> = slots
            .iter()
            .enumerate()
            .map(|(i, s)| (s.id.clone(), world.position_m(i + 1)))
            .collect();
        let decisions: Vec<DecisionNotice> =
            slots.iter_mut().flat_map(|s| s.pending.drain(..)).collect();
        let clock = ClockTick::at(tick).context("tick overflow")?;
        let out = scheduler.step(&scheduler::TickInput {
            clock,
            positions_m: &positions,
            decisions: &decisions,
            alive: &alive,
        })?;
        for control in &out.session {
            for slot in &mut slots {
                if slot.agent.on_session(control.event) {
                    slot.perception.reset();
                }
            }
        }
        if let Some(plan) = &out.broadcast {
            let payloads: Vec<u8> = plan.offers.iter().map(|o| o.to_payload()).collect();
            performer = Some(broadcast(
                plan.start_ns,
                &payloads,
                plan.acquisition,
                &gesture,
            )?);
        }
        if let Some(reason) = out.mission_end {
            break reason;
        }
        // Physics and sensing over (t_k, t_{k+1}].
        let tick_end = now + TICK_NS;
        while world.time_ns() < tick_end {
            let t = world.time_ns();
            let performer_ref = performer.as_ref().map_or(
                Reference::hover(proto::scene::PERFORMER_HOVER_M, 0.0),
                |s| performer_reference(s.state_at(t)),
            );
            world.set_reference(0, performer_ref);
            for (i, sp) in scheduler.setpoints_at(t).iter().enumerate() {
                world.set_reference(
                    i + 1,
                    Reference {
                        pos_m: sp.pos_m,
                        vel_mps: sp.vel_mps,
                        acc_mps2: sp.acc_mps2,
                        yaw_rad: sp.yaw_rad,
                    },
                );
            }
            world.step();
            let t = world.time_ns();
            if t.is_multiple_of(sample_period_ns) {
                sense(&mut world, renderer.as_mut(), &mut slots, t)?;
            }
        }
        tick += 1;
    };

    let stats = scheduler.stats();
    let departures: BTreeMap<(ObserverId, u32), u64> = scheduler
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
    for slot in &slots {
        for d in slot.decisions.iter().filter(|d| d.assignment.is_some()) {
            if let Some(dep) = departures.get(&(slot.id.clone(), d.round))
                && let Err(v) = proto::audit_assignment(d, *dep)
            {
                violations.push(v.to_string());
            }
        }
    }
    let contact = world.contact_stats();
    let observers: BTreeMap<String, ObserverSummary> = slots
        .iter()
        .map(|s| {
            let complete: Vec<&AgentFrame> = s
                .frames
                .iter()
                .filter(|f| matches!(f.outcome, FrameOutcome::Cached(_)))
                .collect();
            let summary = ObserverSummary {
                complete_messages: complete.len(),
                payloads: s
                    .frames
                    .iter()
                    .map(|f| format!("{:06b}", f.frame.payload))
                    .collect(),
                final_null_s: s
                    .frames
                    .iter()
                    .map(|f| ns_s(f.frame.final_null_ns()))
                    .collect(),
                decisions: s
                    .decisions
                    .iter()
                    .map(|d| {
                        format!(
                            "r{}:{}",
                            d.round,
                            d.assignment.map_or("-".to_string(), |x| x.to_string())
                        )
                    })
                    .collect(),
                services: stats.services.get(&s.id).map_or(Vec::new(), |v| {
                    v.iter().map(|(_, site)| site.to_string()).collect()
                }),
                tokens: s.tokens.len(),
            };
            (s.name.clone(), summary)
        })
        .collect();
    let mut summary = MissionSummary {
        case: case.name.clone(),
        modality: format!("{modality:?}").to_lowercase(),
        observers,
        work_units: stats.work_units,
        mission_time_s: ns_s(world.time_ns()),
        end_reason: format!("{end_reason:?}"),
        contact_steps: contact.contact_steps,
        min_separation_m: contact.min_separation_m,
        provenance_violations: violations,
        pass: false,
        reasons: Vec::new(),
        wall_seconds: started.elapsed().as_secs_f64(),
    };
    summary.reasons = check_expected(case, &summary);
    summary.pass = summary.reasons.is_empty();
    Ok(summary)
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
            Perception::Sensor(p) => outputs
                .iter()
                .map(|output| match output {
                    SensorOutput::Rgb(f) => p.push(SensorInput::Rgb(f)),
                    SensorOutput::Events(e) => p.push(SensorInput::Events(e)),
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        for step in steps {
            slot.absorb(step, t);
        }
    }
    Ok(())
}
