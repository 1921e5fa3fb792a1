//! A Waggle recording (`session.mcap` of a run directory) → a ROS 2 bag.
//!
//! | Waggle key | bag topic | type |
//! | --- | --- | --- |
//! | `sensor/<o>/rgb` | `/<o>/camera/image_raw/compressed` (PNG, lossless) or, with [`crate::ImageFormat::Raw`], `/<o>/camera/image_raw` | `sensor_msgs/msg/CompressedImage` / `Image` (`rgb8`) |
//! | `sensor/<o>/events` | `/<o>/events` | `event_camera_msgs/msg/EventPacket`, `encoding: "evt3"` |
//! | either sensor | `/<o>/camera/camera_info` (with every image or packet) | `sensor_msgs/msg/CameraInfo` |
//! | `sim/state` | `/tf` (`world` → each drone's body frame) | `tf2_msgs/msg/TFMessage` |
//! | (camera mounts) | `/tf_static` (`<o>` → `<o>/camera_optical`), latched | `tf2_msgs/msg/TFMessage` |
//! | `observer/<o>/tokens`, `frames`, `decision` | `/<o>/tokens`, `/<o>/frames`, `/<o>/decision` | `waggle_msgs/msg/Token`, `Frame`, `Decision` |
//! | `fault/<o>` | `/<o>/fault` | `waggle_msgs/msg/Fault` |
//! | `sched/broadcast` (ticks that start a broadcast) | `/performer/broadcast` | `waggle_msgs/msg/Broadcast` |
//!
//! Times: ROS time is Waggle's sim clock (from 0); each message keeps the recording's log time.
//! Event packets are stamped with their start watermark and cover (stamp, stamp + 40 ms]; their
//! EVT 3.0 words, concatenated per camera, are one EVT 3.0 stream (time-high wraps made visible,
//! `time_base` 0), and each packet repeats the time and row words first so a decoder may start
//! at any packet, and ends with the time words of its end watermark, so the stream's clock
//! runs through packets without events as a camera's does. Other keys (clock, status, tracks,
//! setpoints, truth, the scheduler's others and broadcast ticks without a broadcast, rejects)
//! are not exported and are counted in [`ExportReport::not_exported`].
//!
//! Output is sorted by log time within a sliding window ([`REORDER_WINDOW_NS`]; ties keep the
//! recording's order) and deterministic: the same recording gives the same bytes. A recording
//! that is damaged, cut short or holds a message that does not decode is refused, naming the
//! file and the byte range or the message; the partial bag is removed.

use std::collections::{BTreeMap, BinaryHeap};
use std::path::{Path, PathBuf};

use proto::scene::Formation;
use recording::{
    Decoded, MessageKind, RAW_ENCODING, SESSION_METADATA, SessionInfo, decode, leading_metadata,
    read_recording,
};

use crate::bag::{BagSummary, BagWriter};
use crate::convert::{Converted, ExportOptions, RosConverter};
use crate::error::Ros2Error;

/// Messages are held this long (sim time) to be written in log-time order.
pub const REORDER_WINDOW_NS: u64 = 1_000_000_000;
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
    order: u64,
    msg: Converted,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        self.key() == other.key()
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
        other.key().cmp(&self.key())
    }
}

impl Pending {
    fn key(&self) -> (u64, u64) {
        (self.msg.log_time_ns, self.order)
    }
}

/// The bag side of an export: the reorder window and the writer.
struct Exporter {
    converter: RosConverter,
    bag: BagWriter,
    pending: BinaryHeap<Pending>,
    order: u64,
    latest_ns: u64,
}

impl Exporter {
    /// Moves what the converter made into the reorder window.
    fn queue(&mut self) {
        for msg in self.converter.take() {
            self.order += 1;
            self.pending.push(Pending {
                order: self.order,
                msg,
            });
        }
    }

    /// Writes every queued message older than `before_ns` (all with `None`).
    fn flush(&mut self, before_ns: Option<u64>) -> Result<(), Ros2Error> {
        while let Some(p) = self.pending.peek() {
            if before_ns.is_some_and(|t| p.msg.log_time_ns >= t) {
                break;
            }
            let p = self.pending.pop().expect("peeked").msg;
            self.bag.add_topic(&p.topic, p.type_name, p.qos)?;
            self.bag.write_cdr(&p.topic, p.log_time_ns, &p.cdr)?;
        }
        Ok(())
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
pub fn pitches(recording: &Path) -> Result<BTreeMap<String, f64>, Ros2Error> {
    let info = leading_metadata(recording, SESSION_METADATA)?
        .map(|m| SessionInfo::from_metadata(&m))
        .unwrap_or_default();
    Ok(formation_pitches(info.observers))
}

/// Camera pitch of each observer of the built-in formation of `observers` (none when there is
/// no such formation).
pub fn formation_pitches(observers: usize) -> BTreeMap<String, f64> {
    let Ok(formation) = Formation::standard(observers) else {
        return BTreeMap::new();
    };
    formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, p)| (proto::scene::observer_name(i), p.pitch_rad))
        .collect()
}

/// A recorded message, or one put in its place: its topic, the message and its log time.
pub type Substituted = (String, Decoded, u64);

/// Replaces recorded messages before they are converted: for a recording that kept the event
/// sensors' input instead of their packets, the packets regenerated from it.
pub trait Substitute {
    /// What to convert in place of `msg`, recorded on `topic` at `log_time_ns` (nothing, the
    /// message itself, or others).
    fn substitute(
        &mut self,
        topic: &str,
        msg: Decoded,
        log_time_ns: u64,
    ) -> Result<Vec<Substituted>, String>;

    /// What is still held when the recording ends.
    fn finish(&mut self) -> Result<Vec<Substituted>, String>;
}

/// Exports the recording of `run` (a run directory or a `.mcap` file) as the bag directory
/// `out`, which must not exist or be empty. The bag is written beside `out` first and moved
/// there only when complete.
pub fn export_run(
    run: &Path,
    out: &Path,
    options: &ExportOptions,
) -> Result<ExportReport, Ros2Error> {
    export_run_with(run, out, options, None)
}

/// [`export_run`] with every recorded message passed through `substitute` first (required for
/// a recording that kept the event sensors' input).
pub fn export_run_with(
    run: &Path,
    out: &Path,
    options: &ExportOptions,
    substitute: Option<&mut dyn Substitute>,
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
    let result = export_into(&recording, &staging, options, substitute);
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
    mut substitute: Option<&mut dyn Substitute>,
) -> Result<ExportReport, Ros2Error> {
    let shown = recording.display().to_string();
    let info = leading_metadata(recording, SESSION_METADATA)?
        .map(|m| SessionInfo::from_metadata(&m))
        .unwrap_or_default();
    if info.events_from_input && substitute.is_none() {
        return Err(Ros2Error::EventsNotRecorded { path: shown });
    }
    let substitute_error = |reason| Ros2Error::Substitute {
        path: shown.clone(),
        reason,
    };
    let pitch_rad = pitches(recording)?;
    let mut x = Exporter {
        converter: RosConverter::new(&shown, *options, pitch_rad),
        bag: BagWriter::create(staging)?,
        pending: BinaryHeap::new(),
        order: 0,
        latest_ns: 0,
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
        let messages = match substitute.as_mut() {
            Some(s) => s
                .substitute(m.topic, decoded, m.log_time_ns)
                .map_err(substitute_error)?,
            None => vec![(m.topic.to_string(), decoded, m.log_time_ns)],
        };
        for (topic, msg, log_time_ns) in messages {
            if !x.converter.convert(&topic, msg, log_time_ns)? {
                *not_exported.entry(topic).or_insert(0) += 1;
            }
        }
        x.queue();
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
    if let Some(s) = substitute {
        for (topic, msg, log_time_ns) in s.finish().map_err(substitute_error)? {
            if !x.converter.convert(&topic, msg, log_time_ns)? {
                *not_exported.entry(topic).or_insert(0) += 1;
            }
        }
        x.queue();
    }
    x.flush(None)?;
    let (events, images) = (x.converter.events(), x.converter.images());
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
