//! `sim-node events`: event statistics of the default scene under a short left–right motion.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use event_camera::picture::{Inset, encode_png, event_picture};
use proto::EventPacket;
use proto::Modality;
use proto::scene::{PERFORMER_HOVER_M, observer_name};
use serde::Serialize;
use sim::control::Reference;
use sim::render::CameraRenderer;
use sim::sensor::{EVENT_RENDER_PERIOD_NS, ObserverSensor, SensorOutput};
use sim::world::World;

/// Amplitude and period of the left–right motion.
const SWAY_M: f64 = 0.15;
const SWAY_PERIOD_S: f64 = 2.0;

#[derive(Debug, Default, Serialize)]
struct Stats {
    packets: u64,
    events: u64,
    on: u64,
    off: u64,
    first_seq: Option<u64>,
    last_seq: Option<u64>,
    contiguous: bool,
    last_end_ns: u64,
}

#[derive(Serialize)]
struct Summary {
    seconds: f64,
    observers: BTreeMap<String, Stats>,
}

fn sway(t_ns: u64) -> Reference {
    let w = std::f64::consts::TAU / SWAY_PERIOD_S;
    let t = t_ns as f64 * 1e-9;
    let (s, c) = (w * t).sin_cos();
    let mut r = Reference::hover(PERFORMER_HOVER_M, 0.0);
    r.kin.pos_m[0] += SWAY_M * s;
    r.kin.vel_mps[0] = SWAY_M * w * c;
    r.kin.acc_mps2[0] = -SWAY_M * w * w * s;
    r
}

pub fn run(observers: usize, seconds: f64, out: &Path, black: &[String]) -> Result<()> {
    if !(seconds.is_finite() && seconds > 0.0) {
        bail!("--seconds {seconds} must be a positive number");
    }
    let names: Vec<String> = (0..observers).map(observer_name).collect();
    for b in black {
        if !names.contains(b) {
            bail!("--black {b}: no such observer (have {})", names.join(", "));
        }
    }
    let mut world = World::new(observers).context("building the scene")?;
    let mut renderer = CameraRenderer::new(&world, sim::render::RenderPath::default())
        .context("creating the offscreen renderer")?;
    let mut sensors = (0..observers)
        .map(|i| ObserverSensor::new(Modality::Events, i, black.contains(&names[i])))
        .collect::<Result<Vec<_>, _>>()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let end_ns = (seconds * 1e9).round() as u64 / EVENT_RENDER_PERIOD_NS * EVENT_RENDER_PERIOD_NS;
    let mut stats: Vec<Stats> = (0..observers)
        .map(|_| Stats {
            contiguous: true,
            ..Stats::default()
        })
        .collect();
    let mut busiest: Vec<Option<EventPacket>> = vec![None; observers];
    loop {
        let t = world.time_ns();
        if t.is_multiple_of(EVENT_RENDER_PERIOD_NS) {
            for (i, sensor) in sensors.iter_mut().enumerate() {
                for output in sensor.capture(&mut world, &mut renderer)? {
                    let SensorOutput::Events(p) = output else {
                        continue;
                    };
                    let s = &mut stats[i];
                    if let Some(last) = s.last_seq {
                        s.contiguous &= p.seq == last + 1 && p.start_ns == s.last_end_ns;
                    }
                    s.first_seq.get_or_insert(p.seq);
                    s.last_seq = Some(p.seq);
                    s.last_end_ns = p.end_ns;
                    s.packets += 1;
                    s.events += p.len() as u64;
                    let on = (0..p.len())
                        .filter(|&k| p.polarity(k) == proto::Polarity::On)
                        .count() as u64;
                    s.on += on;
                    s.off += p.len() as u64 - on;
                    if busiest[i].as_ref().is_none_or(|b| p.len() > b.len()) {
                        busiest[i] = Some(p);
                    }
                }
            }
        }
        if t >= end_ns {
            break;
        }
        world.set_reference(0, sway(t));
        world.step();
    }
    for (i, packet) in busiest.iter().enumerate() {
        let Some(p) = packet else { continue };
        let picture = event_picture(p, Some(&Inset::paper(320, 240)))?;
        let path = out.join(format!("{}_busiest_packet.png", names[i]));
        std::fs::write(&path, encode_png(&picture)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let summary = Summary {
        seconds: end_ns as f64 * 1e-9,
        observers: names.iter().cloned().zip(stats).collect(),
    };
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(&summary)?)
        .with_context(|| format!("writing {}", path.display()))?;
    for (name, s) in &summary.observers {
        println!(
            "{name}: {} packets, {} events ({} ON / {} OFF), contiguous={}",
            s.packets, s.events, s.on, s.off, s.contiguous
        );
    }
    println!("wrote {}", path.display());
    Ok(())
}
