//! Waggle messages → ROS 2 messages ([`RosConverter`]), shared by the bag export
//! ([`crate::export`]) and the live view on `rmw_zenoh` ([`crate::live`]). The mapping of keys to
//! topics and types is the table in [`crate::export`].

use std::collections::BTreeMap;

use event_camera::Event;
use event_formats::evt3::StreamEncoder;
use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use proto::{EventPacket, RgbFrame, RgbReassembler};
use recording::Decoded;

use crate::bag::QosProfile;
use crate::cdr::RosMessage;
use crate::error::Ros2Error;
use crate::geometry::{camera_info, camera_mount};
use crate::messages::{
    CompressedImageMsg, EventPacketMsg, HeaderMsg, ImageMsg, QuaternionMsg, TfMessage,
    TransformStampedMsg, Vector3Msg,
};
use crate::waggle_msgs::{BroadcastMsg, DecisionMsg, FaultMsg, FrameMsg, TokenMsg, optical_frame};

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

/// One camera's conversion state.
struct Camera {
    reassembler: RgbReassembler,
    evt3: Option<StreamEncoder>,
}

/// A ROS 2 message made from a Waggle message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Converted {
    /// The recording's log time (sim time) of the message it was made from.
    pub log_time_ns: u64,
    /// The ROS topic (`/O1/events`).
    pub topic: String,
    pub qos: QosProfile,
    /// `pkg/msg/Type`.
    pub type_name: &'static str,
    /// The CDR bytes, encapsulation header included.
    pub cdr: Vec<u8>,
}

/// Waggle messages → ROS 2 messages, in the order they come (one per recording or session: it
/// keeps each camera's RGB reassembly and EVT 3.0 encoder).
pub struct RosConverter {
    /// What is converted, for errors (a recording's path, or a session).
    source: String,
    options: ExportOptions,
    /// Camera pitch per observer (from the session's formation).
    pitch_rad: BTreeMap<String, f64>,
    cameras: BTreeMap<String, Camera>,
    out: Vec<Converted>,
    wrote_static: bool,
    events: u64,
    images: u64,
}

impl RosConverter {
    /// A converter of `source` (named in errors) whose observers' cameras are pitched as
    /// `pitch_rad` says (their static transforms).
    pub fn new(source: &str, options: ExportOptions, pitch_rad: BTreeMap<String, f64>) -> Self {
        Self {
            source: source.to_string(),
            options,
            pitch_rad,
            cameras: BTreeMap::new(),
            out: Vec::new(),
            wrote_static: false,
            events: 0,
            images: 0,
        }
    }

    /// Events converted so far (all cameras).
    pub fn events(&self) -> u64 {
        self.events
    }

    /// RGB frames converted so far (all cameras).
    pub fn images(&self) -> u64 {
        self.images
    }

    /// Takes the messages made since the last call, in the order they were made.
    pub fn take(&mut self) -> Vec<Converted> {
        std::mem::take(&mut self.out)
    }

    fn queue<M: RosMessage>(&mut self, topic: String, qos: QosProfile, log_time_ns: u64, msg: &M) {
        self.out.push(Converted {
            log_time_ns,
            topic,
            qos,
            type_name: M::TYPE_NAME,
            cdr: msg.to_cdr(),
        });
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

    fn event_packet(
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
        // The packet's end: the stream's clock passes through silence as a camera's does, so
        // a live reader can hand on a packet without waiting for the next event.
        encoder.advance(p.end_ns, &mut words).map_err(evt3_error)?;
        self.events += events.len() as u64;
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
        self.images += 1;
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

    /// Converts one decoded message of recording topic `topic` (`/sensor/O1/events`), the
    /// static transforms first; `false` when ROS 2 gets nothing of its kind.
    ///
    /// # Errors
    ///
    /// A message that does not convert (an RGB update without its base frame, an EVT 3.0 or PNG
    /// encoding failure, a field out of its ROS type's range).
    pub fn convert(
        &mut self,
        topic: &str,
        msg: Decoded,
        log_time_ns: u64,
    ) -> Result<bool, Ros2Error> {
        if !self.wrote_static {
            self.tf_static(log_time_ns)?;
        }
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
            Decoded::EventPacket(p) => self.event_packet(&observer(), &p, log_time_ns)?,
            Decoded::RgbFrame(f) => self.image(&observer(), f, log_time_ns)?,
            Decoded::RgbUpdate(u) => {
                let o = observer();
                let seq = u.seq;
                let path = self.source.clone();
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
            // Only the ticks that start a broadcast; the others carry nothing to export.
            Decoded::BroadcastTick(t) => match t.broadcast {
                Some(b) => {
                    let m = BroadcastMsg::from_wire(&b)?;
                    self.queue("/performer/broadcast".into(), vol, log_time_ns, &m);
                }
                None => return Ok(false),
            },
            _ => return Ok(false),
        }
        Ok(true)
    }
}
