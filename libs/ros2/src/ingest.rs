//! ROS 2 event bags read back (`waggle decode --events BAG`): the `event_camera_msgs/msg/
//! EventPacket` messages of one topic of a rosbag2 MCAP bag (a bag directory or its `.mcap`
//! file), their CDR decoded ([`EventPacketMsg::from_cdr`]) and their `evt3` payloads decoded as
//! one EVT 3.0 word stream, in the bag's order (`event_formats::evt3::StreamDecoder`).
//!
//! Event times are the EVT 3.0 stream's own clock at microsecond resolution, as in a `.raw`
//! file: for bags of `waggle export ros2` that is sim time (`time_base` 0); header stamps and
//! `time_base` are not used. Only `encoding: "evt3"`, little-endian, is read.
//!
//! [`PacketDecoder`] and [`image_from_cdr`] decode one message at a time, for a bag here and for
//! a live topic (`waggle observe`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use event_camera::Event;
use event_formats::evt3::StreamDecoder;

use crate::cdr::{CdrError, CdrReader, RosMessage};
use crate::error::Ros2Error;
use crate::messages::{CompressedImageMsg, EventPacketMsg, HeaderMsg, ImageMsg, TimeMsg};

impl HeaderMsg {
    fn read(r: &mut CdrReader) -> Result<Self, CdrError> {
        let stamp = TimeMsg {
            sec: r.i32()?,
            nanosec: r.u32()?,
        };
        Ok(Self {
            stamp,
            frame_id: r.string()?,
        })
    }
}

impl EventPacketMsg {
    /// Decodes a message's CDR bytes (encapsulation header first).
    pub fn from_cdr(bytes: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        Ok(Self {
            header: HeaderMsg::read(&mut r)?,
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

impl CompressedImageMsg {
    /// Decodes a message's CDR bytes (encapsulation header first).
    pub fn from_cdr(bytes: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        Ok(Self {
            header: HeaderMsg::read(&mut r)?,
            format: r.string()?,
            data: r.bytes()?.to_vec(),
        })
    }
}

impl ImageMsg {
    /// Decodes a message's CDR bytes (encapsulation header first).
    pub fn from_cdr(bytes: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        Ok(Self {
            header: HeaderMsg::read(&mut r)?,
            height: r.u32()?,
            width: r.u32()?,
            encoding: r.string()?,
            is_bigendian: r.u8()?,
            step: r.u32()?,
            data: r.bytes()?.to_vec(),
        })
    }
}

/// One image of a bag, as 8-bit RGB.
#[derive(Debug, Clone, PartialEq)]
pub struct BagImage {
    /// The message header's stamp, ns.
    pub stamp_ns: u64,
    pub width: u16,
    pub height: u16,
    /// Row-major RGB, 3 bytes a pixel.
    pub rgb: Vec<u8>,
}

/// The image messages of one topic of a bag, decoded one at a time ([`ImageBag::images`]) so a
/// long recording is never held decompressed.
#[derive(Debug, Clone)]
pub struct ImageBag {
    path: PathBuf,
    pub topic: String,
    /// `sensor_msgs/msg/CompressedImage` (else `sensor_msgs/msg/Image`).
    pub compressed: bool,
    messages: Vec<(usize, u64, Vec<u8>)>,
}

/// Finds the image topic `topic` of the bag at `path` (`sensor_msgs/msg/CompressedImage` in
/// PNG, or `sensor_msgs/msg/Image` in `rgb8`, `bgr8`, `rgba8`, `bgra8` or `mono8`); without a
/// topic, the bag's only image topic, or the first of `preferred` it has when there are
/// several.
pub fn read_image_bag(
    path: &Path,
    topic: Option<&str>,
    preferred: &[&str],
) -> Result<ImageBag, Ros2Error> {
    let compressed = topic_messages(path, CompressedImageMsg::TYPE_NAME, topic, preferred);
    let (found, compressed) = match compressed {
        Ok(found) => (found, true),
        Err(first) => match topic_messages(path, ImageMsg::TYPE_NAME, topic, preferred) {
            Ok(found) => (found, false),
            Err(_) => return Err(first),
        },
    };
    Ok(ImageBag {
        path: path.to_path_buf(),
        topic: found.topic,
        compressed,
        messages: found.messages,
    })
}

impl ImageBag {
    /// Messages on the topic.
    pub fn len(&self) -> usize {
        self.messages.len()
    }

    pub fn is_empty(&self) -> bool {
        self.messages.is_empty()
    }

    /// The topic's images in the bag's order, each decoded when reached.
    pub fn images(&self) -> impl Iterator<Item = Result<BagImage, Ros2Error>> + '_ {
        self.messages
            .iter()
            .enumerate()
            .map(|(i, (_, log_time, cdr))| {
                image_from_cdr(cdr, self.compressed)
                    .map_err(|reason| message_error(&self.path, &self.topic, i, *log_time, reason))
            })
    }
}

fn stamp_ns(header: &HeaderMsg) -> Result<u64, String> {
    let sec = u64::try_from(header.stamp.sec)
        .map_err(|_| format!("stamp {} s is before 1970", header.stamp.sec))?;
    Ok(sec * 1_000_000_000 + u64::from(header.stamp.nanosec))
}

fn size(width: u32, height: u32) -> Result<(u16, u16), String> {
    match (u16::try_from(width), u16::try_from(height)) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(format!("image {width}×{height}")),
    }
}

fn compressed_image(msg: &CompressedImageMsg) -> Result<BagImage, String> {
    if !msg.format.to_ascii_lowercase().contains("png") {
        return Err(format!(
            "format {:?}: only PNG compressed images are read (republish lossy images as              sensor_msgs/msg/Image)",
            msg.format
        ));
    }
    let decoded = image::load_from_memory_with_format(&msg.data, image::ImageFormat::Png)
        .map_err(|e| format!("PNG: {e}"))?
        .into_rgb8();
    let (width, height) = size(decoded.width(), decoded.height())?;
    Ok(BagImage {
        stamp_ns: stamp_ns(&msg.header)?,
        width,
        height,
        rgb: decoded.into_raw(),
    })
}

fn raw_image(msg: &ImageMsg) -> Result<BagImage, String> {
    let (width, height) = size(msg.width, msg.height)?;
    let (channels, order): (usize, [usize; 3]) = match msg.encoding.as_str() {
        "rgb8" => (3, [0, 1, 2]),
        "bgr8" => (3, [2, 1, 0]),
        "rgba8" => (4, [0, 1, 2]),
        "bgra8" => (4, [2, 1, 0]),
        "mono8" => (1, [0, 0, 0]),
        other => {
            return Err(format!(
                "encoding {other:?}: rgb8, bgr8, rgba8, bgra8 and mono8 are read"
            ));
        }
    };
    let row = usize::from(width) * channels;
    let step = msg.step as usize;
    if step < row || msg.data.len() < step * usize::from(height) {
        return Err(format!(
            "{} bytes with step {step} for a {width}×{height} {} image",
            msg.data.len(),
            msg.encoding
        ));
    }
    let mut rgb = Vec::with_capacity(usize::from(width) * usize::from(height) * 3);
    for line in msg.data.chunks(step).take(usize::from(height)) {
        for px in line[..row].chunks(channels) {
            rgb.extend(order.iter().map(|&c| px[c]));
        }
    }
    Ok(BagImage {
        stamp_ns: stamp_ns(&msg.header)?,
        width,
        height,
        rgb,
    })
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

/// A bad message: the topic, its index and log time, and what is wrong.
fn message_error(
    path: &Path,
    topic: &str,
    i: usize,
    log_time_ns: u64,
    reason: String,
) -> Ros2Error {
    bag_error(
        path,
        format!("{topic} message {i} (log time {log_time_ns} ns): {reason}"),
    )
}

fn bag_error(path: &Path, reason: impl Into<String>) -> Ros2Error {
    Ros2Error::BagRead {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// One topic's messages of one type: `(file index, log time, CDR bytes)` in the stream's order
/// (file, then log time; equal times keep the file's order).
struct TopicMessages {
    topic: String,
    messages: Vec<(usize, u64, Vec<u8>)>,
}

/// The messages of type `type_name` on `topic` of the bag at `path`; without a topic, the bag's
/// only topic of that type, or the first of `preferred` (e.g. `/O1/events`) it has when there
/// are several.
fn topic_messages(
    path: &Path,
    type_name: &str,
    topic: Option<&str>,
    preferred: &[&str],
) -> Result<TopicMessages, Ros2Error> {
    // (topic, file, log time, CDR bytes) of every message of the type.
    let mut packets: Vec<(String, usize, u64, Vec<u8>)> = Vec::new();
    let files = mcap_files(path)?;
    for (k, file) in files.iter().enumerate() {
        let bytes = std::fs::read(file).map_err(|source| Ros2Error::Io {
            path: file.display().to_string(),
            source,
        })?;
        let mut found = file_messages(file, &bytes, type_name, topic)?;
        packets.extend(found.drain(..).map(|(t, time, cdr)| (t, k, time, cdr)));
    }
    choose_topic(path, packets, type_name, topic, preferred)
}

/// Reads the events of `topic` of one bag file already in memory (`bytes`; `path` names it in
/// errors), as [`read_event_bag`] reads a file.
pub fn read_event_bag_bytes(
    path: &Path,
    bytes: &[u8],
    topic: Option<&str>,
    preferred: Option<&str>,
) -> Result<EventBag, Ros2Error> {
    let preferred: Vec<&str> = preferred.into_iter().collect();
    let found = file_messages(path, bytes, EventPacketMsg::TYPE_NAME, topic)?;
    let packets = found.into_iter().map(|(t, time, cdr)| (t, 0, time, cdr));
    let found = choose_topic(
        path,
        packets.collect(),
        EventPacketMsg::TYPE_NAME,
        topic,
        &preferred,
    )?;
    decode_packets(path, found)
}

/// Largest record of a bag read back (a chunk decompressed, or one message): 128 MiB holds an
/// event packet of 64 M EVT 3.0 words or five 4K RGB images; a length field claiming more is
/// refused before anything is allocated for it.
const BAG_RECORD_LIMIT_BYTES: usize = 128 << 20;

/// `(topic, log time, CDR bytes)` of every message of type `type_name` (on `topic`, if given)
/// of one MCAP file's `bytes`, read record by record (chunks decompressed) with every length
/// checked before `mcap` allocates for it (`recording::records`).
fn file_messages(
    file: &Path,
    bytes: &[u8],
    type_name: &str,
    topic: Option<&str>,
) -> Result<Vec<(String, u64, Vec<u8>)>, Ros2Error> {
    use mcap::records::op;
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
    let bad = |e: String| bag_error(file, e);
    let unreadable = |e: String| bag_error(file, format!("not a readable MCAP file: {e}"));
    // Chunks come whole and go through the recorder's checked chunk reader.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_record_length_limit(BAG_RECORD_LIMIT_BYTES)
            .with_emit_chunks(true),
    );
    let mut bag = BagRecords::default();
    let mut fed = false;
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| unreadable(e.to_string()))? {
            LinearReadEvent::ReadRequest(_) if fed => reader.notify_read(0),
            LinearReadEvent::ReadRequest(_) => {
                reader.insert(bytes.len()).copy_from_slice(bytes);
                reader.notify_read(bytes.len());
                fed = true;
            }
            LinearReadEvent::Record { data, opcode } if opcode == op::CHUNK => {
                let mut record = vec![opcode];
                record.extend((data.len() as u64).to_le_bytes());
                record.extend(data);
                let inner = recording::records::chunk_records(&record).map_err(unreadable)?;
                for (opcode, data) in inner {
                    bag.take(opcode, &data, type_name, topic).map_err(bad)?;
                }
            }
            LinearReadEvent::Record { data, opcode } => {
                bag.take(opcode, data, type_name, topic).map_err(bad)?;
            }
        }
    }
    Ok(bag.out)
}

/// The schemas and channels of a bag file so far, and the messages kept.
#[derive(Default)]
struct BagRecords {
    schemas: BTreeMap<u16, String>,
    channels: BTreeMap<u16, mcap::records::Channel>,
    out: Vec<(String, u64, Vec<u8>)>,
}

impl BagRecords {
    /// Takes one record: a schema or channel is kept, a message of type `type_name` (on
    /// `topic`, if given) too.
    fn take(
        &mut self,
        opcode: u8,
        data: &[u8],
        type_name: &str,
        topic: Option<&str>,
    ) -> Result<(), String> {
        use mcap::records::Record;
        let record = recording::records::parse(opcode, data)
            .map_err(|e| format!("not a readable MCAP file: {e}"))?;
        match record {
            Some(Record::Schema { header, .. }) => {
                self.schemas.insert(header.id, header.name);
            }
            Some(Record::Channel(c)) => {
                self.channels.insert(c.id, c);
            }
            Some(Record::Message { header, data }) => {
                let c = self.channels.get(&header.channel_id).ok_or_else(|| {
                    format!(
                        "not a readable MCAP file: a message on undeclared channel {}",
                        header.channel_id
                    )
                })?;
                let schema = self.schemas.get(&c.schema_id).map(String::as_str);
                if schema != Some(type_name) || topic.is_some_and(|t| t != c.topic) {
                    return Ok(());
                }
                if c.message_encoding != "cdr" {
                    return Err(format!(
                        "{}: message encoding {:?}, not cdr",
                        c.topic, c.message_encoding
                    ));
                }
                self.out
                    .push((c.topic.clone(), header.log_time, data.into_owned()));
            }
            _ => {}
        }
        Ok(())
    }
}

/// The messages of the topic chosen among `packets` (`(topic, file, log time, CDR bytes)`):
/// `topic`, else the only topic, else the first of `preferred` present.
fn choose_topic(
    path: &Path,
    packets: Vec<(String, usize, u64, Vec<u8>)>,
    type_name: &str,
    topic: Option<&str>,
    preferred: &[&str],
) -> Result<TopicMessages, Ros2Error> {
    let mut topics: Vec<&str> = packets.iter().map(|p| p.0.as_str()).collect();
    topics.sort_unstable();
    topics.dedup();
    let chosen = match (topic, topics.as_slice()) {
        (Some(t), []) => {
            return Err(bag_error(
                path,
                format!("no {type_name} messages on topic {t}"),
            ));
        }
        (_, []) => return Err(bag_error(path, format!("no {type_name} topic"))),
        (_, [one]) => (*one).to_owned(),
        (_, many) => match preferred.iter().find(|p| many.contains(p)) {
            Some(p) => (*p).to_owned(),
            None => {
                return Err(bag_error(
                    path,
                    format!(
                        "several {type_name} topics ({}): choose one with --topic",
                        many.join(", ")
                    ),
                ));
            }
        },
    };
    let mut messages: Vec<(usize, u64, Vec<u8>)> = packets
        .into_iter()
        .filter(|p| p.0 == chosen)
        .map(|(_, k, t, cdr)| (k, t, cdr))
        .collect();
    messages.sort_by_key(|p| (p.0, p.1));
    Ok(TopicMessages {
        topic: chosen,
        messages,
    })
}

/// Reads the events of `topic` of the bag at `path`; without a topic, the bag's only
/// `EventPacket` topic, or `preferred` (e.g. `/O1/events`) when there are several.
pub fn read_event_bag(
    path: &Path,
    topic: Option<&str>,
    preferred: Option<&str>,
) -> Result<EventBag, Ros2Error> {
    let preferred: Vec<&str> = preferred.into_iter().collect();
    let found = topic_messages(path, EventPacketMsg::TYPE_NAME, topic, &preferred)?;
    decode_packets(path, found)
}

fn decode_packets(path: &Path, found: TopicMessages) -> Result<EventBag, Ros2Error> {
    let mut decoder = PacketDecoder::default();
    let mut events = Vec::new();
    for (i, (_, log_time, cdr)) in found.messages.iter().enumerate() {
        decoder
            .push(cdr, &mut events)
            .map_err(|reason| message_error(path, &found.topic, i, *log_time, reason))?;
    }
    let (width, height) = decoder.size().unwrap_or((0, 0));
    Ok(EventBag {
        topic: found.topic,
        messages: decoder.messages(),
        width,
        height,
        events,
    })
}

/// `event_camera_msgs/msg/EventPacket` messages of one camera decoded one at a time, in the
/// order they come (a bag's, or a live topic's): every message `evt3`, little-endian, of one
/// sensor size; the EVT 3.0 state carries from one message to the next.
#[derive(Debug, Clone, Default)]
pub struct PacketDecoder {
    decoder: StreamDecoder,
    size: Option<(u16, u16)>,
    messages: u64,
    triggers: Vec<event_formats::evt3::Trigger>,
}

impl PacketDecoder {
    /// The sensor's size, once a message has stated it.
    pub fn size(&self) -> Option<(u16, u16)> {
        self.size
    }

    /// Messages decoded.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// The EVT 3.0 stream's clock after the messages decoded so far, ns: the stream has
    /// reached it even where it carried no event.
    pub fn stream_time_ns(&self) -> Option<u64> {
        self.decoder.time_us().map(|t_us| t_us * 1000)
    }

    /// Decodes one message's CDR bytes, appending its events to `events`. A message that is
    /// refused adds no event (its reason is returned); the stream's state stays as it was
    /// after the words decoded before the fault.
    pub fn push(&mut self, cdr: &[u8], events: &mut Vec<Event>) -> Result<(), String> {
        let msg = EventPacketMsg::from_cdr(cdr).map_err(|e| e.to_string())?;
        if msg.encoding != "evt3" || msg.is_bigendian {
            return Err(format!(
                "encoding {:?}{}: only little-endian evt3 is read",
                msg.encoding,
                if msg.is_bigendian { ", big-endian" } else { "" }
            ));
        }
        let size = (u16::try_from(msg.width), u16::try_from(msg.height));
        let (Ok(width), Ok(height)) = size else {
            return Err(format!("sensor {}×{}", msg.width, msg.height));
        };
        match self.size {
            None => self.size = Some((width, height)),
            Some((w, h)) if (w, h) != (width, height) => {
                return Err(format!("sensor {width}×{height} after {w}×{h}"));
            }
            Some(_) => {}
        }
        let before = events.len();
        self.triggers.clear();
        if let Err(e) = self
            .decoder
            .decode(&msg.events, 0, events, &mut self.triggers)
        {
            events.truncate(before);
            return Err(format!("events payload: {e}"));
        }
        self.messages += 1;
        Ok(())
    }
}

/// One `sensor_msgs/msg/CompressedImage` (PNG; `compressed`) or `sensor_msgs/msg/Image`
/// message's CDR bytes as an 8-bit RGB image, or why not.
pub fn image_from_cdr(cdr: &[u8], compressed: bool) -> Result<BagImage, String> {
    if compressed {
        compressed_image(&CompressedImageMsg::from_cdr(cdr).map_err(|e| e.to_string())?)
    } else {
        raw_image(&ImageMsg::from_cdr(cdr).map_err(|e| e.to_string())?)
    }
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

    fn header() -> HeaderMsg {
        HeaderMsg {
            stamp: TimeMsg {
                sec: 2,
                nanosec: 40_000_000,
            },
            frame_id: "O1/camera_optical".into(),
        }
    }

    #[test]
    fn raw_images_of_every_read_encoding_become_rgb() {
        // 2×1 pixels, rows padded to 8 bytes.
        let cases: [(&str, Vec<u8>); 3] = [
            ("bgr8", vec![3, 2, 1, 6, 5, 4, 0, 0]),
            ("rgba8", vec![1, 2, 3, 9, 4, 5, 6, 9]),
            ("mono8", vec![7, 8, 0, 0, 0, 0, 0, 0]),
        ];
        for (encoding, data) in cases {
            let msg = ImageMsg {
                header: header(),
                height: 1,
                width: 2,
                encoding: encoding.into(),
                is_bigendian: 0,
                step: 8,
                data,
            };
            let back = ImageMsg::from_cdr(&msg.to_cdr()).unwrap();
            assert_eq!(back, msg);
            let image = raw_image(&back).unwrap();
            assert_eq!(image.stamp_ns, 2_040_000_000);
            let want = if encoding == "mono8" {
                vec![7, 7, 7, 8, 8, 8]
            } else {
                vec![1, 2, 3, 4, 5, 6]
            };
            assert_eq!(image.rgb, want, "{encoding}");
        }
        let short = ImageMsg {
            header: header(),
            height: 2,
            width: 2,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: 6,
            data: vec![0; 6],
        };
        assert!(raw_image(&short).unwrap_err().contains("6 bytes"));
    }

    #[test]
    fn compressed_images_must_be_png() {
        let mut png = Vec::new();
        image::RgbImage::from_raw(1, 1, vec![10, 20, 30])
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let msg = CompressedImageMsg {
            header: header(),
            format: "rgb8; png compressed bgr8".into(),
            data: png,
        };
        let back = CompressedImageMsg::from_cdr(&msg.to_cdr()).unwrap();
        assert_eq!(compressed_image(&back).unwrap().rgb, [10, 20, 30]);
        let jpeg = CompressedImageMsg {
            format: "jpeg".into(),
            ..msg
        };
        assert!(compressed_image(&jpeg).unwrap_err().contains("only PNG"));
    }
}
