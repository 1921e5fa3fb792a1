//! `waggle decode --events FILE`: an event camera's recording (EVT 3.0 `.raw`, from a real
//! camera or written by `waggle link --events-raw`) through one observer's event receiver, the
//! same chain `waggle link` and the observer process run, into tokens, frames and payloads.
//!
//! The file's events are cut into the receiver's 40 ms packets on the sensor grid
//! (`(k·P, (k+1)·P]` from t = 0, empty packets included), followed by `tail_s` of silence so a
//! final rest can be confirmed. The camera's pose (its viewpoint of the performer's hover point)
//! sets the receiver's rectification, as in `waggle link`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use event_formats::evt3;
use perception::perception::{Perception, SensorInput};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement};
use proto::{EventPacket, Modality, Rectification};
use serde::Serialize;

use crate::harness::link::{ObserverOut, observer_out};

/// The receiver's packet period, ns (the paper's 25 Hz).
const PACKET_NS: u64 = 40_000_000;

/// What to decode and from where the camera saw it.
#[derive(Debug, Clone)]
pub struct DecodeOptions {
    pub file: PathBuf,
    /// The camera's placement relative to the performer's hover point.
    pub placement: Placement,
    pub rectification: Rectification,
    /// Silence appended after the last event, s.
    pub tail_s: f64,
}

/// What `waggle decode --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct DecodeOut {
    pub file: String,
    pub events: u64,
    pub packets: u64,
    pub sim_seconds: f64,
    pub decoded: ObserverOut,
}

/// Decodes `opts.file` with one observer's event receiver.
pub fn decode_events_file(opts: &DecodeOptions) -> Result<DecodeOut> {
    let bytes =
        std::fs::read(&opts.file).with_context(|| format!("reading {}", opts.file.display()))?;
    let decoded =
        evt3::read(&bytes).with_context(|| format!("decoding {}", opts.file.display()))?;
    let (width, height) = match decoded.geometry {
        Some(g) => (g.width, g.height),
        None => (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX),
    };
    if (width, height) != (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX) {
        bail!(
            "{}: a {width}×{height} sensor; the event receiver is the paper's \
             {IMAGE_WIDTH_PX}×{IMAGE_HEIGHT_PX} one (other resolutions are not supported yet)",
            opts.file.display()
        );
    }
    if !(opts.tail_s.is_finite() && (0.0..=600.0).contains(&opts.tail_s)) {
        bail!("--tail-s {} must be 0–600 s", opts.tail_s);
    }
    let mut events = decoded.events;
    // Cameras write in time order; a file that does not is sorted rather than refused.
    events.sort_by_key(|e| e.t_ns);
    let last_ns = events.last().map_or(0, |e| e.t_ns);
    let end_ns = last_ns + (opts.tail_s * 1e9).round() as u64;
    let packets = end_ns.div_ceil(PACKET_NS).max(1);
    let mut perception = Perception::for_camera(
        Modality::Events,
        opts.placement.camera(),
        opts.rectification,
    )?;
    let (mut tokens, mut frames) = (Vec::new(), Vec::new());
    let mut next = 0usize;
    for k in 0..packets {
        let (start, end) = (k * PACKET_NS, (k + 1) * PACKET_NS);
        let mut inside = Vec::new();
        while let Some(e) = events.get(next) {
            // (start, end]; an event exactly at t = 0 joins the first packet.
            if e.t_ns > end {
                break;
            }
            let dt = e.t_ns.saturating_sub(start) as u32;
            inside.push((e.x, e.y, dt, e.polarity));
            next += 1;
        }
        let packet = EventPacket::from_events(k, (start, end), (width, height), &inside);
        let step = perception.push(SensorInput::Events(&packet))?;
        tokens.extend(step.tokens);
        frames.extend(step.frames);
    }
    Ok(DecodeOut {
        file: opts.file.display().to_string(),
        events: events.len() as u64,
        packets,
        sim_seconds: end_ns as f64 * 1e-9,
        decoded: observer_out(&tokens, &frames),
    })
}
