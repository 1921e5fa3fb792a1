//! `waggle observe`: a live camera through one observer's receiver. The camera is a ROS 2
//! topic on `rmw_zenoh` — `event_camera_msgs/msg/EventPacket` in `evt3` as Prophesee's
//! `metavision_driver` publishes it, or `sensor_msgs/msg/Image` / `CompressedImage` — received
//! as a ROS 2 subscription receives it ([`ros2_bag::live`]); what the receiver confirms and
//! releases is published back at once as `waggle_msgs` on `/<id>/tokens` and `/<id>/frames`.
//!
//! Standing alone, the observer receives continuously: every packet goes to the receiver, as
//! `waggle decode` gives it a whole file, cut into the same 40 ms packets by the same
//! [`Packetizer`] from t = 0 of the camera's clock. So the same events decode to the same
//! tokens and frames live as from the file. It makes no decision: deciding needs a session's
//! reception windows and offers.
//!
//! It ends when every publisher seen on the topic has left the ROS graph (its liveliness token
//! withdrawn, after its samples), on SIGINT/SIGTERM, or after `idle_s` of wall time without a
//! message; then `tail_s` of silence (or the last image held still) lets a final rest be
//! confirmed. The wall clock decides only when to stop listening, never what a message decodes
//! to. A message that does not decode (CDR, encoding, sensor size, EVT 3.0 words) is counted
//! and its reason kept, never fatal.

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use commands::observe::LiveKind;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, Placement};
use proto::{FrameEvent, ObserverId, Rectification, ReleasedFrame, SegmentToken, TokenEvent};
use recording::Decoded;
use ros2_bag::camera::CameraPackets;
use ros2_bag::ingest::image_from_cdr;
use ros2_bag::live::{LiveInput, LiveOptions, LiveView};
use serde::Serialize;

use super::images::{Feed, Image};
use super::{DecodingReceiver, check_tail};
use crate::harness::link::ObserverOut;

/// The node name `waggle observe` joins the ROS graph as.
pub const NODE_NAME: &str = "waggle_observer";
/// Reasons of refused messages kept for the report.
const REASONS_KEPT: usize = 10;

/// What to listen to and who the observer is.
#[derive(Debug, Clone)]
pub struct ObserveOptions {
    /// The ROS side: domain and router.
    pub live: LiveOptions,
    pub topic: String,
    pub kind: LiveKind,
    pub id: ObserverId,
    /// The camera's placement relative to the performer's hover point.
    pub placement: Placement,
    pub rectification: Rectification,
    /// The check the performer's frames carry after their payload.
    pub frame_check: proto::FrameCheck,
    /// The camera's calibration file (ROS `camera_info` or OpenCV YAML), if any.
    pub calibration: Option<std::path::PathBuf>,
    pub tail_s: f64,
    /// Wall seconds without a message that end the observer (0: never).
    pub idle_s: f64,
}

/// What `waggle observe --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct ObserveOut {
    pub topic: String,
    /// The ROS type received.
    pub message_type: String,
    /// The camera's size, once a message stated it.
    pub width_px: u16,
    pub height_px: u16,
    /// Whether the input was remapped into the reference camera.
    pub remapped: bool,
    /// Messages received, and of them those refused.
    pub messages: u64,
    pub refused: u64,
    /// Why, for the first refused messages.
    pub refusals: Vec<String>,
    /// Events decoded (events input), before any remap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events: Option<u64>,
    /// Events outside the reference camera's field (remapped events only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_outside: Option<u64>,
    /// Events that arrived after a later packet had gone to the receiver, dropped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_late: Option<u64>,
    /// Images given to the receiver (images input), the tail's included.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub images: Option<u64>,
    /// Packets or frames given to the receiver.
    pub packets: u64,
    /// The camera time covered, tail included, s.
    pub sim_seconds: f64,
    /// Why listening stopped: `publishers left`, `stop signal` or `idle`.
    pub ended: String,
    /// Publishers of the topic seen.
    pub publishers: u64,
    /// Samples published, per ROS topic.
    pub published: BTreeMap<String, u64>,
    /// Outputs that failed to convert or send.
    pub publish_failures: u64,
    pub decoded: ObserverOut,
}

/// The ROS type of a kind of camera topic.
pub fn message_type(kind: LiveKind) -> &'static str {
    match kind {
        LiveKind::Events => "event_camera_msgs/msg/EventPacket",
        LiveKind::Image => "sensor_msgs/msg/Image",
        LiveKind::CompressedImage => "sensor_msgs/msg/CompressedImage",
    }
}

/// What the receiver gave for one message.
type Outputs = (Vec<SegmentToken>, Vec<ReleasedFrame>);

/// The event path: messages → packets of the reference camera → the receiver.
struct EventPath {
    packets: CameraPackets,
    receiver: DecodingReceiver,
}

impl EventPath {
    fn take(&mut self, cdr: &[u8]) -> Result<Outputs, String> {
        let (mut tokens, mut frames) = (Vec::new(), Vec::new());
        let receiver = &mut self.receiver;
        self.packets.take(cdr, |p| {
            let (t, f) = receiver.take(&p);
            tokens.extend(t);
            frames.extend(f);
        })?;
        Ok((tokens, frames))
    }

    fn finish(&mut self, tail_s: f64) -> (u64, Outputs) {
        let (mut tokens, mut frames) = (Vec::new(), Vec::new());
        let receiver = &mut self.receiver;
        let end_ns = self.packets.finish((tail_s * 1e9).round() as u64, |p| {
            let (t, f) = receiver.take(&p);
            tokens.extend(t);
            frames.extend(f);
        });
        (end_ns, (tokens, frames))
    }
}

/// The image path: messages → images → the RGB receiver.
struct ImagePath {
    feed: Feed,
    compressed: bool,
    /// Tokens and frames already handed out.
    tokens_out: usize,
    frames_out: usize,
}

impl ImagePath {
    fn new_outputs(&mut self) -> Outputs {
        let decoded = self.feed.tokens_and_frames();
        let tokens = decoded.0[self.tokens_out..].to_vec();
        let frames = decoded.1[self.frames_out..].to_vec();
        (self.tokens_out, self.frames_out) = (decoded.0.len(), decoded.1.len());
        (tokens, frames)
    }

    fn take(&mut self, cdr: &[u8]) -> Result<Outputs, String> {
        let image = image_from_cdr(cdr, self.compressed)?;
        self.feed
            .push(Image {
                stamp_ns: image.stamp_ns,
                width: image.width,
                height: image.height,
                rgb: image.rgb,
            })
            .map_err(|e| format!("{e:#}"))?;
        Ok(self.new_outputs())
    }
}

enum Path {
    Events(Box<EventPath>),
    Images(Box<ImagePath>),
}

impl Path {
    fn new(opts: &ObserveOptions) -> Result<Self> {
        Ok(match opts.kind {
            LiveKind::Events => Path::Events(Box::new(EventPath {
                packets: CameraPackets::new(opts.calibration.as_deref()),
                receiver: DecodingReceiver::new(
                    opts.placement,
                    opts.rectification,
                    opts.frame_check,
                )?,
            })),
            kind => Path::Images(Box::new(ImagePath {
                feed: Feed::new(
                    opts.placement,
                    opts.rectification,
                    opts.frame_check,
                    opts.calibration.clone(),
                )?,
                compressed: kind == LiveKind::CompressedImage,
                tokens_out: 0,
                frames_out: 0,
            })),
        })
    }

    fn take(&mut self, cdr: &[u8]) -> Result<Outputs, String> {
        match self {
            Path::Events(p) => p.take(cdr),
            Path::Images(p) => p.take(cdr),
        }
    }

    /// The tail, and what the path reports.
    fn finish(&mut self, tail_s: f64) -> Result<(Report, Outputs)> {
        Ok(match self {
            Path::Events(p) => {
                let (end_ns, outputs) = p.finish(tail_s);
                let c = &p.packets;
                let report = Report {
                    size: c.size(),
                    remapped: c.remapped(),
                    events: Some(c.events()),
                    outside: c.remapped().then_some(c.outside()),
                    late: Some(c.late()),
                    images: None,
                    packets: c.packets(),
                    end_ns,
                };
                (report, outputs)
            }
            Path::Images(p) => {
                let end_ns = p.feed.finish(tail_s)?.unwrap_or(0);
                let report = Report {
                    size: p.feed.size(),
                    remapped: p.feed.remapped(),
                    events: None,
                    outside: None,
                    late: None,
                    images: Some(p.feed.images()),
                    packets: p.feed.images(),
                    end_ns,
                };
                (report, p.new_outputs())
            }
        })
    }

    fn decoded(self) -> Result<ObserverOut> {
        match self {
            Path::Events(p) => p.receiver.finish(),
            Path::Images(p) => Ok(p.feed.decoded()),
        }
    }
}

/// Messages received and refused, with the first reasons.
#[derive(Default)]
struct Received {
    messages: u64,
    refused: u64,
    refusals: Vec<String>,
}

/// The messages published and the sequence numbers of the observer's streams.
struct Publisher {
    view: LiveView,
    id: ObserverId,
    tokens: u64,
    frames: u64,
}

impl Publisher {
    fn publish(&mut self, (tokens, frames): Outputs) {
        let id = &self.id;
        for t in tokens {
            let event = TokenEvent {
                observer: id.clone(),
                seq: self.tokens,
                token: t.token,
                confirmed_ns: t.stamp_ns,
            };
            self.tokens += 1;
            self.view.publish(
                &format!("observer/{id}/tokens"),
                Decoded::TokenEvent(event),
                t.stamp_ns,
            );
        }
        for frame in frames {
            let at_ns = frame.final_null_ns();
            let event = FrameEvent {
                observer: id.clone(),
                seq: self.frames,
                // Standing alone there are no rounds.
                round: 0,
                frame,
            };
            self.frames += 1;
            self.view.publish(
                &format!("observer/{id}/frames"),
                Decoded::FrameEvent(event),
                at_ns,
            );
        }
    }
}

fn check(opts: &ObserveOptions) -> Result<()> {
    check_tail(opts.tail_s)?;
    ros2_bag::rmw_zenoh::topic_key(opts.live.domain, &opts.topic, message_type(opts.kind))
        .with_context(|| format!("--topic {}", opts.topic))?;
    if !(opts.idle_s.is_finite() && opts.idle_s >= 0.0) {
        bail!("--idle-s {} must be 0 or more seconds", opts.idle_s);
    }
    Ok(())
}

/// Listens to the camera until it leaves (or the idle time or a stop signal), decoding as
/// messages arrive, and reports what came and what was decoded.
pub fn observe(opts: &ObserveOptions) -> Result<ObserveOut> {
    check(opts)?;
    let stop = bus::on_stop_signal();
    let type_name = message_type(opts.kind);
    let view = LiveView::start_node(&opts.live, NODE_NAME)?;
    let mut out = Publisher {
        view,
        id: opts.id.clone(),
        tokens: 0,
        frames: 0,
    };
    let mut subscription = out
        .view
        .subscribe(&opts.topic, type_name)
        .with_context(|| format!("subscribing to {}", opts.topic))?;
    let mut path = Path::new(opts)?;
    let mut received = Received::default();
    let idle = (opts.idle_s > 0.0).then(|| Duration::from_secs_f64(opts.idle_s));
    let mut last_message = Instant::now();
    let ended = loop {
        if stop.load(Ordering::Relaxed) {
            break "stop signal";
        }
        match subscription.next(Duration::from_millis(100)) {
            LiveInput::Message(cdr) => {
                received.messages += 1;
                last_message = Instant::now();
                match path.take(&cdr) {
                    Ok(outputs) => out.publish(outputs),
                    Err(reason) => {
                        received.refused += 1;
                        if received.refusals.len() < REASONS_KEPT {
                            let k = received.messages - 1;
                            received.refusals.push(format!("message {k}: {reason}"));
                        }
                    }
                }
            }
            LiveInput::PublishersGone => break "publishers left",
            LiveInput::Idle => {
                if idle.is_some_and(|idle| last_message.elapsed() >= idle) {
                    break "idle";
                }
            }
        }
    };
    let publishers = subscription.publishers_seen();
    drop(subscription);
    let (report, outputs) = path.finish(opts.tail_s)?;
    out.publish(outputs);
    let decoded = path.decoded()?;
    let counts = out.view.close()?;
    let (width_px, height_px) = report.size.unwrap_or((IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX));
    Ok(ObserveOut {
        topic: opts.topic.clone(),
        message_type: type_name.to_string(),
        width_px,
        height_px,
        remapped: report.remapped,
        messages: received.messages,
        refused: received.refused,
        refusals: received.refusals,
        events: report.events,
        events_outside: report.outside,
        events_late: report.late,
        images: report.images,
        packets: report.packets,
        sim_seconds: report.end_ns as f64 * 1e-9,
        ended: ended.to_string(),
        publishers,
        published: counts.published,
        publish_failures: counts.failed,
        decoded,
    })
}

/// What a path reports at the end.
struct Report {
    size: Option<(u16, u16)>,
    remapped: bool,
    events: Option<u64>,
    outside: Option<u64>,
    late: Option<u64>,
    images: Option<u64>,
    packets: u64,
    end_ns: u64,
}
