//! A Waggle recording (`session.mcap` of a run directory) → a ROS 2 bag.
//!
//! | Waggle key | bag topic | type |
//! | --- | --- | --- |
//! | `sensor/<o>/rgb` | `/<o>/camera/image_raw/compressed` (PNG, lossless) or, with [`ImageFormat::Raw`], `/<o>/camera/image_raw` | `sensor_msgs/msg/CompressedImage` / `Image` (`rgb8`) |
//! | `sensor/<o>/events` | `/<o>/events` | `event_camera_msgs/msg/EventPacket`, `encoding: "evt3"` |
//! | either sensor | `/<o>/camera/camera_info` (with every image or packet) | `sensor_msgs/msg/CameraInfo` |
//! | `sim/state` | `/tf` (`world` → each drone's body frame) | `tf2_msgs/msg/TFMessage` |
//! | (camera mounts) | `/tf_static` (`<o>` → `<o>/camera_optical`), latched | `tf2_msgs/msg/TFMessage` |
//! | `observer/<o>/tokens`, `frames`, `decision` | `/<o>/tokens`, `/<o>/frames`, `/<o>/decision` | `waggle_msgs/msg/Token`, `Frame`, `Decision` |
//! | `fault/<o>` | `/<o>/fault` | `waggle_msgs/msg/Fault` |
//!
//! Times: ROS time is Waggle's sim clock (from 0); each message keeps the recording's log time.
//! Event packets are stamped with their start watermark and cover (stamp, stamp + 40 ms]; their
//! EVT 3.0 words, concatenated per camera, are one EVT 3.0 stream (time-high wraps made visible,
//! `time_base` 0), and each packet repeats the time and row words first so a decoder may start
//! at any packet. Other keys (clock, status, tracks, setpoints, truth, scheduler, rejects) are
//! not exported and are counted in [`ExportReport::not_exported`].
//!
//! Output is sorted by log time within a sliding window ([`REORDER_WINDOW_NS`]; ties keep the
//! recording's order) and deterministic: the same recording gives the same bytes. A recording
//! that is damaged, cut short or holds a message that does not decode is refused, naming the
//! file and the byte range or the message; the partial bag is removed.

use std::collections::{BTreeMap, BinaryHeap};
use std::path::{Path, PathBuf};

use event_camera::Event;
use event_formats::evt3::StreamEncoder;
use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use proto::scene::Formation;
use proto::{EventPacket, RgbFrame, RgbReassembler};
use recording::{
    Decoded, MessageKind, RAW_ENCODING, SESSION_METADATA, SessionInfo, decode, leading_metadata,
    read_recording,
};

use crate::bag::{BagSummary, BagWriter, QosProfile};
use crate::cdr::RosMessage;
use crate::error::Ros2Error;
use crate::geometry::{camera_info, camera_mount};
use crate::messages::{
    CompressedImageMsg, EventPacketMsg, HeaderMsg, ImageMsg, QuaternionMsg, TfMessage,
    TransformStampedMsg, Vector3Msg,
};
use crate::waggle_msgs::{DecisionMsg, FaultMsg, FrameMsg, TokenMsg, optical_frame};

/// Messages are held this long (sim time) to be written in log-time order.
pub const REORDER_WINDOW_NS: u64 = 1_000_000_000;
/// The world frame of `/tf`.
pub const WORLD_FRAME: &str = "world";

/// How RGB frames go into the bag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImageFormat {
    /// `sensor_msgs/msg/CompressedImage`, lossless PNG.
    #[default]
    Png,
    /// `sensor_msgs/msg/Image`, `rgb8`.
    Raw,
}

/// What to export.
#[derive(Debug, Clone, Copy, Default)]
pub struct ExportOptions {
    pub images: ImageFormat,
}

/// What an export wrote.
#[derive(Debug, Clone)]
pub struct ExportReport {
    pub recording: PathBuf,
    pub bag: BagSummary,
    /// Raw messages read from the recording.
    pub recorded_messages: u64,
    /// Raw messages of keys the bag does not carry, per recording topic.
    pub not_exported: BTreeMap<String, u64>,
    /// Events written (all cameras).
    pub events: u64,
    /// RGB frames written (all cameras).
    pub images: u64,
}

/// A converted message waiting in the reorder window.
struct Pending {
    log_time_ns: u64,
    order: u64,
    topic: String,
    qos: QosProfile,
    type_name: &'static str,
    cdr: Vec<u8>,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        (self.log_time_ns, self.order) == (other.log_time_ns, other.order)
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Pending {
    /// Reversed: the heap pops the earliest first.
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (other.log_time_ns, other.order).cmp(&(self.log_time_ns, self.order))
    }
}

/// One camera's conversion state.
struct Camera {
    reassembler: RgbReassembler,
    evt3: Option<StreamEncoder>,
}

/// The conversion of one recording.
struct Exporter {
    /// The recording's path, for errors.
    recording: String,
    bag: BagWriter,
    options: ExportOptions,
    /// Camera pitch per observer (from the session's formation).
    pitch_rad: BTreeMap<String, f64>,
    cameras: BTreeMap<String, Camera>,
    pending: BinaryHeap<Pending>,
    order: u64,
    latest_ns: u64,
    wrote_static: bool,
    report_events: u64,
    report_images: u64,
}

impl Exporter {
    fn queue<M: RosMessage>(&mut self, topic: String, qos: QosProfile, log_time_ns: u64, msg: &M) {
        self.order += 1;
        self.pending.push(Pending {
            log_time_ns,
            order: self.order,
            topic,
            qos,
            type_name: M::TYPE_NAME,
            cdr: msg.to_cdr(),
        });
    }

    /// Writes every queued message older than `before_ns` (all with `None`).
    fn flush(&mut self, before_ns: Option<u64>) -> Result<(), Ros2Error> {
        while let Some(p) = self.pending.peek() {
            if before_ns.is_some_and(|t| p.log_time_ns >= t) {
                break;
            }
            let p = self.pending.pop().expect("peeked");
            self.bag.add_topic(&p.topic, p.type_name, p.qos)?;
            self.bag.write_cdr(&p.topic, p.log_time_ns, &p.cdr)?;
        }
        Ok(())
    }

    /// The static camera mounts, once, at the first message's time.
    fn tf_static(&mut self, log_time_ns: u64) -> Result<(), Ros2Error> {
        self.wrote_static = true;
        let mut msg = TfMessage::default();
        for (o, &pitch) in &self.pitch_rad {
            msg.transforms.push(camera_mount(
                HeaderMsg::at(0, o.clone())?,
                optical_frame(o),
                pitch,
            ));
        }
        if !msg.transforms.is_empty() {
            self.queue(
                "/tf_static".into(),
                QosProfile::TRANSIENT_LOCAL,
                log_time_ns,
                &msg,
            );
        }
        Ok(())
    }

    fn camera(&mut self, observer: &str) -> &mut Camera {
        self.cameras
            .entry(observer.to_string())
            .or_insert_with(|| Camera {
                reassembler: RgbReassembler::default(),
                evt3: None,
            })
    }

    fn camera_info(
        &mut self,
        observer: &str,
        stamp_ns: u64,
        log_time_ns: u64,
    ) -> Result<(), Ros2Error> {
        let info = camera_info(HeaderMsg::at(stamp_ns, optical_frame(observer))?);
        self.queue(
            format!("/{observer}/camera/camera_info"),
            QosProfile::VOLATILE,
            log_time_ns,
            &info,
        );
        Ok(())
    }

    fn events(
        &mut self,
        observer: &str,
        p: &EventPacket,
        log_time_ns: u64,
    ) -> Result<(), Ros2Error> {
        let evt3_error = |source| Ros2Error::Evt3 {
            observer: observer.to_string(),
            source,
        };
        let camera = self.camera(observer);
        if camera.evt3.is_none() {
            camera.evt3 = Some(StreamEncoder::new(p.width, p.height).map_err(evt3_error)?);
        }
        let encoder = camera.evt3.as_mut().expect("set above");
        let events: Vec<Event> = (0..p.len())
            .map(|i| Event {
                t_ns: p.t_ns(i),
                x: p.xs[i],
                y: p.ys[i],
                polarity: p.polarity(i),
            })
            .collect();
        let mut words = Vec::with_capacity(events.len() * 2 + 8);
        encoder.restart();
        encoder.encode(&events, &mut words).map_err(evt3_error)?;
        self.report_events += events.len() as u64;
        let msg = EventPacketMsg {
            header: HeaderMsg::at(p.start_ns, optical_frame(observer))?,
            height: u32::from(p.height),
            width: u32::from(p.width),
            seq: p.seq,
            time_base: 0,
            encoding: "evt3".into(),
            is_bigendian: false,
            events: words,
        };
        self.queue(
            format!("/{observer}/events"),
            QosProfile::VOLATILE,
            log_time_ns,
            &msg,
        );
        self.camera_info(observer, p.start_ns, log_time_ns)
    }

    fn image(&mut self, observer: &str, f: RgbFrame, log_time_ns: u64) -> Result<(), Ros2Error> {
        let header = HeaderMsg::at(f.stamp_ns, optical_frame(observer))?;
        let (w, h) = (u32::from(f.width), u32::from(f.height));
        self.report_images += 1;
        match self.options.images {
            ImageFormat::Raw => {
                let msg = ImageMsg {
                    header,
                    height: h,
                    width: w,
                    encoding: "rgb8".into(),
                    is_bigendian: 0,
                    step: w * 3,
                    data: f.rgb,
                };
                let topic = format!("/{observer}/camera/image_raw");
                self.queue(topic, QosProfile::VOLATILE, log_time_ns, &msg);
            }
            ImageFormat::Png => {
                let mut png = Vec::new();
                PngEncoder::new_with_quality(&mut png, CompressionType::Fast, FilterType::Adaptive)
                    .write_image(&f.rgb, w, h, image::ExtendedColorType::Rgb8)
                    .map_err(|e| Ros2Error::Png {
                        observer: observer.to_string(),
                        reason: e.to_string(),
                    })?;
                // compressed_image_transport's own tag for a colour PNG of an rgb8 image.
                let msg = CompressedImageMsg {
                    header,
                    format: "rgb8; png compressed bgr8".into(),
                    data: png,
                };
                let topic = format!("/{observer}/camera/image_raw/compressed");
                self.queue(topic, QosProfile::VOLATILE, log_time_ns, &msg);
            }
        }
        self.camera_info(observer, f.stamp_ns, log_time_ns)
    }

    /// Converts one decoded message; `false` when the bag does not carry its kind.
    fn convert(&mut self, topic: &str, msg: Decoded, log_time_ns: u64) -> Result<bool, Ros2Error> {
        let observer = || {
            recording::topics::topic_observer(topic)
                .unwrap_or("unknown")
                .to_string()
        };
        let vol = QosProfile::VOLATILE;
        match msg {
            Decoded::SimState(s) => {
                let mut tf = TfMessage::default();
                for d in &s.drones {
                    tf.transforms.push(TransformStampedMsg {
                        header: HeaderMsg::at(s.stamp_ns, WORLD_FRAME)?,
                        child_frame_id: d.name.clone(),
                        translation: Vector3Msg {
                            x: d.pos_m[0],
                            y: d.pos_m[1],
                            z: d.pos_m[2],
                        },
                        rotation: QuaternionMsg::from_wxyz(d.quat_wxyz),
                    });
                }
                self.queue("/tf".into(), vol, log_time_ns, &tf);
            }
            Decoded::EventPacket(p) => self.events(&observer(), &p, log_time_ns)?,
            Decoded::RgbFrame(f) => self.image(&observer(), f, log_time_ns)?,
            Decoded::RgbUpdate(u) => {
                let o = observer();
                let seq = u.seq;
                let path = self.recording.clone();
                let frame =
                    self.camera(&o)
                        .reassembler
                        .apply(u)
                        .map_err(|e| Ros2Error::Unassembled {
                            path,
                            observer: o.clone(),
                            seq,
                            reason: e.to_string(),
                        })?;
                self.image(&o, frame, log_time_ns)?;
            }
            Decoded::TokenEvent(t) => {
                let m = TokenMsg::from_wire(&t)?;
                self.queue(format!("/{}/tokens", t.observer), vol, log_time_ns, &m);
            }
            Decoded::FrameEvent(f) => {
                let m = FrameMsg::from_wire(&f)?;
                self.queue(format!("/{}/frames", f.observer), vol, log_time_ns, &m);
            }
            Decoded::Decision(d) => {
                let m = DecisionMsg::from_wire(&d)?;
                self.queue(format!("/{}/decision", d.observer), vol, log_time_ns, &m);
            }
            Decoded::Fault(f) => {
                let m = FaultMsg::from_wire(&f)?;
                self.queue(format!("/{}/fault", f.observer), vol, log_time_ns, &m);
            }
            _ => return Ok(false),
        }
        Ok(true)
    }
}

/// The recording of `run`: `run/session.mcap` for a directory, else `run` itself.
pub fn recording_path(run: &Path) -> PathBuf {
    if run.is_dir() {
        run.join("session.mcap")
    } else {
        run.to_path_buf()
    }
}

/// Camera pitch of each observer of the recorded session's formation (the built-in formation
/// of its observer count, as `waggle run` flies it).
fn pitches(recording: &Path) -> Result<BTreeMap<String, f64>, Ros2Error> {
    let info = leading_metadata(recording, SESSION_METADATA)?
        .map(|m| SessionInfo::from_metadata(&m))
        .unwrap_or_default();
    let Ok(formation) = Formation::standard(info.observers) else {
        return Ok(BTreeMap::new());
    };
    Ok(formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, p)| (proto::scene::observer_name(i), p.pitch_rad))
        .collect())
}

/// Exports the recording of `run` (a run directory or a `.mcap` file) as the bag directory
/// `out`, which must not exist or be empty. The bag is written beside `out` first and moved
/// there only when complete.
pub fn export_run(
    run: &Path,
    out: &Path,
    options: &ExportOptions,
) -> Result<ExportReport, Ros2Error> {
    let recording = recording_path(run);
    if out.exists()
        && (!out.is_dir()
            || out
                .read_dir()
                .map(|mut d| d.next().is_some())
                .unwrap_or(true))
    {
        return Err(Ros2Error::OutputExists {
            path: out.display().to_string(),
        });
    }
    let name = out
        .file_name()
        .map_or_else(|| "bag".into(), |n| n.to_string_lossy().into_owned());
    let staging = out
        .parent()
        .unwrap_or(Path::new("."))
        .join(format!(".{name}.partial-{}", std::process::id()))
        .join(&name);
    let result = export_into(&recording, &staging, options);
    let finish = result.and_then(|mut report| {
        let io = |source| Ros2Error::Io {
            path: out.display().to_string(),
            source,
        };
        if out.exists() {
            std::fs::remove_dir(out).map_err(io)?;
        }
        std::fs::rename(&staging, out).map_err(io)?;
        report.bag.dir = out.to_path_buf();
        Ok(report)
    });
    if let Some(parent) = staging.parent() {
        let _ = std::fs::remove_dir_all(parent);
    }
    finish
}

fn export_into(
    recording: &Path,
    staging: &Path,
    options: &ExportOptions,
) -> Result<ExportReport, Ros2Error> {
    let shown = recording.display().to_string();
    let pitch_rad = pitches(recording)?;
    let mut x = Exporter {
        recording: shown.clone(),
        bag: BagWriter::create(staging)?,
        options: *options,
        pitch_rad,
        cameras: BTreeMap::new(),
        pending: BinaryHeap::new(),
        order: 0,
        latest_ns: 0,
        wrote_static: false,
        report_events: 0,
        report_images: 0,
    };
    let mut recorded = 0u64;
    let mut index = 0u64;
    let mut not_exported: BTreeMap<String, u64> = BTreeMap::new();
    let outcome = read_recording::<Ros2Error>(recording, |m| {
        index += 1;
        if m.message_encoding != RAW_ENCODING {
            return Ok(());
        }
        let Some(kind) = MessageKind::from_schema_name(m.schema) else {
            return Ok(());
        };
        recorded += 1;
        let decoded = decode(kind, m.data).map_err(|e| Ros2Error::Undecodable {
            path: shown.clone(),
            index,
            topic: m.topic.to_string(),
            log_time_ns: m.log_time_ns,
            reason: e.to_string(),
        })?;
        if !x.wrote_static {
            x.tf_static(m.log_time_ns)?;
        }
        if !x.convert(m.topic, decoded, m.log_time_ns)? {
            *not_exported.entry(m.topic.to_string()).or_insert(0) += 1;
        }
        x.latest_ns = x.latest_ns.max(m.log_time_ns);
        x.flush(x.latest_ns.checked_sub(REORDER_WINDOW_NS))
    })?;
    if let Some(d) = outcome.damaged.first() {
        return Err(Ros2Error::Damaged {
            path: shown,
            from_byte: d.from_byte,
            to_byte: d.to_byte,
            reason: d.reason.clone(),
        });
    }
    if !outcome.complete {
        return Err(Ros2Error::Incomplete {
            path: shown,
            reason: outcome.problem.unwrap_or_else(|| "unknown".into()),
        });
    }
    x.flush(None)?;
    let (events, images) = (x.report_events, x.report_images);
    let bag = x.bag.finish()?;
    Ok(ExportReport {
        recording: recording.to_path_buf(),
        bag,
        recorded_messages: recorded,
        not_exported,
        events,
        images,
    })
}
