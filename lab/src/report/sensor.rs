//! The sensor-comparison figure (paper, Figure "sensor-comparison"): for one observer camera,
//! the MuJoCo RGB render beside the 40 ms event packet that ends at the same instant, during
//! the acquisition motion, the acquired quiet and a bit-0 symbol.
//!
//! Produced in-process with the libraries the processes use — `World` physics, the performer's
//! broadcast schedule, `CameraRenderer` and the `event_camera` converter fed every 100 Hz render
//! from t = 0 (the converter's reference levels depend on the whole history) — the way
//! `waggle link` drives them; not read back from a recording.

use std::path::Path;

use anyhow::{Context, Result, bail};
use event_camera::picture::{
    Inset, RgbImage, encode_png, event_picture, filled, from_rgb, with_inset,
};
use event_camera::{CameraConfig, EventCamera};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, ObserverCamera, observer_name};
use proto::{Action, EventPacket, Polarity, TICK_NS};
use proto::{TruthSymbol, paper_broadcast};
use sim::render::CameraRenderer;
use sim::sensor::EVENT_RENDER_PERIOD_NS;
use sim::world::World;

use crate::harness::flight::performer::step_along;
use run_eval::summary::ns_s;

/// The scheduler's first broadcast starts here (tick 125 of every case with a broadcast).
pub const BROADCAST_START_NS: u64 = 5_000_000_000;
/// Round 1's first offer of the three-observer case: A `011010`, whose first bit is 0.
const FIRST_OFFER: u8 = 0b011010;

/// One column of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorColumn {
    pub label: &'static str,
    /// End of the packet and instant of the render.
    pub t_ns: u64,
    pub events: usize,
    pub on_events: usize,
    pub inset_px: [u32; 2],
}

fn align_tick(t_ns: u64) -> u64 {
    t_ns / TICK_NS * TICK_NS
}

/// Renders the figure for observer index `observer` of `observers` into `png_path`.
pub fn sensor_comparison(
    observers: usize,
    observer: usize,
    png_path: &Path,
) -> Result<Vec<SensorColumn>> {
    let schedule = paper_broadcast(BROADCAST_START_NS, &[FIRST_OFFER], true)
        .context("building the broadcast schedule")?;
    let timeline = schedule.timeline();
    let acquisition = timeline
        .iter()
        .find(|s| s.symbol == TruthSymbol::Acquisition)
        .context("the schedule has no acquisition motion")?;
    // The first offer's leading NULL hover is the quiet after the acquisition motion.
    let quiet = timeline
        .iter()
        .find(|s| s.symbol == TruthSymbol::Null && s.start_ns >= acquisition.end_ns)
        .context("the schedule has no NULL hover after the acquisition motion")?;
    let bit0 = timeline
        .iter()
        .find(|s| s.symbol == TruthSymbol::Action(Action::Bit0))
        .context("the offer has no bit 0")?;
    let instants = [
        (
            "acquisition motion",
            align_tick((acquisition.start_ns + acquisition.end_ns) / 2),
        ),
        (
            "acquired quiet",
            align_tick((quiet.start_ns + quiet.end_ns) / 2),
        ),
        ("bit 0 (V)", align_tick((bit0.start_ns + bit0.end_ns) / 2)),
    ];
    let end_ns = instants[2].1;

    let mut world = World::new(observers).context("building the scene")?;
    let mut renderer = CameraRenderer::new(&world, sim::render::RenderPath::default())
        .context("creating the offscreen renderer")?;
    let mut camera = EventCamera::new(CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX))
        .context("building the event camera")?;
    let lens = ObserverCamera::at_home(observer, observers);
    let mut captured: Vec<(RgbImage, EventPacket, [f64; 2])> = Vec::new();
    // The first render (t = 0) initialises the converter, as in a camera process.
    let first = renderer.render(&mut world, observer)?.to_vec();
    camera.push_frame(0, &first)?;
    while world.time_ns() < end_ns {
        step_along(&mut world, &schedule);
        let t = world.time_ns();
        if !t.is_multiple_of(EVENT_RENDER_PERIOD_NS) {
            continue;
        }
        let rgb = renderer.render(&mut world, observer)?.to_vec();
        let packets = camera.push_frame(t, &rgb)?;
        if let Some((_, want)) = instants.iter().find(|(_, at)| *at == t) {
            let packet = packets
                .into_iter()
                .find(|p| p.end_ns == *want)
                .with_context(|| format!("no packet ends at {:.2} s", ns_s(*want)))?;
            let centre = lens
                .project_px(world.position_m(0))
                .context("the performer is behind the camera")?;
            let image = from_rgb(u32::from(IMAGE_WIDTH_PX), u32::from(IMAGE_HEIGHT_PX), rgb)?;
            captured.push((image, packet, centre));
        }
    }
    if captured.len() != instants.len() {
        bail!("captured {} of {} instants", captured.len(), instants.len());
    }
    let (w, h) = (u32::from(IMAGE_WIDTH_PX), u32::from(IMAGE_HEIGHT_PX));
    let gap = 12;
    let mut sheet = filled(3 * w + 2 * gap, 2 * h + gap, [255, 255, 255]);
    let mut phases = Vec::new();
    for (k, ((image, packet, centre), (label, t_ns))) in captured.iter().zip(instants).enumerate() {
        let cx = centre[0].clamp(0.0, f64::from(w - 1)) as u32;
        let cy = centre[1].clamp(0.0, f64::from(h - 1)) as u32;
        let inset = Inset::paper(cx, cy);
        let top = with_inset(image, &inset)?;
        let bottom = event_picture(packet, Some(&inset))?;
        image::imageops::replace(&mut sheet, &top, i64::from(k as u32 * (w + gap)), 0);
        image::imageops::replace(
            &mut sheet,
            &bottom,
            i64::from(k as u32 * (w + gap)),
            i64::from(h + gap),
        );
        phases.push(SensorColumn {
            label,
            t_ns,
            events: packet.len(),
            on_events: (0..packet.len())
                .filter(|&i| packet.polarity(i) == Polarity::On)
                .count(),
            inset_px: [inset.x, inset.y],
        });
    }
    let bytes = encode_png(&sheet)?;
    std::fs::write(png_path, bytes).with_context(|| format!("writing {}", png_path.display()))?;
    Ok(phases)
}

/// The figure's caption (markdown), naming the camera and the packets.
pub fn caption(observers: usize, observer: usize, phases: &[SensorColumn]) -> String {
    let cols: Vec<String> = phases
        .iter()
        .map(|p| {
            format!(
                "{} at {:.2} s: {} events ({} ON, {} OFF)",
                p.label,
                ns_s(p.t_ns),
                p.events,
                p.on_events,
                p.events - p.on_events
            )
        })
        .collect();
    format!(
        "{}'s camera ({observers} observers, round 1 offer `{FIRST_OFFER:06b}` from {:.1} s). \
         Top: the MuJoCo RGB render at the instant; bottom: the synthetic events of the 40 ms \
         packet ending then (blue ON, red OFF, last polarity per pixel, white none). Each pair \
         shares one 80×60 px inset (×3, top right) around the performer. Columns: {}. Rendered \
         in-process for this report, not read from the run's recording.",
        observer_name(observer),
        ns_s(BROADCAST_START_NS),
        cols.join("; ")
    )
}
