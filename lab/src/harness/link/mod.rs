//! `waggle link`: the in-process link harness.
//!
//! One process steps physics, flies the broadcast, renders each observer's camera at its
//! modality's rate and feeds each observer's receiver only its own sensor data. It is the fast
//! bench on which receivers are developed and tested without Zenoh.
//!
//! Decode success against viewing angle and distance is [`viewpoints`].

pub mod viewpoints;

use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use evaluation::IdealReceiver;
use perception::{Perception, SensorInput};
use proto::ReleasedFrame;
use proto::scene::{Formation, MAX_OBSERVERS, Placement, distance_m, observer_name};
use proto::{GestureConfig, Receiver, Rectification, RenderPath, Schedule, broadcast};
use proto::{SegmentToken, SegmenterConfig};
use serde::Serialize;
use sim::render::CameraRenderer;
use sim::sensor::{ObserverSensor, SensorOutput};
use sim::world::World;

use crate::harness::flight::performer::step_along;

/// What to fly and decode (the options of `waggle link`).
#[derive(Debug, Clone)]
pub struct LinkOptions {
    /// Number of observers (1..=8).
    pub observers: usize,
    /// Observer sensor modality.
    pub modality: Receiver,
    /// Six-bit payloads to broadcast back to back; none: the performer only hovers.
    pub payloads: Vec<u8>,
    /// Events modality: skip the acquisition sweep before the first offer (a control).
    pub no_acquisition: bool,
    /// Seconds to hover when no payload is given.
    pub hover_s: f64,
    /// Observers whose camera is black from start-up.
    pub black: Vec<String>,
    /// How cameras render.
    pub render: RenderPath,
    /// Observers placed at these viewpoints instead of the built-in formation of `observers`.
    pub viewpoints: Vec<Placement>,
    /// Receivers' (and the ideal receiver's) viewpoint rectification.
    pub rectification: Rectification,
    /// Events modality: write each observer's events to `DIR/<observer>.raw` (EVT 3.0).
    pub events_raw: Option<std::path::PathBuf>,
    /// The check every frame carries after its payload.
    pub frame_check: proto::FrameCheck,
}

impl LinkOptions {
    /// The broadcast to fly (with the acquisition sweep for event cameras) and when the
    /// harness stops: the schedule's end (or the hover) plus the tail.
    pub fn schedule(&self) -> Result<(Schedule, u64)> {
        let acquisition =
            self.modality == Receiver::Events && !self.no_acquisition && !self.payloads.is_empty();
        let hover_ns = if self.payloads.is_empty() {
            (self.hover_s * 1e9).round() as u64
        } else {
            0
        };
        broadcast_schedule(&self.payloads, acquisition, hover_ns, self.frame_check)
    }

    /// The observers' placements: the viewpoints if given, else the built-in formation.
    pub fn formation(&self) -> Result<Formation> {
        if self.viewpoints.is_empty() {
            Formation::standard(self.observers).map_err(|_| {
                anyhow::anyhow!(
                    "--observers {} is outside 1..={MAX_OBSERVERS}",
                    self.observers
                )
            })
        } else {
            Formation::custom(self.viewpoints.clone()).context("--viewpoint")
        }
    }
}

/// The performer's broadcast of `payloads` after the lead-in (with the acquisition sweep
/// first when asked) and when a harness stops: its end, or the lead-in plus `hover_ns`,
/// whichever is later, plus the tail.
pub(crate) fn broadcast_schedule(
    payloads: &[u8],
    acquisition: bool,
    hover_ns: u64,
    check: proto::FrameCheck,
) -> Result<(Schedule, u64)> {
    let schedule = broadcast(
        LEAD_IN_NS,
        payloads,
        acquisition,
        &GestureConfig::default(),
        check,
    )
    .context("building the broadcast schedule")?;
    let end_ns = schedule.end_ns().max(LEAD_IN_NS + hover_ns) + TAIL_NS;
    Ok((schedule, end_ns))
}

pub(crate) fn bits6(payload: u8) -> String {
    format!("{payload:06b}")
}

/// Time after the last scheduled symbol that the harness keeps running, so a late NULL can land.
pub(crate) const TAIL_NS: u64 = 2_000_000_000;
/// Hover before the first symbol so physics and receivers settle.
pub(crate) const LEAD_IN_NS: u64 = 1_000_000_000;
/// The ideal receiver samples at the RGB rate.
pub(crate) const IDEAL_PERIOD_NS: u64 = 40_000_000;

pub use run_format::link_out::{FrameOut, ObserverOut, TokenOut};

/// What `waggle link --json` prints.
#[derive(Debug, Serialize)]
pub struct LinkOut {
    pub modality: String,
    pub observers: BTreeMap<String, ObserverOut>,
    pub sim_seconds: f64,
    pub wall_seconds: f64,
    pub performer_max_tracking_error_m: f64,
    /// The ideal receiver's output for the same flight (rgb/events runs only), for comparison.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ideal: Option<BTreeMap<String, ObserverOut>>,
    pub contact_steps: u64,
}

/// One observer's sensor and receiver.
struct Chain {
    sensor: ObserverSensor,
    perception: Perception,
    tokens: Vec<SegmentToken>,
    frames: Vec<ReleasedFrame>,
    /// With `--events-raw`: every event this observer's camera produced.
    events: Option<Vec<event_camera::Event>>,
}

fn ns_to_s(ns: u64) -> f64 {
    ns as f64 * 1e-9
}

pub(crate) fn observer_out(tokens: &[SegmentToken], frames: &[ReleasedFrame]) -> ObserverOut {
    ObserverOut {
        payloads: frames.iter().map(|f| bits6(f.payload)).collect(),
        frames: frames
            .iter()
            .map(|f| FrameOut {
                payload: bits6(f.payload),
                final_null_s: ns_to_s(*f.token_stamps_ns.last().unwrap_or(&0)),
            })
            .collect(),
        tokens: tokens
            .iter()
            .map(|t| TokenOut {
                token: format!("{:?}", t.token).to_uppercase(),
                t_s: ns_to_s(t.stamp_ns),
            })
            .collect(),
    }
}

/// Flies `schedule` in physics, calling `sample(world)` at every multiple of `period_ns`.
/// Returns the performer's largest distance from its commanded position.
fn fly(
    world: &mut World,
    schedule: &Schedule,
    end_ns: u64,
    period_ns: u64,
    mut sample: impl FnMut(&mut World) -> Result<()>,
) -> Result<f64> {
    let mut max_err_m: f64 = 0.0;
    while world.time_ns() < end_ns {
        step_along(world, schedule);
        let t = world.time_ns();
        let err = distance_m(schedule.setpoint_at(t), world.position_m(0));
        max_err_m = max_err_m.max(err);
        if t.is_multiple_of(period_ns) {
            sample(world)?;
        }
    }
    Ok(max_err_m)
}

/// Checks the options; the observers' names.
fn check(args: &LinkOptions, formation: &Formation) -> Result<Vec<String>> {
    let names: Vec<String> = (0..formation.len()).map(observer_name).collect();
    for b in &args.black {
        if !names.contains(b) {
            bail!("--black {b}: no such observer (have {})", names.join(", "));
        }
    }
    if !(args.hover_s.is_finite() && args.hover_s >= 0.0) {
        bail!("--hover-s {} must be a non-negative number", args.hover_s);
    }
    Ok(names)
}

/// Each observer's sensor and receiver (none for the ideal receiver).
fn chains(args: &LinkOptions, formation: &Formation, black: &[bool]) -> Result<Vec<Chain>> {
    let Some(kind) = args.modality.sensor() else {
        return Ok(Vec::new());
    };
    formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, p)| -> Result<Chain> {
            let mut perception = Perception::for_camera(kind, p.camera(), args.rectification)?;
            perception.set_frame_check(args.frame_check);
            Ok(Chain {
                sensor: ObserverSensor::new(kind, i, black[i])?,
                perception,
                tokens: Vec::new(),
                frames: Vec::new(),
                events: args.events_raw.as_ref().map(|_| Vec::new()),
            })
        })
        .collect()
}

/// Writes each observer's events to `dir/<name>.raw` (EVT 3.0).
pub(crate) fn write_raws<'a>(
    dir: &std::path::Path,
    names: &[String],
    events: impl Iterator<Item = &'a [event_camera::Event]>,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for (name, events) in names.iter().zip(events) {
        crate::harness::flight::raw::write_raw(&dir.join(format!("{name}.raw")), events)?;
    }
    Ok(())
}

/// Flies the broadcast and decodes it with every observer's receiver (and the ideal one).
pub fn fly_link(args: &LinkOptions) -> Result<LinkOut> {
    let formation = args.formation()?;
    let names = check(args, &formation)?;
    let started = Instant::now();
    let (schedule, end_ns) = args.schedule()?;
    let mut world = World::with_formation(&formation).context("building the scene")?;

    let ideal_config = if args.modality == Receiver::Events {
        SegmenterConfig::events()
    } else {
        SegmenterConfig::rgb()
    };
    let mut ideal = IdealReceiver::with_formation(&formation, ideal_config, args.rectification)?;
    ideal.set_frame_check(args.frame_check);
    let black: Vec<bool> = names.iter().map(|n| args.black.contains(n)).collect();
    let mut chains = chains(args, &formation, &black)?;
    let mut renderer = if chains.is_empty() {
        None
    } else {
        Some(CameraRenderer::new(&world, args.render).context("creating the offscreen renderer")?)
    };
    let period_ns = chains
        .first()
        .map_or(IDEAL_PERIOD_NS, |c| c.sensor.render_period_ns());
    let max_err_m = fly(&mut world, &schedule, end_ns, period_ns, |w| {
        let t = w.time_ns();
        if t.is_multiple_of(IDEAL_PERIOD_NS) {
            ideal.push(t, w.position_m(0))?;
            for (i, &b) in black.iter().enumerate() {
                if b {
                    ideal.interrupt(i, t)?;
                }
            }
        }
        if let Some(renderer) = renderer.as_mut() {
            for chain in &mut chains {
                chain.sample(w, renderer)?;
            }
        }
        Ok(())
    })?;
    if let Some(dir) = &args.events_raw {
        write_raws(
            dir,
            &names,
            chains.iter().filter_map(|c| c.events.as_deref()),
        )?;
    }
    let ideal_outs: Vec<ObserverOut> = ideal
        .outputs()
        .iter()
        .map(|o| observer_out(&o.tokens, &o.frames))
        .collect();
    let (outputs, ideal_tokens) = if chains.is_empty() {
        (ideal_outs, None)
    } else {
        let outs = chains
            .iter()
            .map(|c| observer_out(&c.tokens, &c.frames))
            .collect();
        (outs, Some(names.iter().cloned().zip(ideal_outs).collect()))
    };
    Ok(LinkOut {
        modality: format!("{:?}", args.modality).to_lowercase(),
        observers: names.iter().cloned().zip(outputs).collect(),
        sim_seconds: ns_to_s(world.time_ns()),
        wall_seconds: started.elapsed().as_secs_f64(),
        performer_max_tracking_error_m: max_err_m,
        ideal: ideal_tokens,
        contact_steps: world.contact_stats().contact_steps,
    })
}

impl Chain {
    /// Captures this observer's sensor now and feeds its receiver.
    fn sample(&mut self, world: &mut World, renderer: &mut CameraRenderer) -> Result<()> {
        for output in self.sensor.capture(world, renderer)? {
            let step = match &output {
                SensorOutput::Rgb(f) => self.perception.push(SensorInput::Rgb(f))?,
                SensorOutput::Events(p) => {
                    if let Some(events) = self.events.as_mut() {
                        crate::harness::flight::raw::packet_events(p, events);
                    }
                    self.perception.push(SensorInput::Events(p))?
                }
            };
            self.tokens.extend(step.tokens);
            self.frames.extend(step.frames);
        }
        Ok(())
    }
}

/// Prints the link's table (`waggle link` without `--json`).
pub fn print_table(out: &LinkOut) {
    println!(
        "link ({}) — {:.2} s simulated in {:.2} s wall; performer tracking error ≤ {:.2} mm",
        out.modality,
        out.sim_seconds,
        out.wall_seconds,
        out.performer_max_tracking_error_m * 1e3
    );
    for (name, o) in &out.observers {
        let frames: Vec<String> = o
            .frames
            .iter()
            .map(|f| format!("{} @ {:.2} s", f.payload, f.final_null_s))
            .collect();
        println!(
            "{name}: {} tokens; released: {}",
            o.tokens.len(),
            if frames.is_empty() {
                "none".into()
            } else {
                frames.join(", ")
            }
        );
        let toks: Vec<String> = o
            .tokens
            .iter()
            .map(|t| format!("{}@{:.2}", t.token, t.t_s))
            .collect();
        println!("    {}", toks.join(" "));
    }
}
