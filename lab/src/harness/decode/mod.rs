//! `waggle decode`: a camera's recording through one observer's receiver — the same chain
//! `waggle link` and the observer process run — into tokens, frames and payloads.
//!
//! Events come from a Prophesee EVT 3.0 or EVT 2.0 `.raw` file, a DAT file, an iniVation AEDAT4
//! file or the `event_camera_msgs/EventPacket` topic of a ROS 2 bag ([`source`]); images from a
//! directory of PNG frames or a ROS 2 bag's image topic ([`images`]). A camera other than the
//! receivers' reference (another resolution, a calibration file) is remapped into it first
//! ([`calibration`]).
//!
//! Events are cut into the receiver's 40 ms packets on the sensor grid (`(k·P, (k+1)·P]` from
//! t = 0 of the recording's clock, empty packets included), followed by `tail_s` of silence so
//! a final rest can be confirmed. The camera's pose (its viewpoint of the performer's hover
//! point) sets the receiver's rectification, as in `waggle link`.
//!
//! PNG frames converted into synthetic events offline (`waggle events convert`) are
//! [`convert`]. A live camera, a ROS 2 topic, goes through the same receivers and the same
//! packet cutting in [`live`] (`waggle observe`).

pub mod convert;

pub mod images;
pub mod live;
pub mod real_noise;
pub mod source;

use std::path::PathBuf;

use anyhow::{Result, bail};
use event_camera::Event;
use perception::{Perception, SensorInput};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement};
use proto::{EventPacket, Modality, Rectification, ReleasedFrame, SegmentToken};
use serde::Serialize;

use self::source::read_events;
use crate::harness::link::{ObserverOut, observer_out};
use commands::decode::EventFormat;
use event_camera::calibration::{EventRemap, Intrinsics};
use event_camera::packets::Packetizer;

/// The receiver's packet period, ns (the paper's 25 Hz).
const PACKET_NS: u64 = proto::TICK_NS;

/// What to decode and from where the camera saw it.
#[derive(Debug, Clone)]
pub struct DecodeOptions {
    pub input: DecodeInput,
    /// The camera's placement relative to the performer's hover point.
    pub placement: Placement,
    pub rectification: Rectification,
    /// The check the recorded frames carry after their payload.
    pub frame_check: proto::FrameCheck,
    /// The camera's calibration file (ROS `camera_info` or OpenCV YAML), if any.
    pub calibration: Option<PathBuf>,
    /// Silence (events) or repeats of the last image (RGB) appended after the recording, s.
    pub tail_s: f64,
}

/// The recording to decode.
#[derive(Debug, Clone)]
pub enum DecodeInput {
    Events {
        file: PathBuf,
        format: EventFormat,
        /// A bag's topic.
        topic: Option<String>,
    },
    Rgb {
        path: PathBuf,
        /// A bag's topic.
        topic: Option<String>,
        /// Frame rate of an image directory, Hz.
        fps: u32,
    },
}

/// What `waggle decode --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct DecodeOut {
    pub file: String,
    /// The format read, e.g. `evt3`, `aedat4 (lz4)`, `bag /O1/events`, `png directory`.
    pub format: String,
    pub width_px: u16,
    pub height_px: u16,
    /// Whether the input was remapped into the reference camera (another size or calibrated).
    pub remapped: bool,
    /// Events read (events input), before any remap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events: Option<u64>,
    /// Events that fell outside the reference camera's field (remapped events only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_outside: Option<u64>,
    /// Images read (RGB input).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub images: Option<u64>,
    /// Packets or frames given to the receiver.
    pub packets: u64,
    pub sim_seconds: f64,
    pub decoded: ObserverOut,
}

/// The camera of a `width`×`height` recording: the calibration file's, or one like the
/// reference; `None` when nothing needs remapping.
pub(crate) fn camera(
    calibration: Option<&PathBuf>,
    size: Option<(u16, u16)>,
) -> Result<Option<Intrinsics>> {
    Ok(Intrinsics::of_recording(
        calibration.map(PathBuf::as_path),
        size,
    )?)
}

pub(crate) fn check_tail(tail_s: f64) -> Result<()> {
    if !(tail_s.is_finite() && (0.0..=600.0).contains(&tail_s)) {
        bail!("--tail-s {tail_s} must be 0–600 s");
    }
    Ok(())
}

/// Decodes `opts.input` with one observer's receiver.
pub fn decode(opts: &DecodeOptions) -> Result<DecodeOut> {
    check_tail(opts.tail_s)?;
    match &opts.input {
        DecodeInput::Events {
            file,
            format,
            topic,
        } => decode_events(opts, file, *format, topic.as_deref()),
        DecodeInput::Rgb { path, topic, fps } => {
            images::decode_images(opts, path, topic.as_deref(), *fps)
        }
    }
}

fn decode_events(
    opts: &DecodeOptions,
    file: &std::path::Path,
    format: EventFormat,
    topic: Option<&str>,
) -> Result<DecodeOut> {
    let read = read_events(file, format, topic)?;
    let cam = camera(opts.calibration.as_ref(), read.size)?;
    let (width, height) = read.size.unwrap_or(match &cam {
        Some(c) => (c.width_px, c.height_px),
        None => (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX),
    });
    let total = read.events.len() as u64;
    let mut events = read.events;
    let outside = cam.as_ref().map(|cam| remap_events(cam, &mut events));
    // Cameras write in time order; a file that does not is sorted rather than refused.
    events.sort_by_key(|e| e.t_ns);
    let last_ns = events.last().map_or(0, |e| e.t_ns);
    let end_ns = last_ns + (opts.tail_s * 1e9).round() as u64;
    let mut receiver = DecodingReceiver::new(opts.placement, opts.rectification, opts.frame_check)?;
    let mut packetizer = Packetizer::new();
    for e in &events {
        packetizer.push(e, |p| {
            receiver.take(&p);
        });
    }
    packetizer.finish(end_ns, |p| {
        receiver.take(&p);
    });
    let packets = packetizer.packets();
    let decoded = receiver.finish()?;
    Ok(DecodeOut {
        file: file.display().to_string(),
        format: read.format,
        width_px: width,
        height_px: height,
        remapped: cam.is_some(),
        events: Some(total),
        events_outside: outside,
        images: None,
        packets,
        sim_seconds: end_ns as f64 * 1e-9,
        decoded,
    })
}

/// One observer's event receiver fed packet by packet, keeping its tokens and frames; the
/// first fault stops it and is returned by [`DecodingReceiver::finish`].
pub(crate) struct DecodingReceiver {
    perception: Perception,
    tokens: Vec<SegmentToken>,
    frames: Vec<ReleasedFrame>,
    fault: Option<anyhow::Error>,
}

impl DecodingReceiver {
    /// The receiver of a camera at `placement`.
    pub(crate) fn new(
        placement: Placement,
        rectification: Rectification,
        check: proto::FrameCheck,
    ) -> Result<Self> {
        let mut perception =
            Perception::for_camera(Modality::Events, placement.camera(), rectification)?;
        perception.set_frame_check(check);
        Ok(Self {
            perception,
            tokens: Vec::new(),
            frames: Vec::new(),
            fault: None,
        })
    }

    /// Gives the receiver one packet; what it confirms and releases is returned as well as
    /// kept.
    pub(crate) fn take(&mut self, packet: &EventPacket) -> (Vec<SegmentToken>, Vec<ReleasedFrame>) {
        if self.fault.is_some() {
            return (Vec::new(), Vec::new());
        }
        match self.perception.push(SensorInput::Events(packet)) {
            Ok(step) => {
                self.tokens.extend(step.tokens.iter().cloned());
                self.frames.extend(step.frames.iter().cloned());
                (step.tokens, step.frames)
            }
            Err(e) => {
                self.fault = Some(e.into());
                (Vec::new(), Vec::new())
            }
        }
    }

    /// What the receiver decoded, or its first fault.
    pub(crate) fn finish(self) -> Result<ObserverOut> {
        match self.fault {
            Some(e) => Err(e),
            None => Ok(observer_out(&self.tokens, &self.frames)),
        }
    }
}

/// Moves `events` into the reference camera, dropping those outside it; returns how many.
pub(crate) fn remap_events(cam: &Intrinsics, events: &mut Vec<Event>) -> u64 {
    remap_with(&EventRemap::new(cam), events)
}

/// Moves `events` through `remap`, dropping those outside the reference camera; returns how
/// many.
pub(crate) fn remap_with(remap: &EventRemap, events: &mut Vec<Event>) -> u64 {
    let before = events.len();
    events.retain_mut(|e| match remap.map(e.x, e.y) {
        Some((x, y)) => {
            (e.x, e.y) = (x, y);
            true
        }
        None => false,
    });
    (before - events.len()) as u64
}
