//! The session writer: every message of a session into one MCAP file.
//!
//! - each key's exact wire bytes on a raw channel (`/<key rest>`, schema `waggle.<Type>`,
//!   encoding [`RAW_ENCODING`]) — event packets losslessly, empty ones included;
//! - viewing channels in Foxglove's official schemas (protobuf, [`crate::foxglove`]):
//!   `/view/<o>/events` (event-frame pictures at a viewing rate), `/view/<o>/rgb` (RGB frames),
//!   `/view/tf` (poses), `/view/scene` (drones, sites and trajectories in 3D), `/view/log`
//!   (tokens, frames, decisions, faults, session controls, the mission report) — each also
//!   handed to a [`ViewTap`] when one is set (the live view);
//! - `waggle.session` metadata first (session, case name and TOML, modality, observers) and
//!   `waggle.recorder` metadata last (message counts, unknown keys, undecodable payloads).
//!
//! Log and publish time are the message's sim time in ns (the latest clock for messages without
//! one). Chunks are zstd-compressed, bounded in size, and buffered whole before they are written
//! (no seeking), so a file cut anywhere holds every chunk written before the cut.

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use mcap::records::Metadata;
use mcap::{Compression, WriteOptions, Writer};
use proto::scene::observer_name;
use proto::{Key, ObserverId, SessionEvent, TICK_NS};

use crate::foxglove::{self, LogLevel, Scene, VIEW_ENCODING, ViewKind, ViewMessage};
use crate::topics::{Decoded, MessageKind, RAW_ENCODING, classify, decode};
use crate::views::{EventView, log_line};

/// Name of the metadata record describing the session.
pub const SESSION_METADATA: &str = "waggle.session";
/// Name of the metadata record the recorder writes when it finishes.
pub const RECORDER_METADATA: &str = "waggle.recorder";
/// The `waggle.recorder` metadata key of [`RecordStats::events_not_recorded`] (JSON).
pub const EVENTS_NOT_RECORDED: &str = "events_not_recorded";
/// Topic of the log view.
pub const LOG_TOPIC: &str = "/view/log";
/// Topic of the pose view.
pub const TF_TOPIC: &str = "/view/tf";
/// Topic of the 3D scene.
pub const SCENE_TOPIC: &str = "/view/scene";
/// Sim-time period of the 3D scene's updates.
pub const SCENE_PERIOD_NS: u64 = 200_000_000;

/// Receives every view message as it is recorded (the live view).
pub trait ViewTap: Send {
    fn view(&mut self, topic: &str, log_time_ns: u64, msg: &ViewMessage);
}
/// Channel encoding of keys of no known type.
const UNKNOWN_ENCODING: &str = "application/octet-stream";

/// Why the writer failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
}

/// What to record besides the raw messages.
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderOptions {
    /// Uncompressed size at which a chunk is closed, bytes.
    pub chunk_bytes: u64,
    /// Sim-time period of the event-frame pictures (`None`: no event view).
    pub event_view_period_ns: Option<u64>,
    /// A view image of every n-th RGB frame (`/view/<o>/rgb`); 1 = all. The raw channel
    /// holds every update the camera published, whatever this is.
    pub rgb_every: u64,
    /// zstd level (0 = zstd's default).
    pub zstd_level: u32,
    /// Keep the event cameras' input (`camera/<o>/input`) and not their packets: the replay
    /// regenerates the packets with the sensor model and seed of the session metadata. The
    /// packets still feed the event view, and each camera's are folded into a digest (the
    /// `waggle.recorder` metadata's `events_not_recorded`) for the replay to match.
    pub events_from_input: bool,
}

impl Default for RecorderOptions {
    fn default() -> Self {
        Self {
            chunk_bytes: 4 << 20,
            event_view_period_ns: Some(500_000_000),
            rgb_every: 25,
            zstd_level: 0,
            events_from_input: false,
        }
    }
}

/// The session a recording belongs to (the `waggle.session` metadata).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SessionInfo {
    pub session: String,
    pub observers: usize,
    /// Case name (`nominal-3`, …), if known.
    pub case_name: Option<String>,
    /// The case file's TOML text, if known.
    pub case_toml: Option<String>,
    /// `rgb` or `events`, if known.
    pub modality: Option<String>,
    /// The event cameras' sensor model as camera arguments (`--sensor-preset NAME --perturb
    /// events.K=V --seed S`; empty: the paper's ideal sensor).
    pub sensor_args: Vec<String>,
    /// The recording keeps the event cameras' input instead of their packets
    /// ([`RecorderOptions::events_from_input`]).
    pub events_from_input: bool,
}

/// The `waggle.session` metadata value of [`SessionInfo::events_from_input`]'s key
/// `event_packets`.
const EVENT_PACKETS_FROM_INPUT: &str = "regenerated from camera/<o>/input";

impl SessionInfo {
    pub fn to_metadata(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        m.insert("session".into(), self.session.clone());
        m.insert("observers".into(), self.observers.to_string());
        m.insert("format_version".into(), proto::FORMAT_VERSION.to_string());
        for (k, v) in [
            ("case", &self.case_name),
            ("case_toml", &self.case_toml),
            ("modality", &self.modality),
        ] {
            if let Some(v) = v {
                m.insert(k.into(), v.clone());
            }
        }
        if !self.sensor_args.is_empty() {
            m.insert(
                "sensor_args".into(),
                serde_json::to_string(&self.sensor_args).unwrap_or_default(),
            );
        }
        if self.events_from_input {
            m.insert("event_packets".into(), EVENT_PACKETS_FROM_INPUT.into());
        }
        m
    }

    pub fn from_metadata(m: &BTreeMap<String, String>) -> Self {
        Self {
            session: m.get("session").cloned().unwrap_or_default(),
            observers: m.get("observers").and_then(|o| o.parse().ok()).unwrap_or(0),
            case_name: m.get("case").cloned(),
            case_toml: m.get("case_toml").cloned(),
            modality: m.get("modality").cloned(),
            sensor_args: m
                .get("sensor_args")
                .and_then(|a| serde_json::from_str(a).ok())
                .unwrap_or_default(),
            events_from_input: m.get("event_packets").map(String::as_str)
                == Some(EVENT_PACKETS_FROM_INPUT),
        }
    }
}

/// Counters of a recording.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// Messages written per raw topic.
    pub messages: BTreeMap<String, u64>,
    /// Payload bytes received.
    pub payload_bytes: u64,
    /// Messages on keys of no known type, per key.
    pub unknown_keys: BTreeMap<String, u64>,
    /// Payloads that did not decode, per topic (recorded raw all the same).
    pub undecodable: BTreeMap<String, u64>,
    /// RGB frames without a view image (the view's reduced rate), per observer.
    pub rgb_skipped: BTreeMap<String, u64>,
    /// RGB updates that built on a frame the recorder did not hold (recorded, no view image),
    /// per observer.
    pub rgb_unassembled: BTreeMap<String, u64>,
    pub view_images: u64,
    /// Event packets received but not recorded ([`RecorderOptions::events_from_input`]), per
    /// observer.
    pub events_not_recorded: BTreeMap<String, UnrecordedPackets>,
}

/// One event camera's packets a recorder received and did not keep (it keeps their input):
/// what the replay must regenerate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct UnrecordedPackets {
    pub packets: u64,
    pub events: u64,
    /// [`proto::camera::digest`] of their encodings, in the order received.
    pub digest: u64,
}

/// What became of one received message.
#[derive(Debug)]
pub enum Recorded {
    /// Decoded and recorded.
    Message {
        kind: MessageKind,
        mission_end: bool,
    },
    /// Recorded raw on a schema-less channel: the key has no known type.
    UnknownKey,
    /// Recorded raw on its channel, but the bytes did not decode.
    Undecodable {
        kind: MessageKind,
        error: proto::DecodeError,
    },
}

/// Writes one session into an MCAP file.
pub struct SessionWriter<W: Write + Seek> {
    mcap: Writer<W>,
    prefix: String,
    options: RecorderOptions,
    schemas: BTreeMap<String, u16>,
    channels: BTreeMap<String, u16>,
    sequence: BTreeMap<u16, u32>,
    event_views: BTreeMap<ObserverId, EventView>,
    rgb_seen: BTreeMap<ObserverId, u64>,
    /// Rebuilds each camera's frames from its updates, for the view images.
    rgb_frames: BTreeMap<ObserverId, proto::RgbReassembler>,
    sim_time_ns: u64,
    stats: RecordStats,
    scene: Scene,
    next_scene_ns: u64,
    tap: Option<Box<dyn ViewTap>>,
    observers: usize,
    modality: Option<String>,
}

impl<W: Write + Seek> SessionWriter<W> {
    /// Hands every view message to `tap` as well.
    pub fn with_tap(mut self, tap: Box<dyn ViewTap>) -> Self {
        self.tap = Some(tap);
        self
    }

    /// Starts a recording of `info.session` into `w`, writing the session metadata first.
    pub fn new(w: W, info: &SessionInfo, options: RecorderOptions) -> Result<Self, RecordError> {
        let keys = proto::Keys::new(&info.session).map_err(|e| {
            RecordError::Io(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                e.to_string(),
            ))
        })?;
        let mcap = WriteOptions::new()
            .compression(Some(Compression::Zstd))
            .compression_level(options.zstd_level)
            .compression_threads(0)
            .chunk_size(Some(options.chunk_bytes.max(1024)))
            .disable_seeking(true)
            .profile("waggle")
            .create(w)?;
        let mut me = Self {
            mcap,
            prefix: keys.prefix().to_string(),
            options,
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            sequence: BTreeMap::new(),
            event_views: BTreeMap::new(),
            rgb_seen: BTreeMap::new(),
            rgb_frames: BTreeMap::new(),
            sim_time_ns: 0,
            stats: RecordStats::default(),
            scene: Scene::default(),
            next_scene_ns: 0,
            tap: None,
            observers: info.observers,
            modality: info.modality.clone(),
        };
        me.mcap.write_metadata(&Metadata {
            name: SESSION_METADATA.into(),
            metadata: info.to_metadata(),
        })?;
        Ok(me)
    }

    /// The view channels this session will carry, known before its first message, sorted by
    /// topic: every observer's images (when the modality is known), the poses, the scene and
    /// the log. A live view advertises them all before any client connects (see
    /// `recorder-node`'s `live`); a view topic not listed here is still recorded when it comes.
    pub fn expected_views(&self) -> Vec<(String, ViewKind)> {
        let images = match self.modality.as_deref() {
            Some("events") if self.options.event_view_period_ns.is_some() => Some("events"),
            Some("rgb") => Some("rgb"),
            _ => None,
        };
        let mut out: Vec<(String, ViewKind)> = images
            .into_iter()
            .flat_map(|kind| {
                (0..self.observers).map(move |i| {
                    (
                        format!("/view/{}/{kind}", observer_name(i)),
                        ViewKind::Image,
                    )
                })
            })
            .chain([
                (TF_TOPIC.to_string(), ViewKind::Transforms),
                (SCENE_TOPIC.to_string(), ViewKind::Scene),
                (LOG_TOPIC.to_string(), ViewKind::Log),
            ])
            .collect();
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    /// The session's sim time as far as recorded (the log time of a message without its own).
    pub fn sim_time_ns(&self) -> u64 {
        self.sim_time_ns
    }

    pub fn stats(&self) -> &RecordStats {
        &self.stats
    }

    fn schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> Result<u16, RecordError> {
        if let Some(&id) = self.schemas.get(name) {
            return Ok(id);
        }
        let id = self.mcap.add_schema(name, encoding, data)?;
        self.schemas.insert(name.to_string(), id);
        Ok(id)
    }

    fn channel(
        &mut self,
        topic: &str,
        schema: Option<(&str, &str, Vec<u8>)>,
        encoding: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<u16, RecordError> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let schema_id = match schema {
            Some((name, enc, data)) => self.schema(name, enc, &data)?,
            None => 0,
        };
        let id = self
            .mcap
            .add_channel(schema_id, topic, encoding, &metadata)?;
        self.channels.insert(topic.to_string(), id);
        Ok(id)
    }

    fn put(&mut self, channel: u16, time_ns: u64, data: &[u8]) -> Result<(), RecordError> {
        let seq = self.sequence.entry(channel).or_insert(0);
        *seq = seq.wrapping_add(1);
        self.mcap.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel,
                sequence: *seq,
                log_time: time_ns,
                publish_time: time_ns,
            },
            data,
        )?;
        Ok(())
    }

    fn raw_channel(
        &mut self,
        topic: &str,
        kind: MessageKind,
        key: &str,
    ) -> Result<u16, RecordError> {
        let description = format!(
            "proto::encode of proto::{} (2-byte little-endian format version {}, then bincode \
             fixint little-endian); decode with proto::decode",
            kind.schema_name().trim_start_matches("waggle."),
            proto::FORMAT_VERSION
        );
        let mut metadata = BTreeMap::new();
        metadata.insert("key".to_string(), key.to_string());
        self.channel(
            topic,
            Some((kind.schema_name(), RAW_ENCODING, description.into_bytes())),
            RAW_ENCODING,
            metadata,
        )
    }

    fn view(&mut self, topic: &str, time_ns: u64, msg: ViewMessage) -> Result<(), RecordError> {
        let id = self.channel(
            topic,
            Some((
                msg.schema_name(),
                msg.schema.encoding.as_str(),
                msg.schema.data.to_vec(),
            )),
            VIEW_ENCODING,
            BTreeMap::new(),
        )?;
        self.put(id, time_ns, &msg.data)?;
        if let Some(tap) = self.tap.as_mut() {
            tap.view(topic, time_ns, &msg);
        }
        Ok(())
    }

    /// Applies one RGB update of camera `o`; the whole frame when its view image is due.
    fn rgb_view_frame(
        &mut self,
        o: &ObserverId,
        update: &proto::RgbUpdate,
    ) -> Option<proto::RgbFrame> {
        let frames = self.rgb_frames.entry(o.clone()).or_default();
        let Ok(frame) = frames.apply(update.clone()) else {
            *self.stats.rgb_unassembled.entry(o.to_string()).or_insert(0) += 1;
            return None;
        };
        let n = self.rgb_seen.entry(o.clone()).or_insert(0);
        *n += 1;
        if !(*n - 1).is_multiple_of(self.options.rgb_every.max(1)) {
            *self.stats.rgb_skipped.entry(o.to_string()).or_insert(0) += 1;
            return None;
        }
        Some(frame)
    }

    /// Records one message received on `key`. Never fails on the message itself: unknown keys
    /// and undecodable payloads are recorded raw and counted.
    pub fn record(&mut self, key: &str, payload: &[u8]) -> Result<Recorded, RecordError> {
        self.stats.payload_bytes += payload.len() as u64;
        let Some(topic) = classify(&self.prefix, key) else {
            *self.stats.unknown_keys.entry(key.to_string()).or_insert(0) += 1;
            let name = key.strip_prefix(&self.prefix).unwrap_or(key).to_string();
            let id = self.channel(
                &format!(
                    "/unknown{}",
                    if name.starts_with('/') {
                        name
                    } else {
                        format!("/{name}")
                    }
                ),
                None,
                UNKNOWN_ENCODING,
                BTreeMap::from([("key".to_string(), key.to_string())]),
            )?;
            let t = self.sim_time_ns;
            self.put(id, t, payload)?;
            return Ok(Recorded::UnknownKey);
        };
        let decoded = match decode(topic.kind, payload) {
            Ok(d) => d,
            Err(error) => {
                *self
                    .stats
                    .undecodable
                    .entry(topic.topic.clone())
                    .or_insert(0) += 1;
                let id = self.raw_channel(&topic.topic, topic.kind, key)?;
                let t = self.sim_time_ns;
                self.put(id, t, payload)?;
                return Ok(Recorded::Undecodable {
                    kind: topic.kind,
                    error,
                });
            }
        };
        let time_ns = decoded.sim_time_ns().unwrap_or(self.sim_time_ns);
        if let Decoded::Clock(c) = &decoded {
            self.sim_time_ns = self.sim_time_ns.max(c.sim_time_ns);
        }
        match (&decoded, &topic.key) {
            (Decoded::EventPacket(p), Key::SensorEvents(o)) if self.options.events_from_input => {
                let kept = self
                    .stats
                    .events_not_recorded
                    .entry(o.to_string())
                    .or_default();
                kept.packets += 1;
                kept.events += p.len() as u64;
                kept.digest = proto::camera::digest(kept.digest, payload);
            }
            _ => {
                let id = self.raw_channel(&topic.topic, topic.kind, key)?;
                self.put(id, time_ns, payload)?;
                *self.stats.messages.entry(topic.topic.clone()).or_insert(0) += 1;
            }
        }
        // An event camera's input has no view of its own: its packets make the event view.
        if !matches!(topic.key, Key::CameraInput(_)) {
            self.views(&decoded, topic.observer.as_ref(), time_ns)?;
        }
        let mission_end = matches!(&decoded, Decoded::SessionTick(s)
            if s.controls.iter().any(|c| c.event == SessionEvent::MissionEnd));
        Ok(Recorded::Message {
            kind: topic.kind,
            mission_end,
        })
    }

    fn views(
        &mut self,
        msg: &Decoded,
        observer: Option<&ObserverId>,
        time_ns: u64,
    ) -> Result<(), RecordError> {
        match (msg, observer) {
            (Decoded::EventPacket(p), Some(o)) => {
                if let Some(period) = self.options.event_view_period_ns {
                    let view = self
                        .event_views
                        .entry(o.clone())
                        .or_insert_with(|| EventView::new(period));
                    if let Some(img) = view.push(p) {
                        let msg = foxglove::raw_image(
                            img.stamp_ns,
                            o.as_str(),
                            img.image.width(),
                            img.image.height(),
                            img.image.as_raw(),
                        );
                        self.view(&format!("/view/{o}/events"), img.stamp_ns, msg)?;
                        self.stats.view_images += 1;
                    }
                }
            }
            (Decoded::RgbUpdate(u), Some(o)) => {
                if let Some(f) = self.rgb_view_frame(o, u) {
                    let msg = foxglove::raw_image(
                        f.stamp_ns,
                        o.as_str(),
                        u32::from(f.width),
                        u32::from(f.height),
                        &f.rgb,
                    );
                    self.view(&format!("/view/{o}/rgb"), f.stamp_ns, msg)?;
                    self.stats.view_images += 1;
                }
            }
            (Decoded::SimState(s), _) if s.stamp_ns % TICK_NS == 0 => {
                self.view(TF_TOPIC, s.stamp_ns, foxglove::frame_transforms(s))?;
                if s.stamp_ns >= self.next_scene_ns {
                    self.next_scene_ns = s.stamp_ns + SCENE_PERIOD_NS;
                    let msg = self.scene.update(s);
                    self.view(SCENE_TOPIC, s.stamp_ns, msg)?;
                }
            }
            _ => {}
        }
        if let Some((level, name, text)) = log_line(msg) {
            self.view(
                LOG_TOPIC,
                time_ns,
                foxglove::log(time_ns, level, &name, &text),
            )?;
        }
        Ok(())
    }

    /// Writes a log line of the recorder itself (e.g. why it stopped) on the log view.
    pub fn note(&mut self, level: LogLevel, text: &str) -> Result<(), RecordError> {
        let t = self.sim_time_ns;
        self.view(LOG_TOPIC, t, foxglove::log(t, level, "recorder", text))
    }

    /// Closes the current chunk and flushes it to the underlying writer: everything recorded so
    /// far survives a kill from now on.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.mcap.flush()?;
        Ok(())
    }

    /// Writes the `waggle.recorder` metadata, the summary and the footer; returns the writer.
    pub fn finish(mut self, extra: BTreeMap<String, String>) -> Result<W, RecordError> {
        let mut m = extra;
        let json = |v: &BTreeMap<String, u64>| serde_json::to_string(v).unwrap_or_default();
        m.insert("messages".into(), json(&self.stats.messages));
        m.insert("unknown_keys".into(), json(&self.stats.unknown_keys));
        m.insert("undecodable".into(), json(&self.stats.undecodable));
        m.insert("rgb_skipped".into(), json(&self.stats.rgb_skipped));
        m.insert("rgb_unassembled".into(), json(&self.stats.rgb_unassembled));
        m.insert("payload_bytes".into(), self.stats.payload_bytes.to_string());
        m.insert("view_images".into(), self.stats.view_images.to_string());
        m.insert("last_sim_time_ns".into(), self.sim_time_ns.to_string());
        if self.options.events_from_input {
            m.insert(
                EVENTS_NOT_RECORDED.into(),
                serde_json::to_string(&self.stats.events_not_recorded).unwrap_or_default(),
            );
        }
        self.mcap.write_metadata(&Metadata {
            name: RECORDER_METADATA.into(),
            metadata: m,
        })?;
        self.mcap.finish()?;
        let mut w = self.mcap.into_inner();
        w.flush()?;
        Ok(w)
    }
}
