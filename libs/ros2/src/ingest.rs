//! ROS 2 event bags read back (`waggle decode --events BAG`): the `event_camera_msgs/msg/
//! EventPacket` messages of one topic of a rosbag2 MCAP bag (a bag directory or its `.mcap`
//! file), their CDR decoded ([`EventPacketMsg::from_cdr`]) and their `evt3` payloads decoded as
//! one EVT 3.0 word stream, in the bag's order (`event_formats::evt3::StreamDecoder`).
//!
//! Event times are the EVT 3.0 stream's own clock at microsecond resolution, as in a `.raw`
//! file: for bags of `waggle export ros2` that is sim time (`time_base` 0); header stamps and
//! `time_base` are not used. Only `encoding: "evt3"`, little-endian, is read.

use std::path::{Path, PathBuf};

use event_camera::Event;
use event_formats::evt3::StreamDecoder;

use crate::cdr::{CdrError, CdrReader, RosMessage};
use crate::error::Ros2Error;
use crate::messages::{EventPacketMsg, HeaderMsg, TimeMsg};

impl EventPacketMsg {
    /// Decodes a message's CDR bytes (encapsulation header first).
    pub fn from_cdr(bytes: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        let stamp = TimeMsg {
            sec: r.i32()?,
            nanosec: r.u32()?,
        };
        let frame_id = r.string()?;
        Ok(Self {
            header: HeaderMsg { stamp, frame_id },
            height: r.u32()?,
            width: r.u32()?,
            seq: r.u64()?,
            time_base: r.u64()?,
            encoding: r.string()?,
            is_bigendian: r.bool()?,
            events: r.bytes()?.to_vec(),
        })
    }
}

/// The events of one topic of a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct EventBag {
    pub topic: String,
    /// Messages read.
    pub messages: u64,
    pub width: u16,
    pub height: u16,
    pub events: Vec<Event>,
}

/// The MCAP files of a bag: a `.mcap` file itself, or a bag directory's `*.mcap` files in name
/// order (rosbag2 numbers its splits `_0`, `_1`, …).
pub fn mcap_files(path: &Path) -> Result<Vec<PathBuf>, Ros2Error> {
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let io = |source| Ros2Error::Io {
        path: path.display().to_string(),
        source,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(bag_error(
            path,
            "no .mcap file in the bag directory (only rosbag2's MCAP storage is read; convert a \
             sqlite3 bag with `ros2 bag convert`)",
        ));
    }
    Ok(files)
}

fn bag_error(path: &Path, reason: impl Into<String>) -> Ros2Error {
    Ros2Error::BagRead {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// Reads the events of `topic` of the bag at `path`; without a topic, the bag's only
/// `EventPacket` topic, or `preferred` (e.g. `/O1/events`) when there are several.
pub fn read_event_bag(
    path: &Path,
    topic: Option<&str>,
    preferred: Option<&str>,
) -> Result<EventBag, Ros2Error> {
    // (topic, file, log time, CDR bytes) of every EventPacket message.
    let mut packets: Vec<(String, usize, u64, Vec<u8>)> = Vec::new();
    let files = mcap_files(path)?;
    for (k, file) in files.iter().enumerate() {
        let bytes = std::fs::read(file).map_err(|source| Ros2Error::Io {
            path: file.display().to_string(),
            source,
        })?;
        let mcap = |e: mcap::McapError| bag_error(file, format!("not a readable MCAP file: {e}"));
        for m in mcap::MessageStream::new(&bytes).map_err(mcap)? {
            let m = m.map_err(mcap)?;
            let schema = m.channel.schema.as_ref().map(|s| s.name.as_str());
            if schema == Some(EventPacketMsg::TYPE_NAME)
                && topic.is_none_or(|t| t == m.channel.topic)
            {
                if m.channel.message_encoding != "cdr" {
                    return Err(bag_error(
                        file,
                        format!(
                            "{}: message encoding {:?}, not cdr",
                            m.channel.topic, m.channel.message_encoding
                        ),
                    ));
                }
                packets.push((m.channel.topic.clone(), k, m.log_time, m.data.into_owned()));
            }
        }
    }
    let mut topics: Vec<&str> = packets.iter().map(|p| p.0.as_str()).collect();
    topics.sort_unstable();
    topics.dedup();
    let chosen = match (topic, topics.as_slice()) {
        (Some(t), _) if topics.is_empty() => {
            return Err(bag_error(
                path,
                format!("no {} messages on topic {t}", EventPacketMsg::TYPE_NAME),
            ));
        }
        (_, []) => {
            return Err(bag_error(
                path,
                format!("no {} topic", EventPacketMsg::TYPE_NAME),
            ));
        }
        (_, [one]) => (*one).to_owned(),
        (_, many) => match preferred.filter(|p| many.contains(p)) {
            Some(p) => p.to_owned(),
            None => {
                return Err(bag_error(
                    path,
                    format!(
                        "several event topics ({}): choose one with --topic",
                        many.join(", ")
                    ),
                ));
            }
        },
    };
    packets.retain(|p| p.0 == chosen);
    // The stream's order: file, then log time (stable: equal times keep the file's order).
    packets.sort_by_key(|p| (p.1, p.2));
    decode_packets(path, chosen, &packets)
}

fn decode_packets(
    path: &Path,
    topic: String,
    packets: &[(String, usize, u64, Vec<u8>)],
) -> Result<EventBag, Ros2Error> {
    let mut out = EventBag {
        topic,
        messages: 0,
        width: 0,
        height: 0,
        events: Vec::new(),
    };
    let mut decoder = StreamDecoder::new();
    let mut triggers = Vec::new();
    for (i, (_, _, log_time, cdr)) in packets.iter().enumerate() {
        let at = |reason: String| {
            bag_error(
                path,
                format!(
                    "{} message {i} (log time {log_time} ns): {reason}",
                    out.topic
                ),
            )
        };
        let msg = EventPacketMsg::from_cdr(cdr).map_err(|e| at(e.to_string()))?;
        if msg.encoding != "evt3" || msg.is_bigendian {
            return Err(at(format!(
                "encoding {:?}{}: only little-endian evt3 is read",
                msg.encoding,
                if msg.is_bigendian { ", big-endian" } else { "" }
            )));
        }
        let size = (u16::try_from(msg.width), u16::try_from(msg.height));
        let (Ok(width), Ok(height)) = size else {
            return Err(at(format!("sensor {}×{}", msg.width, msg.height)));
        };
        if i == 0 {
            (out.width, out.height) = (width, height);
        } else if (width, height) != (out.width, out.height) {
            return Err(at(format!(
                "sensor {width}×{height} after {}×{}",
                out.width, out.height
            )));
        }
        decoder
            .decode(&msg.events, 0, &mut out.events, &mut triggers)
            .map_err(|e| at(format!("events payload: {e}")))?;
        out.messages += 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::RosMessage;

    #[test]
    fn an_event_packet_decodes_to_what_was_encoded() {
        let msg = EventPacketMsg {
            header: HeaderMsg {
                stamp: TimeMsg {
                    sec: 3,
                    nanosec: 40_000_000,
                },
                frame_id: "O1/camera_optical".into(),
            },
            height: 480,
            width: 640,
            seq: 77,
            time_base: 0,
            encoding: "evt3".into(),
            is_bigendian: false,
            events: vec![0x34, 0x12, 0x01, 0x80],
        };
        let cdr = msg.to_cdr();
        assert_eq!(EventPacketMsg::from_cdr(&cdr).unwrap(), msg);
        let e = EventPacketMsg::from_cdr(&cdr[..cdr.len() - 1]).unwrap_err();
        assert!(e.to_string().contains("runs past the end"), "{e}");
    }
}
