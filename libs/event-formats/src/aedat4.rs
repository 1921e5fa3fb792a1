//! iniVation AEDAT 4.0 (`.aedat4`, the DV software's format), event streams written and read
//! (iniVation's "AEDAT 4.0" file-format documentation):
//!
//! - the version line `#!AER-DAT4.0\r\n`;
//! - a size-prefixed FlatBuffer `IOHeader` (file identifier `IOHE`): `compression` (0 none,
//!   1 LZ4, 2 LZ4 high, 3 Zstd, 4 Zstd high), `dataTablePosition` (byte offset of the
//!   `FileDataTable`, −1 when there is none) and `infoNode`, an XML tree whose
//!   `…/outInfo/<id>/` nodes (at the root, or under DV's `/mainloop/Recorder/`) describe the streams (`typeIdentifier` `EVTS` for events, the
//!   sensor's `sizeX`/`sizeY` under `info/`);
//! - packets: a `PacketHeader` (`i32` stream id, `i32` size), then that many bytes — one LZ4 or
//!   Zstd frame when compressed — holding a size-prefixed FlatBuffer; for events an
//!   `EventPacket` (identifier `EVTS`) whose field 0 is a vector of 16-byte `Event` structs
//!   (`i64` timestamp in µs, `i16` x, `i16` y, `bool` polarity, 3 bytes of padding);
//! - optionally a `FileDataTable` (an index of the packets) at `dataTablePosition`, the end.
//!
//! Reading takes the first `EVTS` stream, skips every other stream's packets and ignores the
//! data table (so files whose recording was cut short, without one, read too). Timestamps are
//! microseconds: Waggle's nanosecond events are written at `t_ns / 1000` (floor), and read back
//! at `t_us · 1000`. Cameras write Unix time; the reader's times count from 0 when the first
//! timestamp is below 2³² µs (≈ 71.6 min: a relative clock, as Waggle writes), else from the
//! earliest event ([`Aedat4Recording::origin_us`]).
//!
//! The writer emits one event stream (id 0) in packets of at most
//! [`WriteOptions::events_per_packet`] events, compressed as asked (LZ4 frames from `lz4_flex`,
//! Zstd from `zstd`; `Lz4High` is written as plain LZ4, which every LZ4 decoder reads), and no
//! data table (`dataTablePosition` −1).
//!
//! Errors name the byte offset of what is wrong (inside a compressed packet: the packet's
//! offset and the offset in its decompressed bytes); nothing in a damaged file panics.

use std::io::{Read, Write};

use event_camera::{Event, Polarity};

use crate::evt3::Geometry;
use crate::flatbuf::{self, FbError, Table};
use crate::input::{EventsError, check_events};

/// The version line every AEDAT 4.0 file starts with.
pub const MAGIC: &[u8] = b"#!AER-DAT4.0\r\n";

/// Bytes of one `Event` struct.
const EVENT_BYTES: usize = 16;

/// Largest decompressed packet accepted (a damaged frame cannot claim all memory).
const MAX_PACKET_BYTES: u64 = 1 << 30;

/// Timestamps below this are a relative clock (read from 0), others Unix time.
const RELATIVE_CLOCK_US: i64 = 1 << 32;

/// Why an AEDAT4 stream could not be written or read; reading errors name the byte offset.
#[derive(Debug, thiserror::Error)]
pub enum Aedat4Error {
    #[error("writing AEDAT4: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error("sensor {width}×{height}: AEDAT4 carries at most 32767×32767")]
    SensorTooLarge { width: u16, height: u16 },
    #[error("byte {offset}: {what}")]
    Data { offset: usize, what: String },
    #[error("packet at byte {packet}, byte {offset} of its decompressed content: {what}")]
    Packet {
        packet: usize,
        offset: usize,
        what: String,
    },
}

fn data(offset: usize, what: impl Into<String>) -> Aedat4Error {
    Aedat4Error::Data {
        offset,
        what: what.into(),
    }
}

/// How packets are compressed (the `IOHeader`'s `compression`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    #[default]
    None,
    Lz4,
    Lz4High,
    Zstd,
    ZstdHigh,
}

impl Compression {
    pub const ALL: [Self; 5] = [
        Self::None,
        Self::Lz4,
        Self::Lz4High,
        Self::Zstd,
        Self::ZstdHigh,
    ];

    fn code(self) -> i32 {
        match self {
            Self::None => 0,
            Self::Lz4 => 1,
            Self::Lz4High => 2,
            Self::Zstd => 3,
            Self::ZstdHigh => 4,
        }
    }

    fn from_code(code: i32) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.code() == code)
    }

    /// The name DV gives it (`compression` in the stream's info node).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "NONE",
            Self::Lz4 => "LZ4",
            Self::Lz4High => "LZ4_HIGH",
            Self::Zstd => "ZSTD",
            Self::ZstdHigh => "ZSTD_HIGH",
        }
    }

    fn compress(self, bytes: &[u8]) -> Result<Vec<u8>, std::io::Error> {
        match self {
            Self::None => Ok(bytes.to_vec()),
            Self::Lz4 | Self::Lz4High => {
                let mut enc = lz4_flex::frame::FrameEncoder::new(Vec::new());
                enc.write_all(bytes)?;
                enc.finish().map_err(std::io::Error::other)
            }
            Self::Zstd => zstd::bulk::compress(bytes, 3),
            Self::ZstdHigh => zstd::bulk::compress(bytes, 15),
        }
    }

    fn decompress(self, bytes: &[u8]) -> Result<Vec<u8>, String> {
        let mut out = Vec::new();
        let read = match self {
            Self::None => return Ok(bytes.to_vec()),
            Self::Lz4 | Self::Lz4High => lz4_flex::frame::FrameDecoder::new(bytes)
                .take(MAX_PACKET_BYTES + 1)
                .read_to_end(&mut out),
            Self::Zstd | Self::ZstdHigh => zstd::stream::read::Decoder::with_buffer(bytes)
                .and_then(|d| d.take(MAX_PACKET_BYTES + 1).read_to_end(&mut out)),
        };
        match read {
            Err(e) => Err(format!("does not decompress ({}): {e}", self.name())),
            Ok(n) if n as u64 > MAX_PACKET_BYTES => Err(format!(
                "decompresses to more than {MAX_PACKET_BYTES} bytes"
            )),
            Ok(_) => Ok(out),
        }
    }
}

/// How [`write()`] lays the events out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteOptions {
    pub compression: Compression,
    /// Events per packet (at least 1).
    pub events_per_packet: usize,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self {
            compression: Compression::Lz4,
            events_per_packet: 8192,
        }
    }
}

/// A decoded `.aedat4` file's event stream.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Aedat4Recording {
    pub geometry: Option<Geometry>,
    pub compression: Compression,
    /// The event stream's id.
    pub stream_id: i32,
    /// The file's timestamp (µs) that the events' t = 0 stands for.
    pub origin_us: i64,
    /// Event packets read.
    pub packets: usize,
    pub events: Vec<Event>,
}

/// The `infoNode` XML Waggle writes for one event stream.
fn info_node(width: u16, height: u16, compression: Compression) -> String {
    let c = compression.name();
    format!(
        "<dv version=\"2.0\">\n    <node name=\"outInfo\" path=\"/outInfo/\">\n        \
         <node name=\"0\" path=\"/outInfo/0/\">\n            \
         <attr key=\"compression\" type=\"string\">{c}</attr>\n            \
         <attr key=\"originalModuleName\" type=\"string\">Waggle</attr>\n            \
         <attr key=\"originalOutputName\" type=\"string\">events</attr>\n            \
         <attr key=\"typeDescription\" type=\"string\">Array of events (polarity ON/OFF).</attr>\n            \
         <attr key=\"typeIdentifier\" type=\"string\">EVTS</attr>\n            \
         <node name=\"info\" path=\"/outInfo/0/info/\">\n                \
         <attr key=\"sizeX\" type=\"int\">{width}</attr>\n                \
         <attr key=\"sizeY\" type=\"int\">{height}</attr>\n                \
         <attr key=\"source\" type=\"string\">Waggle</attr>\n            \
         </node>\n        </node>\n    </node>\n</dv>\n"
    )
}

/// Writes `events` (sorted by time) of a `width`×`height` sensor as an AEDAT4 file.
pub fn write(
    out: &mut impl Write,
    width: u16,
    height: u16,
    events: &[Event],
    opts: &WriteOptions,
) -> Result<(), Aedat4Error> {
    if width == 0 || height == 0 || width > 32767 || height > 32767 {
        return Err(Aedat4Error::SensorTooLarge { width, height });
    }
    check_events(events, width, height, 0)?;
    out.write_all(MAGIC)?;
    let info = info_node(width, height, opts.compression);
    out.write_all(&flatbuf::io_header(opts.compression.code(), -1, &info))?;
    let mut structs = Vec::new();
    for chunk in events.chunks(opts.events_per_packet.max(1)) {
        structs.clear();
        for e in chunk {
            let t_us = i64::try_from(e.t_ns / 1000).unwrap_or(i64::MAX);
            structs.extend_from_slice(&t_us.to_le_bytes());
            // Coordinates are below 32768 (checked above).
            structs.extend_from_slice(&(e.x as i16).to_le_bytes());
            structs.extend_from_slice(&(e.y as i16).to_le_bytes());
            structs.extend_from_slice(&[u8::from(e.polarity == Polarity::On), 0, 0, 0]);
        }
        let packet = flatbuf::one_vector_table(b"EVTS", chunk.len(), &structs);
        let body = opts.compression.compress(&packet)?;
        out.write_all(&0i32.to_le_bytes())?;
        let size = i32::try_from(body.len()).map_err(|_| {
            std::io::Error::other("an AEDAT4 packet is larger than 2 GiB: fewer events per packet")
        })?;
        out.write_all(&size.to_le_bytes())?;
        out.write_all(&body)?;
    }
    Ok(())
}

/// Every `<attr>` of the info node: (path of its `<node>`, key, text).
fn attrs(xml: &str) -> Vec<(String, String, String)> {
    let quoted = |tag: &str, name: &str| -> Option<String> {
        let at = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        let len = tag[at..].find('"')?;
        Some(tag[at..at + len].to_owned())
    };
    let mut stack: Vec<String> = Vec::new();
    let mut out = Vec::new();
    let mut rest = xml;
    while let Some(i) = rest.find('<') {
        rest = &rest[i..];
        let Some(end) = rest.find('>') else { break };
        let tag = &rest[..end];
        if tag.starts_with("</node") {
            stack.pop();
        } else if tag.starts_with("<node") && !tag.ends_with('/') {
            stack.push(quoted(tag, "path").unwrap_or_default());
        } else if tag.starts_with("<attr")
            && let (Some(key), Some(close)) = (quoted(tag, "key"), rest.find("</attr>"))
            && close > end
        {
            let text = rest[end + 1..close]
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&quot;", "\"")
                .replace("&apos;", "'")
                .replace("&amp;", "&");
            out.push((stack.last().cloned().unwrap_or_default(), key, text));
        }
        rest = &rest[end..];
    }
    out
}

/// The first event stream of the info node: its id and geometry.
fn event_stream(xml: &str) -> Option<(i32, Option<Geometry>)> {
    let attrs = attrs(xml);
    let (path, id) = attrs.iter().find_map(|(path, key, text)| {
        // DV's recorder nests the node (`/mainloop/Recorder/outInfo/0/`); Waggle and
        // dv-processing write it at the root (`/outInfo/0/`).
        let (parent, id) = path.strip_suffix('/')?.rsplit_once('/')?;
        if !(parent == "/outInfo" || parent.ends_with("/outInfo")) {
            return None;
        }
        (key == "typeIdentifier" && text.trim() == "EVTS")
            .then(|| id.parse::<i32>().ok().map(|id| (path.clone(), id)))
            .flatten()
    })?;
    let size = |name: &str| {
        attrs.iter().find_map(|(p, k, t)| {
            (*p == format!("{path}info/") && k == name)
                .then(|| t.trim().parse::<u16>().ok())
                .flatten()
        })
    };
    let geometry = match (size("sizeX"), size("sizeY")) {
        (Some(width), Some(height)) => Some(Geometry { width, height }),
        _ => None,
    };
    Some((id, geometry))
}

/// The header: compression, data table position, event stream, and where packets start.
struct Header {
    compression: Compression,
    data_table: i64,
    stream_id: i32,
    geometry: Option<Geometry>,
    packets_at: usize,
}

fn header(bytes: &[u8]) -> Result<Header, Aedat4Error> {
    if !bytes.starts_with(MAGIC) {
        let what = if MAGIC.starts_with(&bytes[..bytes.len().min(MAGIC.len())]) {
            "truncated inside the version line `#!AER-DAT4.0`"
        } else {
            "not an AEDAT 4.0 file (no `#!AER-DAT4.0` version line)"
        };
        return Err(data(0, what));
    }
    let at = MAGIC.len();
    let fb_err =
        |base: usize| move |e: FbError| data(base + e.pos, format!("IOHeader: {}", e.what));
    let size = flatbuf::u32_at(bytes, at)
        .map_err(|_| data(at, "truncated: the IOHeader's size is missing"))?
        as usize;
    let fb = bytes
        .get(at + 4..)
        .and_then(|b| b.get(..size))
        .ok_or_else(|| {
            data(
                at,
                format!("truncated: the IOHeader's {size} bytes run past the end"),
            )
        })?;
    let (table, ident) = Table::root(fb).map_err(fb_err(at + 4))?;
    if &ident != b"IOHE" {
        return Err(data(
            at + 8,
            "the header is not an IOHeader (identifier `IOHE`)",
        ));
    }
    let code = table.i32(0, 0).map_err(fb_err(at + 4))?;
    let compression = Compression::from_code(code)
        .ok_or_else(|| data(at + 4, format!("unknown compression {code}")))?;
    let data_table = table.i64(1, -1).map_err(fb_err(at + 4))?;
    let info = table.string(2).map_err(fb_err(at + 4))?.unwrap_or_default();
    let info = std::str::from_utf8(info).map_err(|_| data(at + 4, "the infoNode is not UTF-8"))?;
    let (stream_id, geometry) = event_stream(info).ok_or_else(|| {
        data(
            at + 4,
            "the header names no event stream (typeIdentifier EVTS)",
        )
    })?;
    Ok(Header {
        compression,
        data_table,
        stream_id,
        geometry,
        packets_at: at + 4 + size,
    })
}

/// Reads an AEDAT 4.0 file's first event stream.
pub fn read(bytes: &[u8]) -> Result<Aedat4Recording, Aedat4Error> {
    let h = header(bytes)?;
    let end = if h.data_table < 0 {
        bytes.len()
    } else {
        let table = usize::try_from(h.data_table).unwrap_or(usize::MAX);
        if table > bytes.len() || table < h.packets_at {
            return Err(data(
                bytes.len(),
                format!(
                    "truncated: the file ends at byte {} but its FileDataTable starts at byte {}",
                    bytes.len(),
                    h.data_table
                ),
            ));
        }
        table
    };
    let mut out = Aedat4Recording {
        geometry: h.geometry,
        compression: h.compression,
        stream_id: h.stream_id,
        ..Aedat4Recording::default()
    };
    let mut stamps: Vec<i64> = Vec::new();
    let mut pos = h.packets_at;
    while pos < end {
        let id = flatbuf::i32_at(&bytes[..end], pos)
            .map_err(|_| data(pos, "truncated: a packet header is cut"))?;
        let size = flatbuf::i32_at(&bytes[..end], pos + 4)
            .map_err(|_| data(pos, "truncated: a packet header is cut"))?;
        let body = usize::try_from(size)
            .ok()
            .and_then(|n| bytes[..end].get(pos + 8..)?.get(..n))
            .ok_or_else(|| {
                data(
                    pos,
                    format!("truncated: a packet of {size} bytes runs past the end"),
                )
            })?;
        if id == h.stream_id {
            let content = h
                .compression
                .decompress(body)
                .map_err(|what| data(pos + 8, format!("packet: {what}")))?;
            let base = (h.compression == Compression::None).then_some(pos + 8);
            packet(
                &content,
                pos,
                base,
                out.geometry,
                &mut out.events,
                &mut stamps,
            )?;
            out.packets += 1;
        }
        pos += 8 + body.len();
    }
    rebase(&mut out, &stamps)?;
    Ok(out)
}

/// Decodes one `EventPacket` (size prefix included) found at byte `packet`; `base` is the
/// file offset of `content[0]` when it is not compressed.
fn packet(
    content: &[u8],
    packet: usize,
    base: Option<usize>,
    geometry: Option<Geometry>,
    events: &mut Vec<Event>,
    stamps: &mut Vec<i64>,
) -> Result<(), Aedat4Error> {
    let err = |offset: usize, what: &str| match base {
        Some(b) => data(b + offset, format!("event packet: {what}")),
        None => Aedat4Error::Packet {
            packet,
            offset,
            what: what.into(),
        },
    };
    let size = flatbuf::u32_at(content, 0).map_err(|e| err(e.pos, "no size prefix"))? as usize;
    let fb = content
        .get(4..)
        .and_then(|b| b.get(..size))
        .ok_or_else(|| err(0, "the size prefix is larger than the packet"))?;
    let (table, ident) = Table::root(fb).map_err(|e| err(4 + e.pos, e.what))?;
    if &ident != b"EVTS" {
        return Err(err(8, "not an EventPacket (identifier `EVTS`)"));
    }
    let Some((start, n)) = table
        .vector(0, EVENT_BYTES)
        .map_err(|e| err(4 + e.pos, e.what))?
    else {
        return Ok(());
    };
    events.reserve(n);
    stamps.reserve(n);
    for (k, s) in fb[start..start + n * EVENT_BYTES]
        .chunks_exact(EVENT_BYTES)
        .enumerate()
    {
        let ts = i64::from_le_bytes(s[..8].try_into().unwrap_or_default());
        let x = i16::from_le_bytes([s[8], s[9]]);
        let y = i16::from_le_bytes([s[10], s[11]]);
        let inside = |v: i16, limit: Option<u16>| {
            u16::try_from(v)
                .ok()
                .filter(|&v| limit.is_none_or(|l| v < l))
        };
        let (Some(x), Some(y)) = (
            inside(x, geometry.map(|g| g.width)),
            inside(y, geometry.map(|g| g.height)),
        ) else {
            let at = 4 + start + k * EVENT_BYTES;
            return Err(err(
                at,
                &format!("event at ({x}, {y}) is outside the sensor"),
            ));
        };
        stamps.push(ts);
        events.push(Event {
            t_ns: 0,
            x,
            y,
            polarity: if s[12] != 0 {
                Polarity::On
            } else {
                Polarity::Off
            },
        });
    }
    Ok(())
}

/// Sets the events' times from their µs timestamps (see the module docs for the origin).
fn rebase(out: &mut Aedat4Recording, stamps: &[i64]) -> Result<(), Aedat4Error> {
    let Some(&min) = stamps.iter().min() else {
        return Ok(());
    };
    out.origin_us = if (0..RELATIVE_CLOCK_US).contains(&min) {
        0
    } else {
        min
    };
    for (e, &ts) in out.events.iter_mut().zip(stamps) {
        e.t_ns = u64::try_from(i128::from(ts) - i128::from(out.origin_us))
            .ok()
            .and_then(|us| us.checked_mul(1000))
            .ok_or_else(|| {
                data(
                    0,
                    format!("timestamp {ts} µs: the recording spans more than 584 years"),
                )
            })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_event as ev;

    fn events(n: u64) -> Vec<Event> {
        (0..n)
            .map(|i| {
                ev(
                    i * 7_321 + 40_000_000,
                    (i * 13 % 640) as u16,
                    (i % 480) as u16,
                    i % 3 == 0,
                )
            })
            .collect()
    }

    fn written(events: &[Event], compression: Compression, per_packet: usize) -> Vec<u8> {
        let mut out = Vec::new();
        let opts = WriteOptions {
            compression,
            events_per_packet: per_packet,
        };
        write(&mut out, 640, 480, events, &opts).unwrap();
        out
    }

    #[test]
    fn every_compression_round_trips_at_microsecond_resolution() {
        let events = events(5000);
        for c in Compression::ALL {
            let d = read(&written(&events, c, 1000)).unwrap();
            assert_eq!(d.compression, c);
            assert_eq!(d.packets, 5);
            assert_eq!(d.origin_us, 0);
            assert_eq!(
                d.geometry,
                Some(Geometry {
                    width: 640,
                    height: 480
                })
            );
            assert_eq!(d.events, crate::floored_to_us(&events), "{c:?}");
        }
    }

    #[test]
    fn unix_timestamps_count_from_the_first_event() {
        let t0 = 1_700_000_000_000_000u64 * 1000;
        let d = read(&written(
            &[ev(t0 + 5000, 1, 2, true), ev(t0 + 9000, 3, 4, false)],
            Compression::None,
            8,
        ))
        .unwrap();
        assert_eq!(d.origin_us, 1_700_000_000_000_005);
        assert_eq!(d.events[0].t_ns, 0);
        assert_eq!(d.events[1].t_ns, 4000);
    }

    #[test]
    fn other_streams_are_skipped_and_a_cut_data_table_is_named() {
        let mut f = written(&events(10), Compression::None, 4);
        // A foreign stream's packet (id 5) appended: skipped.
        f.extend_from_slice(&5i32.to_le_bytes());
        f.extend_from_slice(&3i32.to_le_bytes());
        f.extend_from_slice(&[1, 2, 3]);
        assert_eq!(read(&f).unwrap().events.len(), 10);
        // A header promising a data table beyond the end: the file was cut.
        let info = info_node(640, 480, Compression::None);
        let mut g = MAGIC.to_vec();
        g.extend_from_slice(&flatbuf::io_header(0, 1 << 20, &info));
        let e = read(&g).unwrap_err().to_string();
        assert!(
            e.contains("FileDataTable") && e.contains("truncated"),
            "{e}"
        );
    }

    /// Every prefix of a file, and the file with any one byte changed, either reads (a cut at a
    /// packet boundary is a shorter recording) or is refused naming a byte; none panics.
    #[test]
    fn truncated_and_corrupted_files_are_refused_naming_the_offset() {
        let events = events(300);
        for c in [Compression::None, Compression::Lz4, Compression::Zstd] {
            let f = written(&events, c, 64);
            for cut in 0..f.len() {
                match read(&f[..cut]) {
                    Ok(d) => assert!(
                        d.events.len() < events.len() && d.events.len() % 64 == 0,
                        "{c:?} cut at {cut}: {} events",
                        d.events.len()
                    ),
                    Err(e) => assert!(e.to_string().contains("byte"), "{c:?} cut at {cut}: {e}"),
                }
            }
            for at in 0..f.len() {
                for flip in [0x01u8, 0x80, 0xFF] {
                    let mut g = f.clone();
                    g[at] ^= flip;
                    if let Err(e) = read(&g) {
                        assert!(e.to_string().contains("byte"), "{c:?} flip at {at}: {e}");
                    }
                }
            }
        }
        let e = read(b"#!AER-DAT3.1\r\n").unwrap_err().to_string();
        assert!(
            e.contains("byte 0") && e.contains("not an AEDAT 4.0"),
            "{e}"
        );
    }

    #[test]
    fn bad_events_are_refused_when_writing() {
        let mut out = Vec::new();
        let opts = WriteOptions::default();
        let e = write(&mut out, 640, 480, &[ev(0, 640, 0, true)], &opts).unwrap_err();
        assert!(
            matches!(e, Aedat4Error::Events(EventsError::Outside { x: 640, .. })),
            "{e}"
        );
        let e = write(
            &mut out,
            640,
            480,
            &[ev(5, 1, 0, true), ev(4, 1, 0, true)],
            &opts,
        )
        .unwrap_err();
        assert!(
            matches!(e, Aedat4Error::Events(EventsError::NotSorted { .. })),
            "{e}"
        );
    }

    #[test]
    fn the_info_node_names_the_event_stream_and_its_size() {
        let xml = "<dv version=\"2.0\"><node name=\"outInfo\" path=\"/outInfo/\">\
            <node name=\"1\" path=\"/outInfo/1/\"><attr key=\"typeIdentifier\" type=\"string\">FRME</attr></node>\
            <node name=\"3\" path=\"/outInfo/3/\"><attr key=\"typeIdentifier\" type=\"string\">EVTS</attr>\
            <node name=\"info\" path=\"/outInfo/3/info/\"><attr key=\"sizeX\" type=\"int\">346</attr>\
            <attr key=\"sizeY\" type=\"int\">260</attr></node></node></node></dv>";
        assert_eq!(
            event_stream(xml),
            Some((
                3,
                Some(Geometry {
                    width: 346,
                    height: 260
                })
            ))
        );
        assert_eq!(event_stream("<dv></dv>"), None);
    }
}
