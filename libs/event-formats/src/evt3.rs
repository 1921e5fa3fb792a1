//! Prophesee EVT 3.0 (`.raw`): an ASCII header of `% key value` lines (ending with `% end`, or,
//! as cameras write it, at the first line that is not one), then
//! little-endian 16-bit words whose top four bits give their type (Prophesee's "EVT 3.0 format"
//! documentation, Metavision SDK):
//!
//! | type | word | payload |
//! | --- | --- | --- |
//! | 0x0 | `EVT_ADDR_Y` | y (11 bits), system type (bit 11) |
//! | 0x2 | `EVT_ADDR_X` | x (11 bits), polarity (bit 11): one event at (x, y, t) |
//! | 0x3 | `VECT_BASE_X` | base x (11 bits), polarity (bit 11) of the vectors that follow |
//! | 0x4 | `VECT_12` | 12-bit mask: events at base x + i; base x += 12 |
//! | 0x5 | `VECT_8` | 8-bit mask: events at base x + i; base x += 8 |
//! | 0x6 | `EVT_TIME_LOW` | low 12 bits of the 24-bit µs time |
//! | 0x8 | `EVT_TIME_HIGH` | high 12 bits of the 24-bit µs time |
//! | 0xA | `EXT_TRIGGER` | value (bit 0), channel (bits 8–11) |
//! | 0xE, 0xF | `OTHERS`, `CONTINUED` | skipped |
//!
//! The 24-bit time wraps every 16.78 s; the reader extends it to 64 bits by counting wraps (a
//! high part smaller than the last one), as every EVT 3.0 decoder does. Times are microseconds:
//! Waggle's nanosecond events are written at `t_ns / 1000` (floor), and read back at
//! `t_us · 1000`.
//!
//! [`StreamDecoder`] reads a headerless word stream given in pieces (ROS 2 `event_camera_msgs`
//! packets), [`read`] a whole file.
//!
//! The writer emits `TIME_HIGH`, `TIME_LOW` and `ADDR_Y` only when they change, then one
//! `ADDR_X` per event (no vectors: simple, and still ≈ 2 bytes per event in a dense stream); the
//! reader accepts vectors too, as cameras write them.

use std::io::Write;

use event_camera::{Event, Polarity};

use crate::input::{EventsError, check_events};

/// Largest coordinate EVT 3.0 can carry (11 bits).
pub const MAX_COORD: u16 = 2047;

/// Why an EVT 3.0 stream could not be written or read; reading errors name the byte offset.
#[derive(Debug, thiserror::Error)]
pub enum Evt3Error {
    #[error("writing EVT 3.0: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error("sensor {width}×{height}: EVT 3.0 carries at most 2048×2048")]
    SensorTooLarge { width: u16, height: u16 },
    #[error("header: {0}")]
    Header(String),
    #[error("byte {offset}: {what}")]
    Data { offset: usize, what: String },
}

/// What a `.raw` file says about its sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Geometry {
    pub width: u16,
    pub height: u16,
}

/// An external trigger edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trigger {
    pub t_us: u64,
    pub channel: u8,
    pub rising: bool,
}

/// A decoded `.raw` stream.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RawRecording {
    pub geometry: Option<Geometry>,
    pub events: Vec<Event>,
    pub triggers: Vec<Trigger>,
}

const ADDR_Y: u16 = 0x0;
const ADDR_X: u16 = 0x2;
const VECT_BASE_X: u16 = 0x3;
const VECT_12: u16 = 0x4;
const VECT_8: u16 = 0x5;
const TIME_LOW: u16 = 0x6;
const TIME_HIGH: u16 = 0x8;
const EXT_TRIGGER: u16 = 0xA;

fn word(kind: u16, payload: u16) -> [u8; 2] {
    ((kind << 12) | (payload & 0x0FFF)).to_le_bytes()
}

/// Writes `events` (sorted by time) of a `width`×`height` sensor as an EVT 3.0 `.raw` stream
/// with its header.
pub fn write(
    out: &mut impl Write,
    width: u16,
    height: u16,
    events: &[Event],
) -> Result<(), Evt3Error> {
    let mut encoder = StreamEncoder::new(width, height)?;
    out.write_all(encoder.header().as_bytes())?;
    let mut buf = Vec::with_capacity(events.len() * 2 + 16);
    encoder.encode(events, &mut buf)?;
    out.write_all(&buf)?;
    Ok(())
}

/// One EVT 3.0 word stream written in pieces: the pieces, concatenated, are exactly the data
/// [`write()`] writes for all their events (after the header). A piece can be made a place where
/// a decoder may start ([`StreamEncoder::restart`]): its first event then repeats `TIME_HIGH`,
/// `TIME_LOW` and `ADDR_Y`, as a camera's USB buffer does — ROS 2 `event_camera_msgs` packets
/// with `encoding: "evt3"` are such pieces.
#[derive(Debug, Clone)]
pub struct StreamEncoder {
    width: u16,
    height: u16,
    /// The last time-high written, as a monotone count (the 24-bit wraps are `high >> 12`).
    high: Option<u64>,
    low: Option<u16>,
    y_last: Option<u16>,
    previous_ns: u64,
    /// Repeat the time and row words before the next event.
    restart: bool,
}

impl StreamEncoder {
    /// An encoder for a `width`×`height` sensor (at most 2048×2048).
    pub fn new(width: u16, height: u16) -> Result<Self, Evt3Error> {
        if width == 0 || height == 0 || width > MAX_COORD + 1 || height > MAX_COORD + 1 {
            return Err(Evt3Error::SensorTooLarge { width, height });
        }
        Ok(Self {
            width,
            height,
            high: None,
            low: None,
            y_last: None,
            previous_ns: 0,
            restart: false,
        })
    }

    /// The `.raw` file header (`% …` lines through `% end`) for this sensor.
    pub fn header(&self) -> String {
        let (width, height) = (self.width, self.height);
        format!(
            "% camera_integrator_name Waggle\n% evt 3.0\n% format EVT3;height={height};width={width}\n\
             % geometry {width}x{height}\n% end\n"
        )
    }

    /// The next event written repeats `TIME_HIGH`, `TIME_LOW` and `ADDR_Y`, so a decoder that
    /// starts there (inside the same 16.78 s wrap) reads it right.
    pub fn restart(&mut self) {
        self.restart = true;
    }

    /// Appends the words of `events` (in time order, also after the events encoded before) to
    /// `buf`. On an error nothing of `events` is appended.
    pub fn encode(&mut self, events: &[Event], buf: &mut Vec<u8>) -> Result<(), Evt3Error> {
        let previous_ns = check_events(events, self.width, self.height, self.previous_ns)?;
        buf.reserve(events.len() * 2 + 8);
        for e in events {
            self.push(e, buf);
        }
        self.previous_ns = previous_ns;
        Ok(())
    }

    /// Appends the time words of `t_ns` (µs resolution) with no event: the stream's clock
    /// has reached it, which a decoder can tell from silence (a camera's stream carries its
    /// time through quiet stretches too). Later events must not be earlier.
    pub fn advance(&mut self, t_ns: u64, buf: &mut Vec<u8>) -> Result<(), Evt3Error> {
        if t_ns < self.previous_ns {
            return Err(EventsError::NotSorted {
                t_ns,
                previous_ns: self.previous_ns,
            }
            .into());
        }
        self.time_words(t_ns / 1000, buf);
        self.restart = false;
        self.previous_ns = t_ns;
        Ok(())
    }

    /// The words that set the stream's time to `t_us` (as little as changed, or all after a
    /// restart).
    fn time_words(&mut self, t_us: u64, buf: &mut Vec<u8>) {
        // The high part as a monotone count (wraps every 2^24 µs are implied by it decreasing).
        let h = t_us >> 12;
        // Each wrap of the 24-bit time crossed since the last event is written as a visible
        // decrease of the high part, so a reader counting decreases cannot miss one, however
        // long the silence.
        // The stream starts at wrap 0 (readers start counting there).
        if self.high.is_none() && h >> 12 > 0 {
            buf.extend_from_slice(&word(TIME_HIGH, 0));
        }
        for _ in (self.high.unwrap_or(0) >> 12)..(h >> 12) {
            buf.extend_from_slice(&word(TIME_HIGH, 0xFFF));
            buf.extend_from_slice(&word(TIME_HIGH, 0));
        }
        if self.restart {
            self.low = None;
            self.y_last = None;
        }
        if self.high != Some(h) || self.restart {
            buf.extend_from_slice(&word(TIME_HIGH, (h & 0xFFF) as u16));
            self.high = Some(h);
            self.low = None;
        }
        let l = (t_us & 0xFFF) as u16;
        if self.low != Some(l) {
            buf.extend_from_slice(&word(TIME_LOW, l));
            self.low = Some(l);
        }
    }

    /// The words of one checked event.
    fn push(&mut self, e: &Event, buf: &mut Vec<u8>) {
        self.time_words(e.t_ns / 1000, buf);
        self.restart = false;
        if self.y_last != Some(e.y) {
            buf.extend_from_slice(&word(ADDR_Y, e.y));
            self.y_last = Some(e.y);
        }
        let p = u16::from(e.polarity == Polarity::On) << 11;
        buf.extend_from_slice(&word(ADDR_X, e.x | p));
    }
}

/// The header's geometry and where the data starts. A header is optional (raw word streams
/// start at byte 0); see [`crate::header`] for where it ends.
fn header(bytes: &[u8]) -> Result<(Option<Geometry>, usize), Evt3Error> {
    let h = crate::header::percent_header(bytes).map_err(Evt3Error::Header)?;
    let evt3 = match (h.get("evt"), h.get("format")) {
        (Some(version), _) => Some(version == "3.0"),
        (None, Some(format)) => Some(format.starts_with("EVT3")),
        (None, None) => None,
    };
    if evt3 == Some(false) {
        return Err(Evt3Error::Header("not an EVT 3.0 stream (`% evt`)".into()));
    }
    let geometry = h
        .geometry()
        .map(|(width, height)| Geometry { width, height });
    Ok((geometry, h.data_at))
}

/// Reads an EVT 3.0 stream (header optional). Events before the first `TIME_HIGH` and the first
/// `ADDR_Y` have no time or row: they are an error, as is a trailing odd byte.
pub fn read(bytes: &[u8]) -> Result<RawRecording, Evt3Error> {
    let (geometry, start) = header(bytes)?;
    let mut out = RawRecording {
        geometry,
        ..RawRecording::default()
    };
    let mut decoder = StreamDecoder::new();
    decoder.decode(&bytes[start..], start, &mut out.events, &mut out.triggers)?;
    Ok(out)
}

/// Decodes an EVT 3.0 word stream (no header) given in pieces, e.g. the `events` of ROS 2
/// `event_camera_msgs` packets with `encoding: "evt3"`: the time, row and vector state carries
/// from one piece to the next, so the pieces decode as their concatenation does (the counterpart
/// of [`StreamEncoder`]).
#[derive(Debug, Clone, Default)]
pub struct StreamDecoder {
    high: Option<u64>,
    wraps: u64,
    low: u64,
    y: Option<u16>,
    base_x: u16,
    vect_on: bool,
}

impl StreamDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends the events and triggers of `data` (whole 16-bit words) to `events` and
    /// `triggers`. `offset` is where `data` starts in its file or message, for errors. Events
    /// before the stream's first `TIME_HIGH` or `ADDR_Y` are an error, as is an odd length.
    pub fn decode(
        &mut self,
        data: &[u8],
        offset: usize,
        events: &mut Vec<Event>,
        triggers: &mut Vec<Trigger>,
    ) -> Result<(), Evt3Error> {
        if !data.len().is_multiple_of(2) {
            return Err(Evt3Error::Data {
                offset: offset + data.len() - 1,
                what: "truncated: a 16-bit word is cut in half".into(),
            });
        }
        events.reserve(data.len() / 2);
        for (k, pair) in data.chunks_exact(2).enumerate() {
            let w = u16::from_le_bytes([pair[0], pair[1]]);
            self.word(w, offset + 2 * k, events, triggers)?;
        }
        Ok(())
    }

    /// The stream's clock after the words decoded so far, µs (`None` before its first
    /// `TIME_HIGH`): time the stream has reached even where it carried no event.
    pub fn time_us(&self) -> Option<u64> {
        self.high.map(|h| (self.wraps << 24) | (h << 12) | self.low)
    }

    fn time(&self, offset: usize) -> Result<u64, Evt3Error> {
        self.high
            .map(|h| (self.wraps << 24) | (h << 12) | self.low)
            .ok_or_else(|| Evt3Error::Data {
                offset,
                what: "event before the first EVT_TIME_HIGH".into(),
            })
    }

    fn row(&self, offset: usize) -> Result<u16, Evt3Error> {
        self.y.ok_or_else(|| Evt3Error::Data {
            offset,
            what: "event before the first EVT_ADDR_Y".into(),
        })
    }

    fn word(
        &mut self,
        w: u16,
        offset: usize,
        events: &mut Vec<Event>,
        triggers: &mut Vec<Trigger>,
    ) -> Result<(), Evt3Error> {
        let (kind, payload) = (w >> 12, w & 0x0FFF);
        let polarity = |on: bool| if on { Polarity::On } else { Polarity::Off };
        match kind {
            ADDR_Y => self.y = Some(payload & 0x7FF),
            ADDR_X => {
                let t_us = self.time(offset)?;
                events.push(Event {
                    t_ns: t_us * 1000,
                    x: payload & 0x7FF,
                    y: self.row(offset)?,
                    polarity: polarity(payload & 0x800 != 0),
                });
            }
            VECT_BASE_X => {
                self.base_x = payload & 0x7FF;
                self.vect_on = payload & 0x800 != 0;
            }
            VECT_12 | VECT_8 => {
                let n = if kind == VECT_12 { 12 } else { 8 };
                let (t_us, y) = (self.time(offset)?, self.row(offset)?);
                for i in 0..n {
                    if payload & (1 << i) != 0 {
                        events.push(Event {
                            t_ns: t_us * 1000,
                            x: self.base_x.wrapping_add(i),
                            y,
                            polarity: polarity(self.vect_on),
                        });
                    }
                }
                self.base_x = self.base_x.wrapping_add(n);
            }
            TIME_LOW => self.low = u64::from(payload),
            TIME_HIGH => {
                let h = u64::from(payload);
                if self.high.is_some_and(|last| h < last) {
                    self.wraps += 1;
                }
                self.high = Some(h);
            }
            EXT_TRIGGER => triggers.push(Trigger {
                t_us: self.time(offset)?,
                channel: ((payload >> 8) & 0xF) as u8,
                rising: payload & 1 != 0,
            }),
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_event as ev;

    #[test]
    fn vectors_and_triggers_decode_as_the_format_says() {
        let mut raw = b"% evt 3.0\n% geometry 640x480\n% end\n".to_vec();
        for w in [
            word(TIME_HIGH, 1),
            word(TIME_LOW, 5),
            word(ADDR_Y, 7),
            word(VECT_BASE_X, 100 | 0x800),
            word(VECT_12, 0b1000_0000_0101),
            word(VECT_8, 0b1000_0001),
            word(EXT_TRIGGER, 0x301),
        ] {
            raw.extend_from_slice(&w);
        }
        let d = read(&raw).unwrap();
        let t = ((1 << 12) | 5) * 1000;
        assert_eq!(
            d.geometry,
            Some(Geometry {
                width: 640,
                height: 480
            })
        );
        assert_eq!(
            d.events,
            vec![
                ev(t, 100, 7, true),
                ev(t, 102, 7, true),
                ev(t, 111, 7, true),
                ev(t, 112, 7, true),
                ev(t, 119, 7, true)
            ]
        );
        assert_eq!(
            d.triggers,
            vec![Trigger {
                t_us: (1 << 12) | 5,
                channel: 3,
                rising: true
            }]
        );
    }

    #[test]
    fn the_clock_runs_through_silence_and_across_wraps() {
        let mut encoder = StreamEncoder::new(64, 48).unwrap();
        let mut decoder = StreamDecoder::new();
        let (mut events, mut triggers, mut buf) = (Vec::new(), Vec::new(), Vec::new());
        encoder.encode(&[ev(3_000, 1, 2, true)], &mut buf).unwrap();
        // Silence to 40 ms, then across two 2^24 µs wraps, then an event again.
        for t_ns in [40_000_000, 40_000_000, 35_000_000_000] {
            encoder.advance(t_ns, &mut buf).unwrap();
            decoder.decode(&buf, 0, &mut events, &mut triggers).unwrap();
            buf.clear();
            assert_eq!(decoder.time_us(), Some(t_ns / 1000));
        }
        encoder
            .encode(&[ev(34_000_000_000, 5, 6, false)], &mut buf)
            .unwrap_err();
        encoder
            .encode(&[ev(35_000_001_000, 5, 6, false)], &mut buf)
            .unwrap();
        decoder.decode(&buf, 0, &mut events, &mut triggers).unwrap();
        assert_eq!(
            events,
            [ev(3_000, 1, 2, true), ev(35_000_001_000, 5, 6, false)]
        );
        assert!(
            encoder.advance(1_000, &mut buf).is_err(),
            "the clock never runs back"
        );
    }

    #[test]
    fn bad_streams_name_the_offset() {
        let e = read(b"% evt 3.0\n% end\n\x05").unwrap_err();
        assert!(e.to_string().contains("byte 16"), "{e}");
        let mut raw = b"% end\n".to_vec();
        raw.extend_from_slice(&word(ADDR_X, 3));
        let e = read(&raw).unwrap_err();
        assert!(
            e.to_string().contains("byte 6") && e.to_string().contains("TIME_HIGH"),
            "{e}"
        );
        assert!(read(b"% evt 2.0\n% end\n").is_err());
        // A camera's header needs no `% end`; a header line cut short is refused.
        assert!(read(b"% evt 3.0\n").unwrap().events.is_empty());
        assert!(read(b"% evt 3.0").is_err());
        let mut out = Vec::new();
        let e = write(&mut out, 640, 480, &[ev(0, 640, 0, true)]).unwrap_err();
        assert!(
            matches!(e, Evt3Error::Events(EventsError::Outside { x: 640, .. })),
            "{e}"
        );
        let e = write(&mut out, 640, 480, &[ev(5, 1, 0, true), ev(4, 1, 0, true)]).unwrap_err();
        assert!(
            matches!(e, Evt3Error::Events(EventsError::NotSorted { .. })),
            "{e}"
        );
    }
}
